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


def srgb_byte(linear, exposure):
    """The PNG's 8-bit value (image.hpp): exposure, Reinhard x / (1 + x) per channel, then the
    sRGB transfer function of IEC 61966-2-1, rounded."""
    x = max(0.0, linear * exposure)
    t = x / (1 + x)
    e = 12.92 * t if t <= 0.0031308 else 1.055 * t ** (1 / 2.4) - 0.055
    return int(round(min(max(e, 0.0), 1.0) * 255))


def test_png_and_exposure(tmp_path):
    values = np.array([0.0, 0.001, 0.05, 0.18, 0.5, 1.0, 3.0, 40.0], np.float32)
    img = np.stack([values, values[::-1], 0.5 * values], axis=-1).reshape(1, 8, 3)
    path = tmp_path / "a.png"
    for exposure in (1.0, 2.0):
        penumbra.write_image(str(path), img, exposure=exposure)
        png = penumbra.read_image(str(path))  # display-encoded values / 255
        assert png.shape == (1, 8, 3)
        got = np.rint(png * 255).astype(int)
        want = np.array([[[srgb_byte(float(v), exposure) for v in px] for px in img[0]]])
        assert np.array_equal(got, want), (got, want)
    assert srgb_byte(1.0, 1.0) == 188  # t = 1/2: 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354


def test_auto_exposure():
    # 0.25 over the log-average luminance (Reinhard et al. 2002, eq. 1; Rec. 709 weights) of the
    # pixels with alpha > 0.5: luminances 0.5 and 2 average to 1 in the log; the background's
    # 1000 must not count (with it the exposure would be 0.025).
    img = np.zeros((1, 3, 4), np.float32)
    img[0, 0, :3], img[0, 1, :3], img[0, 2, :3] = 0.5, 2.0, 1000.0
    img[0, :2, 3] = 1.0
    assert penumbra.auto_exposure(img) == pytest.approx(0.25, rel=2e-4)
    # Without alpha every pixel counts; a pure green pixel has luminance 0.7152 x its value.
    rgb = np.zeros((1, 2, 3), np.float32)
    rgb[0, 0, 1], rgb[0, 1, 1] = 1.0, 4.0
    assert penumbra.auto_exposure(rgb) == pytest.approx(0.25 / (0.7152 * 2.0), rel=2e-4)
