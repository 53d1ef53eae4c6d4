import gc
import json

import numpy as np
import pytest

import penumbra
from conftest import H, W, small_options

TECHNIQUES = ["none", "hard", "pcss", "cssm", "mssm4", "mssm6", "brute", "bitmask-hard"]


@pytest.mark.parametrize("technique", TECHNIQUES)
def test_every_technique(scene, camera, lights, env, renderer, technique):
    opt = small_options(technique=technique)
    opt.brute.samples = 4
    frame = renderer.render(scene, camera, lights, env, opt)
    img = frame.image
    assert img.shape == (H, W, 4) and img.dtype == np.float32
    assert np.isfinite(img).all()
    alpha = img[..., 3]
    assert (alpha > 0.5).any() and (alpha < 0.5).any()  # geometry and sky
    assert "total" in frame.timings and all(v >= 0 for v in frame.timings.values())
    # The maps' bytes: none for no shadows, one 32-bit depth per texel and light for hard and
    # PCSS, one depth map per sample for brute force; every other technique stores more per texel.
    depth_maps = 64 * 64 * len(lights) * 4
    expected = {"none": 0, "hard": depth_maps, "pcss": depth_maps, "brute": 4 * depth_maps}
    if technique in expected:
        assert frame.shadow_map_bytes == expected[technique]
    else:
        assert frame.shadow_map_bytes > depth_maps


def test_bitmask_sampled(scene, camera, lights, env, renderer):
    opt = small_options(technique=penumbra.ShadowTechnique.BITMASK, shadow_map_size=32)
    opt.bitmask.light_samples = 128
    img = renderer.render(scene, camera, lights, env, opt).image
    assert np.isfinite(img).all()
    # Visibility only takes light away: never brighter than the unshadowed frame, darker somewhere.
    none = renderer.render(scene, camera, lights, env, small_options(technique="none")).image
    assert (img[..., :3] <= none[..., :3] + 1e-5).all()
    assert (img[..., :3] < none[..., :3] - 1e-3).any()


def test_shadows_darken(scene, camera, lights, env, renderer):
    unshadowed = renderer.render(scene, camera, lights, env, small_options(technique="none")).image
    shadowed = renderer.render(scene, camera, lights, env, small_options(technique="mssm4")).image
    geo = unshadowed[..., 3] > 0.5
    assert shadowed[geo, :3].sum() < unshadowed[geo, :3].sum()


def test_image_is_a_view(scene, camera, lights, env, renderer):
    frame = renderer.render(scene, camera, lights, env, small_options())
    a, b = frame.image, frame.image
    assert np.shares_memory(a, b)  # both are views of the frame's pixels, not copies
    del frame
    gc.collect()
    assert a.shape == (H, W, 4) and np.isfinite(a).all()  # the array keeps the frame alive


def test_options():
    o = penumbra.RenderOptions()
    assert (o.width, o.height, o.shadow_map_size) == (640, 360, 384)
    assert o.technique == penumbra.ShadowTechnique.AUTO and o.prefilter == penumbra.Prefilter.SAT
    assert (o.auto_choice.exact_lights, o.auto_choice.filtered_lights) == (0, 24)
    o.technique = "cssm"
    assert o.technique == penumbra.ShadowTechnique.CSSM
    o.technique = penumbra.ShadowTechnique.PCSS
    assert penumbra.technique_name(o.technique) == "pcss"
    assert penumbra.parse_shadow_technique("bitmask-hard") == penumbra.ShadowTechnique.BITMASK_HARD
    o.prefilter = "mip"
    assert o.prefilter == penumbra.Prefilter.MIP
    o.shadow.depth_bias = 0.01  # nested options change in place
    assert o.shadow.depth_bias == pytest.approx(0.01)
    o.mssm = penumbra.MSSMOptions(upper_bound_blocker=True, moment_bias=1e-4)
    assert o.mssm.upper_bound_blocker and o.mssm.moment_bias == pytest.approx(1e-4)
    m = o.mssm
    assert penumbra.MSSMOptions().upper_bound_blocker  # on by default, by tilt
    assert penumbra.parse_shadow_technique("auto") == penumbra.ShadowTechnique.AUTO
    o.auto_choice.exact_lights = 0
    assert o.auto_choice.exact_lights == 0 and penumbra.AutoOptions().pcss_texels == 0
    assert penumbra.AutoOptions().pcss_min_elevation_deg == 8
    assert penumbra.AutoOptions().filtered_lights == 24  # the default frame's budget
    for f in ("slope_bias", "blocker_epsilon", "delta1", "delta2", "upper_bound_tilt"):
        assert getattr(m, f) >= 0
    assert m.cosine_centroid and 0 < m.leak_reduction < 1  # on by default
    for f in ("light_size_scale", "max_filter_texels", "min_filter_texels"):
        assert getattr(o.shadow, f) >= 0
    assert o.shadow.contact_shadows and o.shadow.contact_texels == 8  # on by default
    assert o.shadow.contact_from_maps  # on by default, with contact shadows
    assert o.shadow.horizon_visibility  # on by default
    assert o.shadow.ground_visibility  # on by default
    c = penumbra.CSSMOptions(order=8)
    assert c.order == 8 and c.sharpen_a == 30 and c.sharpen_b == 80
    assert (c.ringing_offset, c.damping, c.depth_bias, c.slope_bias) == (0, 0, 0, 0)
    assert c.max_basis_bytes == 256 << 20
    p = penumbra.PCSSOptions(blocker_taps=9)
    assert (p.blocker_taps, p.filter_taps, p.receiver_plane_bias) == (9, 0, True)
    b = penumbra.BruteOptions(samples=16)
    assert b.samples == 16 and b.batch_bytes == 256 << 20
    bm = penumbra.BitmaskOptions()
    assert (bm.light_samples, bm.list_size, bm.mask_bytes) == (256, 0, 256 << 20)
    o.cssm, o.pcss, o.brute, o.bitmask = c, p, b, bm
    o.front_back_faces = True
    o.environment_background = False
    assert o.cssm.order == 8 and o.front_back_faces and not o.environment_background


def test_mip_front_back_no_background(scene, camera, lights, env, renderer):
    opt = small_options(prefilter="mip", front_back_faces=True, environment_background=False)
    img = renderer.render(scene, camera, lights, env, opt).image
    assert np.all(img[img[..., 3] < 0.5, :3] == 0)


def test_last_visibility_and_report(ctx, scene, camera, lights, env, renderer):
    ctx.reset_timings()
    frame = renderer.render(scene, camera, lights, env, small_options())
    vis = renderer.last_visibility(W, H)
    assert vis.shape == (len(lights), H, W)
    assert vis.min() >= -1e-4 and vis.max() <= 1 + 1e-4
    report = json.loads(penumbra.render_report_json(ctx, lights, env, small_options(), frame))
    assert (report["width"], report["height"], report["shadow_map_size"]) == (W, H, 64)
    assert report["lights"] == len(lights) and report["shadows"] == "auto"
    assert report["environment"] == env.source and report["sanitized_pixels"] == 0
    assert report["shadow_map_bytes"] == frame.shadow_map_bytes
    assert report["shadow_map_bytes_per_texel"] == frame.shadow_map_bytes // (64 * 64 * len(lights))
    assert report["timings_ms"]["total"] == pytest.approx(frame.timings["total"], rel=1e-5)
    # Each option lands in its own field (values that differ from every default).
    opt = small_options(technique="cssm", prefilter="mip", front_back_faces=True)
    opt.shadow.depth_bias, opt.shadow.light_size_scale, opt.shadow.max_filter_texels = 0.0125, 0.5, 9
    opt.shadow.contact_shadows, opt.shadow.contact_texels = False, 3.5
    opt.shadow.horizon_visibility = opt.shadow.ground_visibility = False
    opt.mssm.moment_bias, opt.mssm.slope_bias, opt.mssm.upper_bound_tilt = 1.5e-4, 0.75, 1.25
    opt.mssm.cosine_centroid, opt.mssm.leak_reduction = False, 0.25
    opt.cssm.order, opt.cssm.sharpen_a, opt.cssm.sharpen_b = 7, 11, 13
    opt.pcss.blocker_taps, opt.pcss.filter_taps, opt.brute.samples = 9, 25, 3
    opt.auto_choice.exact_lights, opt.auto_choice.pcss_texels = 2, 6.5
    opt.auto_choice.pcss_min_elevation_deg = 12.5
    opt.auto_choice.filtered_lights = 16
    opt.auto_choice.exact_share, opt.auto_choice.exact_half_angle_deg = 0.25, 7.5
    # The report holds the shared "shadow" block and only the block of the technique used.
    def report_for(technique):
        opt.technique = technique
        return json.loads(penumbra.render_report_json(ctx, lights, env, opt, frame))
    blocks = {"mssm", "cssm", "pcss", "brute", "bitmask", "auto", "area_approx"}
    r = report_for("cssm")
    assert r["shadows"] == "cssm" and r["prefilter"] == "mip" and r["front_back_faces"] is True
    assert (r["shadow"]["depth_bias"], r["shadow"]["light_size_scale"],
            r["shadow"]["max_filter_texels"]) == (0.0125, 0.5, 9)
    assert (r["shadow"]["contact_shadows"], r["shadow"]["contact_texels"]) == (False, 3.5)
    assert r["shadow"]["contact_maps"] is False  # needs contact shadows
    assert r["shadow"]["horizon_visibility"] is False
    assert r["shadow"]["ground_visibility"] is False
    assert (r["cssm"]["order"], r["cssm"]["sharpen_a"], r["cssm"]["sharpen_b"]) == (7, 11, 13)
    assert blocks & set(r) == {"cssm"}
    r = report_for("mssm4")
    assert (r["mssm"]["moment_bias"], r["mssm"]["slope_bias"], r["mssm"]["upper_bound_tilt"]) == \
        (1.5e-4, 0.75, 1.25)
    assert (r["mssm"]["cosine_centroid"], r["mssm"]["leak_reduction"]) == (False, 0.25)
    assert blocks & set(r) == {"mssm"}
    r = report_for("pcss")
    assert (r["pcss"]["blocker_taps"], r["pcss"]["filter_taps"]) == (9, 25)
    assert blocks & set(r) == {"pcss"}
    r = report_for("brute")
    assert r["brute"]["samples"] == 3 and blocks & set(r) == {"brute"}
    # this frame was rendered with the default, auto, whose picks bring the bitmask block (the
    # sun, a light of its own, exact: MedianCutOptions.peak_ratio, AutoOptions.exact_share) and
    # the mssm block (the seven sky lights)
    r = report_for("auto")
    assert (r["auto"]["exact_lights"], r["auto"]["pcss_texels"]) == (2, 6.5)
    assert r["auto"]["pcss_min_elevation_deg"] == 12.5
    assert r["auto"]["filtered_lights"] == 16
    assert (r["auto"]["exact_share"], r["auto"]["exact_half_angle_deg"]) == (0.25, 7.5)
    assert blocks & set(r) == {"auto", "mssm", "bitmask"}
    r = report_for("hard")
    assert blocks & set(r) == set() and "shadow" in r
    with pytest.raises(penumbra.BadInput):
        renderer.last_visibility(7, 3)


def test_animation(ctx, camera, renderer):
    env = penumbra.builtin_environment(64)
    images = []
    for i in range(2):
        env.rotation_y_deg = 30.0 * i
        ls = penumbra.extract_lights(ctx, env, lights=4, options=penumbra.ExtractOptions(
            median_cut=penumbra.MedianCutOptions(face_size=32)))
        images.append(renderer.render(penumbra.builtin_scene(0.5 * i), camera, ls, env,
                                      small_options()).image.copy())
    assert not np.array_equal(images[0], images[1])


def test_bent_normals(scene, camera, lights, env, renderer, ctx):
    o = penumbra.RenderOptions()
    assert not o.bent_normals and o.bent_normals_scale == 3  # off by default; the paper's c
    off = renderer.render(scene, camera, lights, env, small_options(technique="bitmask-hard"))
    opt = small_options(technique="bitmask-hard", bent_normals=True)
    frame = renderer.render(scene, camera, lights, env, opt)
    img = frame.image
    assert np.isfinite(img).all()
    # Shading only ever darkens (kernels/render/shade.cl), and the option does something on the
    # sphere's and torus's silhouettes.
    assert (img[..., :3] <= off.image[..., :3] + 1e-6).all()
    assert (img[..., :3] < off.image[..., :3]).any()
    report = json.loads(penumbra.render_report_json(ctx, lights, env, opt, frame))
    assert report["bent_normals"] is True and report["bent_normals_scale"] == 3
    with pytest.raises(penumbra.BadInput, match="RenderOptions.bent_normals_scale"):
        renderer.render(scene, camera, lights, env,
                        small_options(bent_normals=True, bent_normals_scale=0.0))
