import json

import numpy as np
import pytest

import penumbra


def map_quadrature(env):
    """The map's texels as (unit direction, radiance x exact solid angle): the equirect convention
    (y up; longitude 2 pi (s / W - 1/2), colatitude pi t / H) written here, not the library's."""
    img = np.asarray(env.equirect, dtype=np.float64)
    h, w = img.shape[:2]
    th0, th1 = np.pi * np.arange(h) / h, np.pi * (np.arange(h) + 1) / h
    dw = 2 * np.pi / w * (np.cos(th0) - np.cos(th1))
    th = np.pi * (np.arange(h) + 0.5) / h
    ph = 2 * np.pi * ((np.arange(w) + 0.5) / w - 0.5)
    T, P = np.meshgrid(th, ph, indexing="ij")
    dirs = np.stack([np.sin(T) * np.sin(P), np.cos(T), -np.sin(T) * np.cos(P)], axis=-1)
    return dirs.reshape(-1, 3), (img[..., :3] * dw[:, None, None]).reshape(-1, 3)


def test_light_set_arrays(lights, env):
    assert len(lights) == len(lights.lights) > 0 and lights.method == "median-cut"
    assert lights.face_size == 64 and lights.has_ambient
    n = len(lights)
    for arr in (lights.directions, lights.powers, lights.radiances):
        assert arr.shape == (n, 3) and arr.dtype == np.float32
    assert lights.cos_alpha.shape == (n,)
    assert np.allclose(np.linalg.norm(lights.directions, axis=1), 1, atol=1e-4)
    first = lights.lights[0]
    assert np.allclose(lights.directions[0], first.direction)
    assert np.allclose(lights.powers[0], first.power)
    assert lights.cos_alpha[0] == pytest.approx(first.cos_alpha)
    assert first.solid_angle() == pytest.approx(2 * np.pi * (1 - first.cos_alpha), rel=1e-5)
    assert 0 < first.half_angle() < np.pi / 2
    assert first.regions and len(first.regions[0]) == 5
    assert all(v >= 0 for v in first.irradiance(first.direction))
    sh = lights.ambient_sh
    assert sh.shape == (9, 3) and sh.dtype == np.float32
    # Lights plus ambient would match the map for any lights (the ambient is the map minus the
    # lights), so the lights and the ambient are judged apart, against a quadrature of the map
    # written here (map_quadrature), with negative controls that must fail.
    dirs, energy = map_quadrature(env)
    power = energy.sum(axis=0)
    # Median cut's lights alone carry the map's whole power (Kneiphof 2017 eqs. 16-17; issue 4's 1%).
    # Not to 1% here: this 64x32 map is narrower than four 64-texel faces, so the cube is gathered
    # (nearest map texel per cube sub-sample), which keeps the map's power only approximately:
    # measured 1.4% short at face 64 (exact to 1e-7 at faces 8 and 16, which splat). Regression
    # bound 2%; half the lights' power (50% off) fails it.
    assert np.allclose(lights.lights_power(), power, rtol=0.02)
    assert not np.allclose(0.5 * np.asarray(lights.lights_power()), power, rtol=0.02)
    assert np.allclose(np.add(lights.lights_power(), lights.ambient_power()), lights.power())
    # The ambient alone is the map's irradiance minus the lights' (issue 4's 2% of the map's) on
    # three normals (measured 0.12% worst); an ambient that subtracted no lights, or half of each,
    # misses by more (measured 101-135% and 51-68%).
    for normal in ((0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (0.6, 0.0, -0.8)):
        e_map = (energy * np.clip(dirs @ np.asarray(normal), 0, None)[:, None]).sum(axis=0)
        e_lights = np.sum([l.irradiance(normal) for l in lights.lights], axis=0)
        amb = np.asarray(lights.ambient_irradiance(normal))
        assert np.all(np.abs(amb - (e_map - e_lights)) < 0.02 * e_map), normal
        for wrong in (e_map, e_map - 0.5 * e_lights):
            assert np.any(np.abs(amb - wrong) > 0.02 * e_map), normal
    doc = json.loads(lights.to_json())
    assert doc["method"] == "median-cut" and doc["count"] == n == len(doc["lights"])
    assert f"{n} lights" in repr(lights)


def test_methods(ctx, env):
    for method in ("median-cut", penumbra.ExtractionMethod.MEDIAN_CUT):
        s = penumbra.extract_lights(ctx, env, method=method, lights=4, ambient=False,
                                    options=penumbra.ExtractOptions(
                                        median_cut=penumbra.MedianCutOptions(face_size=32)))
        assert 1 <= len(s) <= 4 and not s.has_ambient
    g = penumbra.extract_lights(ctx, env, method="greedy", lights=8,
                                options=penumbra.ExtractOptions(greedy=penumbra.GreedyOptions(face_size=16)))
    assert g.method == "greedy" and 1 <= len(g) <= 8 and g.has_ambient
    c = penumbra.extract_lights(ctx, env, method=penumbra.ExtractionMethod.CENTER_SURROUND, lights=8,
                                options=penumbra.ExtractOptions(
                                    center_surround=penumbra.CenterSurroundOptions(width=64, sizes=4)))
    assert c.method == "center-surround" and 1 <= len(c) <= 8


def test_option_objects():
    o = penumbra.ExtractOptions()
    assert o.method == penumbra.ExtractionMethod.MEDIAN_CUT and o.ambient
    o.method = "greedy"
    assert o.method == penumbra.ExtractionMethod.GREEDY
    o.median_cut.lights = 5  # nested options are modified in place
    assert o.median_cut.lights == 5
    mc = penumbra.MedianCutOptions(lights=3, merge_across_faces=False)
    assert (mc.lights, mc.face_size, mc.merge_across_faces) == (3, 256, False)
    assert mc.min_half_angle_deg == 0 and mc.max_half_angle_deg == 85 and mc.supersample == 4
    assert mc.merge_compactness == pytest.approx(0.5)
    g = penumbra.GreedyOptions(threshold=0.05, square=False)
    assert (g.threshold, g.square, g.face_size, g.max_lights, g.supersample) == \
        (pytest.approx(0.05), False, 64, 64, 4)
    c = penumbra.CenterSurroundOptions()
    assert (c.width, c.sizes, c.max_lights) == (512, 20, 256)
    assert c.min_deg == pytest.approx(4.5) and c.max_deg == pytest.approx(45)
    assert c.inner_ratio == pytest.approx(0.75) and c.surround_weight == pytest.approx(-10)
    assert c.candidate_fraction == pytest.approx(0.1) and c.stop_fraction == pytest.approx(0.02)


def test_individual_extractors(ctx, env, tmp_path):
    mc = penumbra.extract_median_cut(ctx, env, penumbra.MedianCutOptions(lights=6, face_size=32,
                                                                         merge_across_faces=False))
    assert len(mc) == 6 and not mc.has_ambient
    penumbra.add_ambient_residual(ctx, env, mc)
    assert mc.has_ambient and np.abs(mc.ambient_sh).sum() > 0
    g = penumbra.extract_greedy(ctx, env, penumbra.GreedyOptions(face_size=16, max_lights=4))
    assert 1 <= len(g) <= 4
    cs = penumbra.extract_center_surround(ctx, env, penumbra.CenterSurroundOptions(width=64, sizes=4))
    assert len(cs) >= 1
    out = tmp_path / "overlay.png"
    penumbra.write_light_overlay(str(out), env, mc)
    assert out.stat().st_size > 0


def test_user_light_set():
    s = penumbra.LightSet()
    light = penumbra.AreaLight(direction=(0, 1, 0), cos_alpha=0.99, radiance=(1, 1, 1))
    light.power = [x * light.solid_angle() for x in light.radiance]
    s.lights = [light]
    s.ambient_sh = np.zeros((9, 3))
    s.has_ambient = False
    assert len(s) == 1 and s.lights[0].cos_alpha == pytest.approx(0.99)
    assert np.allclose(s.power(), light.power)
    with pytest.raises(penumbra.BadInput):
        s.ambient_sh = np.zeros((3, 9))


def test_polygon_lights_and_light_set_files(ctx, tmp_path):
    verts = [(0.2, 1.0, 0.1), (-0.2, 1.0, 0.1), (-0.2, 1.0, -0.1), (0.2, 1.0, -0.1)]
    verts = [tuple(np.array(v) / np.linalg.norm(v)) for v in verts]
    light = penumbra.make_polygon_light(verts, (1.0, 1.0, 1.0))
    assert light.shape == penumbra.LightShape.POLYGON and len(light.vertices) == 4
    # Lambert's formula for a small polygon straight above: E ~ radiance * solid angle.
    e = light.irradiance((0.0, 1.0, 0.0))
    assert e[0] == pytest.approx(light.solid_angle(), rel=0.03)
    dirs = penumbra.light_sample_directions(light, 64)
    assert len(dirs) == 64
    with pytest.raises(penumbra.BadInput, match="vert"):
        penumbra.make_polygon_light(verts[:2], (1.0, 1.0, 1.0))
    f = tmp_path / "set.json"
    f.write_text(json.dumps({"lights": [
        {"shape": "rect", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [10, 5],
         "radiance": [1, 1, 1]},
        {"shape": "cap", "direction": [1, 1, 0], "half_angle_deg": 4, "power": [2, 2, 2]}]}))
    s = penumbra.load_light_set(str(f))
    assert len(s) == 2 and s.lights[0].shape == penumbra.LightShape.POLYGON
    assert s.lights[1].shape == penumbra.LightShape.CAP
    again = penumbra.light_set_from_json(s.to_json())
    assert np.allclose(again.powers, s.powers, rtol=1e-5)
    f.write_text('{"lights": [{"shape": "cap", "direction": [0, 1]}]}')
    with pytest.raises(penumbra.BadInput, match="set.json"):
        penumbra.load_light_set(str(f))
    opt = penumbra.MedianCutOptions()
    opt.shape = penumbra.LightShape.POLYGON
    assert opt.shape == penumbra.LightShape.POLYGON


def test_ambient_irradiance_map(ctx, env):
    # The default ambient is the pre-integrated irradiance map: H x W x 3 float32, 128 x 64.
    o = penumbra.AmbientOptions()
    assert o.model == penumbra.AmbientModel.IRRADIANCE_MAP and (o.map_width, o.map_height) == (128, 64)
    s = penumbra.extract_lights(ctx, env, lights=4, ambient=False)
    penumbra.add_ambient_residual(ctx, env, s, penumbra.AmbientOptions(map_width=7, map_height=5))
    m = s.ambient_map
    assert m.shape == (5, 7, 3) and m.dtype == np.float32 and np.isfinite(m).all()
    # Row 0 is the +y pole: every texel of it holds the irradiance on (0, 1, 0), which lights +
    # ambient make the map's (to the host quadrature's sub-sampling).
    assert np.allclose(m[0], m[0, 0], rtol=1e-6)
    assert np.allclose(s.ambient_irradiance((0.0, 1.0, 0.0)), m[0, 0], rtol=1e-5)
    assert np.allclose(s.irradiance((0.0, 1.0, 0.0)), env.irradiance((0.0, 1.0, 0.0)), rtol=1e-3)
    doc = json.loads(s.to_json())
    assert doc["ambient_map"]["width"] == 7 and len(doc["ambient_map"]["irradiance"]) == 105
    back = penumbra.light_set_from_json(s.to_json())
    assert np.array_equal(back.ambient_map, m)
    # SH9: no table; the ambient is the SH irradiance again.
    penumbra.add_ambient_residual(ctx, env, s, penumbra.AmbientOptions(model=penumbra.AmbientModel.SH9))
    assert s.ambient_map.shape == (0, 0, 3) and "ambient_map" not in json.loads(s.to_json())
    eo = penumbra.ExtractOptions()
    eo.ambient_options.model = penumbra.AmbientModel.SH9
    assert penumbra.extract_lights(ctx, env, lights=4, options=eo).ambient_map.size == 0
    # Assigning a table: shape and values are checked.
    s.ambient_map = np.ones((2, 3, 3), np.float32)
    assert np.allclose(s.ambient_irradiance((1.0, 0.0, 0.0)), 1.0)
    with pytest.raises(penumbra.BadInput):
        s.ambient_map = np.ones((2, 3), np.float32)
    with pytest.raises(penumbra.BadInput):
        s.ambient_map = np.full((1, 1, 3), np.nan, np.float32)
    with pytest.raises(penumbra.BadInput):
        penumbra.add_ambient_residual(ctx, env, s, penumbra.AmbientOptions(map_width=0))


def test_rotate_light_set(lights):
    # A quarter turn about +y, counter-clockwise seen from above (+x towards -z), as
    # Environment.rotation_y_deg turns the map; written here as a matrix, not the library's.
    R = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    t = penumbra.rotate_light_set(lights, 90.0)
    assert len(t) == len(lights)
    assert np.allclose(t.directions, lights.directions @ R.T, atol=1e-6)
    assert np.array_equal(t.powers, lights.powers) and np.array_equal(t.cos_alpha, lights.cos_alpha)
    # 90 degrees of the 128-wide irradiance map is 32 whole columns: the rows shift exactly.
    assert np.array_equal(t.ambient_map, np.roll(lights.ambient_map, -32, axis=1))
    for n in [(1.0, 0.0, 0.0), (0.0, 0.6, 0.8), (-0.48, -0.6, 0.64)]:
        assert np.allclose(t.irradiance(tuple(R @ np.array(n))), lights.irradiance(n), rtol=1e-5)
    # whole turns: the set itself; a non-finite angle: BadInput
    assert np.array_equal(penumbra.rotate_light_set(lights, -360.0).directions, lights.directions)
    with pytest.raises(penumbra.BadInput, match="rotateLightSet"):
        penumbra.rotate_light_set(lights, float("nan"))


def test_ellipse_and_textured_lights(tmp_path):
    a, b = np.radians(30.0), np.radians(10.0)
    el = penumbra.make_ellipse_light((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (a, b), (1.0, 1.0, 1.0))
    assert el.shape == penumbra.LightShape.POLYGON and el.outline == penumbra.LightOutline.ELLIPSE
    assert len(el.vertices) == 32
    assert el.tan_half[0] == pytest.approx(np.tan(a), rel=1e-6)
    # the elliptic cone's solid angle, integrated here in polar coordinates of the unit disk:
    # ta tb * integral over phi of (1 - (1 + k)^(-1/2)) / k, k = ta^2 cos^2 + tb^2 sin^2
    ta, tb = np.tan(a), np.tan(b)
    phi = (np.arange(4096) + 0.5) * 2 * np.pi / 4096
    k = ta**2 * np.cos(phi)**2 + tb**2 * np.sin(phi)**2
    omega = ta * tb * np.mean((1 - 1 / np.sqrt(1 + k)) / k) * 2 * np.pi
    assert el.solid_angle() == pytest.approx(omega, rel=1e-6)
    rect = penumbra.make_rect_light((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (a, b), (1.0, 1.0, 1.0))
    assert rect.outline == penumbra.LightOutline.RECT
    assert el.solid_angle() < rect.solid_angle()
    with pytest.raises(penumbra.BadInput, match="half-angles"):
        penumbra.make_ellipse_light((0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (a, 0.0), (1.0, 1.0, 1.0))
    samples = penumbra.light_samples(el, 128)
    assert len(samples) == 128
    for s in samples:
        x, y = el.frame_coords(s.dir)
        assert x * x + y * y <= 1 + 1e-5 and 0 < s.weight <= 1
    # half-black texture: the left half bright, the right half black
    tex = penumbra.LightTexture(width=2, height=1, radiance=[4.0, 4.0, 4.0, 0.0, 0.0, 0.0])
    penumbra.set_light_texture(rect, tex)
    assert rect.texture.width == 2 and not rect.texture.empty()
    assert rect.power[0] == pytest.approx(2.0 * rect.solid_angle(), rel=1e-5)
    assert rect.sample_weight((-0.1, 1.0, 0.0)) == 1.0 and rect.sample_weight((0.1, 1.0, 0.0)) == 0.0
    assert rect.radiance_at((-0.1, 1.0, 0.0))[0] == 4.0
    bright = [s for s in penumbra.light_samples(rect, 256) if s.weight > 0]
    assert 0.4 < len(bright) / 256 < 0.6
    with pytest.raises(penumbra.BadInput, match="needs 12 radiance values"):
        penumbra.set_light_texture(rect, penumbra.LightTexture(width=2, height=2, radiance=[1.0] * 3))
    f = tmp_path / "tex.json"
    f.write_text(json.dumps({"lights": [
        {"shape": "ellipse", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 10],
         "texture": {"width": 2, "height": 1, "radiance": [4, 4, 4, 0, 0, 0]}},
        {"shape": "ellipse", "direction": [0, 1, 0], "up": [0, 0, 1], "half_angles_deg": [30, 95],
         "radiance": [1, 1, 1]}]}))
    with pytest.raises(penumbra.BadInput, match="tex.json: light 1"):
        penumbra.load_light_set(str(f))
    s = penumbra.light_set_from_json(json.dumps({"lights": json.loads(f.read_text())["lights"][:1]}))
    assert s.lights[0].outline == penumbra.LightOutline.ELLIPSE and s.lights[0].texture.width == 2
    again = penumbra.light_set_from_json(s.to_json())
    assert again.lights[0].texture.radiance == s.lights[0].texture.radiance
    assert np.allclose(again.powers, s.powers, rtol=1e-5)


def test_texture_lights_from_map(ctx, env):
    opt = penumbra.ExtractOptions()
    opt.median_cut.lights = 4
    opt.median_cut.face_size = 32
    plain = penumbra.extract_lights(ctx, env, options=opt)
    opt.light_texture = 4
    assert opt.light_texture == 4
    textured = penumbra.extract_lights(ctx, env, options=opt)
    assert np.allclose(textured.powers, plain.powers, rtol=1e-5)
    assert any(l.texture.width == 4 for l in textured.lights)
    opt.light_texture = 0
    again = penumbra.extract_lights(ctx, env, options=opt)
    penumbra.texture_lights_from_map(env, again, 4)
    assert [l.texture.radiance for l in again.lights] == [l.texture.radiance for l in textured.lights]
    with pytest.raises(penumbra.BadInput, match="got 0"):
        penumbra.texture_lights_from_map(env, again, 0)


def test_light_count_to_a_target_error(ctx, env):
    """ExtractOptions.target_error chooses the median-cut count (up to median_cut.lights) whose
    light_set_probe_error meets the target; fewer lights predict more error."""
    few = penumbra.extract_lights(ctx, env, lights=4)
    many = penumbra.extract_lights(ctx, env, lights=64)
    assert penumbra.light_set_probe_error(env, few) > penumbra.light_set_probe_error(env, many) > 0
    o = penumbra.ExtractOptions(target_error=0.08)
    o.median_cut.lights = 128
    chosen = penumbra.extract_lights(ctx, env, options=o)
    assert penumbra.light_set_probe_error(env, chosen) <= 0.08
    assert 4 <= len(chosen) <= 128
    with pytest.raises(penumbra.BadInput, match="median-cut"):
        penumbra.extract_lights(ctx, env, options=penumbra.ExtractOptions(target_error=0.05,
                                                                          method="greedy"))
