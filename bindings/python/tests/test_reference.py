import json
import math

import numpy as np
import pytest

import penumbra
from conftest import H, W, small_options


def test_reference_options():
    o = penumbra.ReferenceOptions()
    assert (o.width, o.height, o.spp, o.seed, o.threads, o.environment_background) == \
        (640, 360, 256, 1, 0, True)


def test_reference_and_compare(scene, camera, lights, env, renderer):
    ro = penumbra.ReferenceOptions(width=W, height=H, spp=16, threads=2)
    ref_l = penumbra.reference_lights(scene, camera, lights, env, ro)
    ref_e = penumbra.reference_environment(scene, camera, env, ro)
    for ref in (ref_l, ref_e):
        assert ref.shape == (H, W, 4) and ref.dtype == np.float32 and np.isfinite(ref).all()
    assert np.array_equal(penumbra.reference_lights(scene, camera, lights, env, ro), ref_l)

    img = renderer.render(scene, camera, lights, env, small_options(technique="mssm4")).image
    m = penumbra.compare_images(img, ref_l)
    assert m.pixels == int((ref_l[..., 3] > 0.5).sum())
    assert 0 < m.relative_rmse < 0.5 and m.rmse > 0 and m.max_abs_error >= m.rmse
    assert math.isfinite(m.psnr)
    doc = json.loads(m.to_json())
    assert doc["pixels"] == m.pixels and doc["relative_rmse"] == pytest.approx(m.relative_rmse)

    same = penumbra.compare_images(ref_l, ref_l)
    assert same.rmse == 0 and same.psnr == math.inf and "ImageMetrics" in repr(same)
    assert json.loads(same.to_json())["psnr"] is None

    bad = ref_l.copy()
    bad[ref_l[..., 3] > 0.5] = np.nan
    with pytest.raises(penumbra.BadInput, match="non-finite"):
        penumbra.compare_images(bad, ref_l)
