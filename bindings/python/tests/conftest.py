# Shared fixtures for the penumbra Python suite: one OpenCL context, a 64x32 built-in sky, the
# built-in scene, a camera and 8 median-cut lights, so every test stays small (32x16 frames).
import os
import pathlib

import pytest

import penumbra

DATA = pathlib.Path(os.environ.get("PENUMBRA_TEST_DATA",
                                   pathlib.Path(__file__).resolve().parents[3] / "tests" / "data"))
W, H = 32, 16


@pytest.fixture(scope="session")
def data():
    return DATA


@pytest.fixture(scope="session")
def ctx():
    return penumbra.Context()


@pytest.fixture(scope="session")
def env():
    return penumbra.builtin_environment(64)


@pytest.fixture(scope="session")
def scene():
    return penumbra.builtin_scene()


@pytest.fixture(scope="session")
def camera(scene):
    return penumbra.frame_camera(scene, W / H)


@pytest.fixture(scope="session")
def lights(ctx, env):
    opt = penumbra.ExtractOptions(median_cut=penumbra.MedianCutOptions(lights=8, face_size=64))
    return penumbra.extract_lights(ctx, env, options=opt)


@pytest.fixture(scope="session")
def renderer(ctx):
    return penumbra.Renderer(ctx)


def small_options(**kw):
    opt = penumbra.RenderOptions(width=W, height=H, shadow_map_size=64)
    for k, v in kw.items():
        setattr(opt, k, v)
    return opt
