# What Python users expect of any package: sequences behave as sequences, paths may be
# os.PathLike, objects print their fields, images can be shown (tonemap, _repr_png_), and the
# files written say what wrote them.
import os
import pathlib
import struct

import numpy as np
import pytest

import penumbra
from conftest import H, W, small_options


class FsPath:
    """An os.PathLike that is not a pathlib.Path: only __fspath__ makes it a path."""

    def __init__(self, path):
        self.path = str(path)

    def __fspath__(self):
        return self.path


def directions(lights):
    return [tuple(l.direction) for l in lights]


def test_light_set_is_a_sequence(lights):
    n = len(lights)
    assert n >= 4
    by_property = directions(lights.lights)  # the list property, which was there before
    items = list(lights)
    assert len(items) == n and all(isinstance(l, penumbra.AreaLight) for l in items)
    assert directions(items) == by_property
    assert [tuple(lights[i].direction) for i in range(n)] == by_property
    assert tuple(lights[-1].direction) == by_property[n - 1]
    assert tuple(lights[-n].direction) == by_property[0]
    for bad in (n, n + 5, -n - 1):
        with pytest.raises(IndexError):
            lights[bad]
    # Slices are lists of lights, with Python's rules for steps and bounds.
    assert directions(lights[1:5:2]) == [by_property[1], by_property[3]]
    assert directions(lights[::-1]) == by_property[::-1]
    assert lights[n:] == [] and len(lights[-2:]) == 2
    assert directions(zip(*zip(lights)).__next__()) == by_property  # iteration ends
    with pytest.raises(TypeError):
        lights["0"]
    # Assigning an item replaces that light; other lights stay.
    s = penumbra.LightSet()
    s.lights = items[:3]
    s[-1] = items[0]
    assert directions(s) == [by_property[0], by_property[1], by_property[0]]
    with pytest.raises(IndexError):
        s[3] = items[0]
    assert len(penumbra.LightSet()) == 0 and list(penumbra.LightSet()) == []


def test_paths_may_be_pathlike(tmp_path, data, env, lights):
    img = np.random.default_rng(2).random((4, 6, 3), dtype=np.float32)
    for kind in (pathlib.Path, FsPath):
        exr = kind(tmp_path / f"a-{kind.__name__}.exr")
        penumbra.write_image(exr, img)
        assert np.allclose(penumbra.read_image(kind(os.fspath(exr))), img, atol=1e-3)
        studio = kind(data / "envmaps" / "studio.exr")
        loaded = penumbra.load_environment(studio)
        assert loaded.source.endswith("studio.exr") and loaded.width > 0
        assert penumbra.environment_from(studio).width == loaded.width
        light_json = tmp_path / f"l-{kind.__name__}.json"
        light_json.write_text(lights.to_json())
        assert len(penumbra.load_light_set(kind(light_json))) == len(lights)
        overlay = kind(tmp_path / f"overlay-{kind.__name__}.png")
        penumbra.write_light_overlay(overlay, env, lights)
        assert pathlib.Path(os.fspath(overlay)).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # Meshes load in a child process each: one load per kind of path.
    mesh = data / "meshes" / "good" / "spider.obj"
    alone = penumbra.load_scene(pathlib.Path(mesh), add_ground=False).triangle_count()
    assert penumbra.scene_from(FsPath(mesh)).triangle_count() > alone > 0  # + the ground
    with pytest.raises(penumbra.BadInput, match="missing.exr"):
        penumbra.read_image(tmp_path / "missing.exr")
    with pytest.raises(TypeError):
        penumbra.read_image(42)


def test_reprs_show_the_fields():
    # Generated from the properties, in definition order, with the struct defaults.
    r = repr(penumbra.MedianCutOptions(lights=8, face_size=64))
    assert r.startswith("MedianCutOptions(lights=8, face_size=64, supersample=4, ")
    assert "merge_compactness=0.5" in r and "shape=LightShape.CAP" in r and r.endswith(")")
    r = repr(penumbra.RenderOptions(width=64, technique="pcss"))
    assert r.startswith("RenderOptions(width=64, height=360, shadow_map_size=384, "
                        "technique=ShadowTechnique.PCSS, ")
    # Nested options print as theirs; float32 fields print their shortest form.
    assert "shadow=ShadowOptions(depth_bias=0.002, " in r and "sharpen_b=80.0" in r
    assert "moment_bias=3e-05" in r
    assert repr(penumbra.Camera(eye=[1, 2, 3], fovy_deg=50)) == \
        "Camera(eye=[1.0, 2.0, 3.0], target=[0.0, 0.0, 0.0], up=[0.0, 1.0, 0.0], fovy_deg=50.0)"
    for cls in (penumbra.ShadowOptions, penumbra.MSSMOptions, penumbra.CSSMOptions,
                penumbra.PCSSOptions, penumbra.BruteOptions, penumbra.BitmaskOptions,
                penumbra.AreaApproxOptions, penumbra.AutoOptions, penumbra.ReferenceOptions,
                penumbra.GreedyOptions, penumbra.CenterSurroundOptions, penumbra.AmbientOptions,
                penumbra.ExtractOptions, penumbra.LightTexture, penumbra.AreaLight):
        r = repr(cls())
        assert r.startswith(cls.__name__ + "(") and " at 0x" not in r, r
        # every property is named once, in order
        names = [k for k, v in vars(cls).items() if isinstance(v, property)]
        positions = [r.find(f"{name}=") for name in names]
        assert all(p > 0 for p in positions) and positions == sorted(positions), (r, names)
    # The reprs read back: every keyword a repr shows is one the constructor takes.
    o = penumbra.ReferenceOptions(width=32, spp=7, seed=9)
    assert eval(repr(o), {"ReferenceOptions": penumbra.ReferenceOptions}).spp == 7
    # The reprs tests and users matched before stay.
    assert "penumbra.Context" in repr(penumbra.Context())


def test_reprs_of_data(scene, lights, renderer, camera, env):
    mesh = scene.meshes[0]
    r = repr(mesh)
    n, t = len(mesh.positions), len(mesh.triangles)
    assert r.startswith(f"Mesh(name={mesh.name!r}, positions=<float32 array ({n}, 3)>, ")
    assert f"triangles=<int32 array ({t}, 3)>" in r
    light = lights[0]
    r = repr(light)
    assert r.startswith("AreaLight(shape=LightShape.CAP, vertices=[], direction=[")
    assert f"cos_alpha={np.float32(light.cos_alpha)!r}" in r or \
        f"cos_alpha={float(np.float32(light.cos_alpha))!r}" in r
    assert "texture=LightTexture(width=0, height=0, radiance=[])" in r
    frame = renderer.render(scene, camera, lights, env, small_options())
    r = repr(frame)
    assert r.startswith(f"Frame(image=<float32 array ({H}, {W}, 4)>, timings=")
    assert f"shadow_map_bytes={frame.shadow_map_bytes})" in r
    tex = penumbra.LightTexture(width=4, height=4, radiance=[1.0] * 48)
    assert "radiance=<list of 48>" in repr(tex)  # long lists are summarized


def srgb_byte(linear, exposure):
    """test_images.py's PNG byte: exposure, x / (1 + x), the sRGB transfer function, rounded."""
    x = max(0.0, linear * exposure)
    t = x / (1 + x)
    e = 12.92 * t if t <= 0.0031308 else 1.055 * t ** (1 / 2.4) - 0.055
    return int(round(min(max(e, 0.0), 1.0) * 255))


def test_tonemap_is_what_the_png_holds(tmp_path, scene, camera, lights, env, renderer):
    image = renderer.render(scene, camera, lights, env, small_options()).image
    auto = penumbra.auto_exposure(image)
    assert not 0.5 < auto < 2  # so that automatic and 1 differ below
    for exposure in (None, 1.0, 0.3):
        shown = penumbra.tonemap(image, exposure)
        assert shown.dtype == np.uint8 and shown.shape == (H, W, 3)
        png = tmp_path / f"f-{exposure}.png"
        penumbra.write_image(png, image, exposure=exposure)
        assert np.array_equal(shown, np.rint(penumbra.read_image(png) * 255).astype(np.uint8))
        # and each byte is the formula, written here
        e = auto if exposure is None else exposure
        for y, x in ((0, 0), (H // 2, W // 2), (H - 1, W - 3)):
            assert list(shown[y, x]) == [srgb_byte(float(v), e) for v in image[y, x, :3]]
    assert not np.array_equal(penumbra.tonemap(image), penumbra.tonemap(image, 1.0))
    # write_image's default is automatic exposure, as `penumbra render` writes PNGs.
    penumbra.write_image(tmp_path / "default.png", image)
    assert (tmp_path / "default.png").read_bytes() == (tmp_path / "f-None.png").read_bytes()
    grey = penumbra.tonemap(np.full((2, 3), 0.5, np.float32), 1.0)
    assert grey.shape == (2, 3, 3) and (grey == srgb_byte(0.5, 1.0)).all()
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(penumbra.BadInput, match="exposure"):
            penumbra.tonemap(image, bad)
        with pytest.raises(penumbra.BadInput, match="exposure"):
            penumbra.write_image(tmp_path / "x.png", image, exposure=bad)


def png_size(data):
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_frame_repr_png(tmp_path, scene, camera, lights, env, renderer):
    frame = renderer.render(scene, camera, lights, env, small_options())
    data = frame._repr_png_()
    assert isinstance(data, bytes) and png_size(data) == (W, H)
    # The same pixels write_image puts in a PNG with automatic exposure.
    path = tmp_path / "shown.png"
    path.write_bytes(data)
    assert np.array_equal(np.rint(penumbra.read_image(path) * 255).astype(np.uint8),
                          penumbra.tonemap(frame.image))


def exr_attributes(path):
    """The header attributes of an OpenEXR file (single part), by the file format: magic,
    version, then (name, type, size, value) until an empty name; strings and doubles decoded."""
    data = pathlib.Path(path).read_bytes()
    assert data[:4] == b"\x76\x2f\x31\x01"
    at, out = 8, {}
    while data[at] != 0:
        name_end = data.index(b"\0", at)
        type_end = data.index(b"\0", name_end + 1)
        name, kind = data[at:name_end].decode(), data[name_end + 1:type_end].decode()
        size = struct.unpack("<i", data[type_end + 1:type_end + 5])[0]
        value = data[type_end + 5:type_end + 5 + size]
        if kind == "string":
            out[name] = value.decode()
        elif kind == "double":
            out[name] = struct.unpack("<d", value)[0]
        else:
            out[name] = (kind, value)
        at = type_end + 5 + size
    return out


def test_exr_says_what_wrote_it(tmp_path):
    path = tmp_path / "m.exr"
    penumbra.write_image(path, np.ones((2, 2, 3), np.float32),
                         metadata={"penumbra:note": "a test", "penumbra:spp": 64})
    attrs = exr_attributes(path)
    assert attrs["penumbra:version"] == penumbra.__version__
    assert attrs["penumbra:command"] == "python"
    assert attrs["penumbra:note"] == "a test" and attrs["penumbra:spp"] == 64.0
    assert penumbra.read_image(path).shape == (2, 2, 3)
    with pytest.raises(penumbra.BadInput, match=r"metadata\['x'\]"):
        penumbra.write_image(path, np.ones((2, 2, 3), np.float32), metadata={"x": [1]})
