# The example script runs end to end at a tiny size and writes its figure.
import json
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
    assert all(r["relative_rmse"] >= 0 and r["ms"] > 0 for r in doc["results"])
    pytest.importorskip("matplotlib")
    png = tmp_path / "compare_techniques.png"
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
