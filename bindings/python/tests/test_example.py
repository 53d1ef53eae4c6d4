# The example script runs end to end at a tiny size and writes its figure.
import json
import math
import pathlib
import subprocess
import sys

import pytest

SCRIPT = pathlib.Path(__file__).resolve().parents[1] / "examples" / "compare_techniques.py"


def test_compare_techniques(tmp_path):
    subprocess.run([sys.executable, str(SCRIPT), "--out-dir", str(tmp_path), "--size", "32x16",
                    "--lights", "4", "--shadow-map-size", "64", "--spp", "4", "--repeat", "1",
                    "--techniques", "hard,pcss,mssm4"], check=True, timeout=120)
    doc = json.loads((tmp_path / "compare_techniques.json").read_text())
    assert [r["technique"] for r in doc["results"]] == ["hard", "pcss", "mssm4"]
    # The figures describe the run that was asked for, and each technique's error is a real
    # difference from the 4-sample truth (its noise alone is about 30% relative RMSE at this size).
    assert (doc["size"], doc["lights"], doc["shadow_map_size"], doc["spp"]) == ([32, 16], 4, 64, 4)
    for r in doc["results"]:
        assert 0 < r["relative_rmse"] < 10 and math.isfinite(r["psnr"]) and r["ms"] > 0
        assert r["device_ms"]["total"] > 0
    pytest.importorskip("matplotlib")
    png = tmp_path / "compare_techniques.png"
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
