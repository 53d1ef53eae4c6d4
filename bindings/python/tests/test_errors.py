# C++ penumbra::Error surfaces as penumbra.Error subclasses with the same message.
import math

import numpy as np
import pytest

import penumbra
from conftest import small_options


def test_hierarchy():
    assert issubclass(penumbra.Error, RuntimeError)
    for cls in (penumbra.BadInput, penumbra.NoPlatform, penumbra.KernelBuild,
                penumbra.OutOfMemory, penumbra.DeviceError, penumbra.InternalError):
        assert issubclass(cls, penumbra.Error)
        assert cls.__doc__
    assert issubclass(penumbra.BadInput, ValueError)
    assert issubclass(penumbra.OutOfMemory, MemoryError)


def test_missing_file(tmp_path):
    path = str(tmp_path / "missing.exr")
    with pytest.raises(penumbra.BadInput, match="missing.exr") as e:
        penumbra.load_environment(path)
    assert "no such file" in str(e.value)
    with pytest.raises(ValueError):
        penumbra.read_image(path)
    with pytest.raises(penumbra.BadInput, match="missing.obj"):
        penumbra.load_scene(str(tmp_path / "missing.obj"))


@pytest.mark.parametrize("name", ["not_an_image.exr", "truncated.exr"])
def test_corrupt_map(data, name):
    with pytest.raises(penumbra.BadInput, match=name):
        penumbra.load_environment(str(data / "envmaps" / "bad" / name))
    with pytest.raises(penumbra.Error, match=name):
        penumbra.environment_from(str(data / "envmaps" / "bad" / name))


def test_repaired_and_tiny_maps_load(data):
    env = penumbra.load_environment(str(data / "envmaps" / "bad" / "nan_inf_negative.exr"))
    assert env.sanitized_pixels > 0
    assert env.non_finite_values + env.negative_values > 0
    assert np.isfinite(env.equirect).all() and (env.equirect >= 0).all()
    one = penumbra.load_environment(str(data / "envmaps" / "bad" / "one_pixel.exr"))
    assert one.equirect.shape[:2] == (1, 1)


@pytest.mark.parametrize("name", ["BoxWithInfinites.glb", "IndexOutOfRange.gltf", "point_cloud.obj"])
def test_broken_mesh(data, name):
    with pytest.raises(penumbra.BadInput, match=name.split(".")[0]):
        penumbra.load_scene(str(data / "meshes" / "bad" / name))


def test_impossible_sizes(ctx, env, scene, camera, lights, renderer):
    with pytest.raises(penumbra.BadInput):
        renderer.render(scene, camera, lights, env, small_options(width=0))
    with pytest.raises(penumbra.BadInput):
        renderer.render(scene, camera, lights, env, small_options(shadow_map_size=-4))
    with pytest.raises(penumbra.BadInput):
        penumbra.cube_map_energy(ctx, env, 0)
    with pytest.raises(penumbra.BadInput):
        penumbra.extract_lights(ctx, env, lights=0)
    with pytest.raises(penumbra.BadInput):
        penumbra.extract_median_cut(ctx, env, penumbra.MedianCutOptions(face_size=100000))
    with pytest.raises(penumbra.BadInput, match="width"):
        penumbra.reference_environment(scene, camera, env,
                                       penumbra.ReferenceOptions(width=0, height=16, spp=1))
    with pytest.raises(penumbra.BadInput):
        penumbra.write_image("x.exr", np.zeros((0, 4, 3), np.float32))


def test_bad_values(tmp_path):
    with pytest.raises(penumbra.BadInput, match="bogus"):
        penumbra.parse_shadow_technique("bogus")
    with pytest.raises(penumbra.BadInput):
        penumbra.RenderOptions(technique="bogus")
    with pytest.raises(penumbra.BadInput):
        penumbra.RenderOptions(prefilter="bogus")
    with pytest.raises(penumbra.BadInput):
        penumbra.ExtractOptions(method="bogus")
    with pytest.raises(penumbra.BadInput):
        penumbra.builtin_scene(math.nan)
    with pytest.raises(penumbra.BadInput, match="--camera"):
        penumbra.parse_camera("1,2")
    with pytest.raises(penumbra.BadInput):
        penumbra.write_image(str(tmp_path / "x.bogus"), np.zeros((2, 2, 3), np.float32))
    with pytest.raises(penumbra.BadInput):
        penumbra.compare_images(np.zeros((2, 2, 4), np.float32), np.ones((3, 2, 4), np.float32))
    with pytest.raises(penumbra.BadInput):
        penumbra.write_image(str(tmp_path / "x.exr"), np.zeros((2, 2, 2, 2), np.float32))
    with pytest.raises(TypeError, match="unknown field"):
        penumbra.RenderOptions(no_such_field=1)


def test_no_device():
    with pytest.raises(penumbra.NoPlatform, match="no-such-device"):
        penumbra.Context("no-such-device")
