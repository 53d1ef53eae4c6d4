import numpy as np
import pytest

import penumbra


def test_builtin(env):
    assert env.source == "builtin" and (env.width, env.height) == (64, 32)
    eq = env.equirect
    assert eq.dtype == np.float32 and eq.shape == (32, 64, 3)
    assert env.sanitized_pixels == 0 and env.non_finite_values == 0 and env.negative_values == 0
    assert "builtin" in repr(env)


def test_equirect_is_a_view_and_settable():
    env = penumbra.builtin_environment(16)
    view = env.equirect
    view[0, 0, :] = 7.0
    assert env.equirect[0, 0, 0] == 7.0
    del env
    assert view[0, 0, 0] == 7.0  # the array keeps the environment alive
    e = penumbra.Environment()
    e.equirect = np.full((4, 8, 3), 2.0)
    assert e.equirect.shape == (4, 8, 3) and e.equirect.dtype == np.float32
    p = e.power()
    assert np.allclose(p, 2.0 * 4 * np.pi, rtol=1e-4)
    assert np.allclose(e.irradiance((0, 1, 0)), 2.0 * np.pi, rtol=0.02)  # 8x4 texels: a coarse cosine sum
    assert np.allclose(e.lookup((1, 0, 0)), 2.0)


def test_rotation(env):
    e = penumbra.builtin_environment(64)
    e.rotation_y_deg = 90.0
    assert e.rotation_y_deg == 90.0
    r = e.with_rotation_applied()
    assert r.rotation_y_deg == 0.0
    assert np.allclose(r.power(), e.power(), rtol=1e-5)
    assert not np.array_equal(r.equirect, env.equirect)
    d = (0.6, 0.3, 0.74)
    assert np.allclose(r.lookup(d), e.lookup(d))


def test_from_and_load(data):
    assert penumbra.environment_from("builtin").source == "builtin"
    path = data / "envmaps" / "courtyard.hdr"
    env = penumbra.load_environment(str(path))
    # The map holds the file's radiance as it is (an RGBE file has nothing to sanitize).
    pixels = penumbra.read_image(str(path))
    assert env.sanitized_pixels == 0
    assert env.equirect.shape == pixels.shape[:2] + (3,)
    assert np.array_equal(env.equirect, pixels[..., :3])
    assert env.source.endswith("courtyard.hdr")


def test_cube_map_energy(ctx, env):
    cube = penumbra.cube_map_energy(ctx, env, 16, supersample=2)
    assert cube.shape == (96, 16, 3) and cube.dtype == np.float32
    assert np.allclose(cube.sum(axis=(0, 1)), env.power(), rtol=1e-3)
