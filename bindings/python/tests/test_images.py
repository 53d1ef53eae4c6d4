import numpy as np
import pytest

import penumbra


def test_exr_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    img = rng.random((16, 32, 4), dtype=np.float32)
    path = str(tmp_path / "a.exr")
    penumbra.write_image(path, img)
    back = penumbra.read_image(path)
    assert back.dtype == np.float32 and back.shape == (16, 32, 4)
    assert np.allclose(back, img, rtol=1e-3, atol=1e-3)  # EXR may store half
    # The returned array owns its pixels through a capsule: no copy, writable.
    assert back.base is not None and back.flags.writeable


def test_inputs_are_cast(tmp_path):
    gray = np.linspace(0, 1, 64, dtype=np.float64).reshape(8, 8)  # (H, W), float64
    path = str(tmp_path / "g.exr")
    penumbra.write_image(path, gray)
    back = penumbra.read_image(path)
    assert back.shape[:2] == (8, 8)
    assert np.allclose(back[..., 0], gray, atol=1e-3)
    penumbra.write_image(str(tmp_path / "t.exr"), np.ones((8, 4, 3), np.float32).transpose(1, 0, 2))


def test_png_and_exposure(tmp_path):
    img = np.full((8, 8, 3), 0.5, np.float32)
    path = tmp_path / "a.png"
    penumbra.write_image(str(path), img, exposure=2.0)
    png = penumbra.read_image(str(path))
    assert png.shape == (8, 8, 3)
    assert 0.0 < penumbra.auto_exposure(img) < np.inf
