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
        penumbra.builtin_scene(math.nan)
    # Library messages name the parameter or field, never a command-line flag.
    with pytest.raises(penumbra.BadInput, match=r"^camera '1,2': ") as e:
        penumbra.parse_camera("1,2")
    assert "--" not in str(e.value)
    with pytest.raises(penumbra.BadInput, match=r"^ExtractOptions\.method: unknown method 'bogus'"):
        penumbra.ExtractOptions(method="bogus")
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


def test_option_errors_name_the_python_attribute(scene, camera, lights, env, renderer):
    # The library names the C++ field (RenderOptions.areaApprox.edgeSamples); Python reports the
    # attribute path a user sets, snake case, `shadows` as `technique`.
    cases = [
        (small_options(width=0), "RenderOptions.width must be in [1, 16384], got 0"),
        (small_options(technique="cssm", cssm=penumbra.CSSMOptions(order=40)),
         "RenderOptions.cssm.order must be in [1, 32], got 40"),
        (small_options(technique="area-approx",
                       area_approx=penumbra.AreaApproxOptions(edge_samples=20)),
         "RenderOptions.area_approx.edge_samples must be in [0, 15], got 20"),
        (small_options(technique="pcss", pcss=penumbra.PCSSOptions(filter_taps=-1)),
         "RenderOptions.pcss.filter_taps must be in [0, 4096], got -1"),
        (small_options(technique="mssm6", mssm=penumbra.MSSMOptions(moment_bias=2)),
         "RenderOptions.mssm.moment_bias must be in [0, 1), got 2"),
        (small_options(shadow=penumbra.ShadowOptions(min_filter_texels=0)),
         "RenderOptions.shadow.min_filter_texels must be > 0, got 0"),
    ]
    for options, message in cases:
        with pytest.raises(penumbra.BadInput) as e:
            renderer.render(scene, camera, lights, env, options)
        assert str(e.value) == message
    # Only the technique in use checks its own options: MSSM's are not CSSM's business.
    renderer.render(scene, camera, lights, env,
                    small_options(technique="hard", mssm=penumbra.MSSMOptions(moment_bias=2)))
    with pytest.raises(penumbra.BadInput, match=r"^RenderOptions\.technique: unknown technique"):
        penumbra.parse_shadow_technique("bogus")


def test_other_errors_name_keywords_too(ctx, env, data):
    # Fields the library spells with '::' or as a LoadOptions member become what Python users
    # type: an attribute path, or load_scene's keyword.
    with pytest.raises(penumbra.BadInput,
                       match=r"^ExtractOptions\.light_texture must be 0 \(none\) or in \[1, 64\], got 100$"):
        penumbra.extract_lights(ctx, env, options=penumbra.ExtractOptions(light_texture=100))
    with pytest.raises(penumbra.BadInput, match=r"^timeout_seconds must be a finite number"):
        penumbra.load_scene(data / "meshes" / "good" / "spider.obj", timeout_seconds=math.nan)


def test_docstrings_show_the_struct_defaults():
    assert "Default 80." in penumbra.CSSMOptions.sharpen_b.__doc__
    assert "Default 3e-05." in penumbra.MSSMOptions.moment_bias.__doc__
    assert "Default 0.002." in penumbra.ShadowOptions.depth_bias.__doc__
    assert "Default 384." in penumbra.RenderOptions.shadow_map_size.__doc__
    assert "Default 'auto'." in penumbra.RenderOptions.technique.__doc__
    assert "Default 24." in penumbra.AutoOptions.filtered_lights.__doc__
    assert "Default 256 MiB." in penumbra.BruteOptions.batch_bytes.__doc__
