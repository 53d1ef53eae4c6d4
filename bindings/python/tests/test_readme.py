# The Python examples of the documentation run as written: every ```python block of README.md's
# "### Python" section and of bindings/README.md, each in a fresh directory, with the interpreter
# and package under test.
import os
import pathlib
import re
import subprocess
import sys

import pytest

import penumbra

ROOT = pathlib.Path(__file__).resolve().parents[3]


def python_blocks(text):
    return re.findall(r"^```python\n(.*?)^```$", text, flags=re.S | re.M)


def readme_python_section():
    text = (ROOT / "README.md").read_text()
    start = text.index("\n### Python\n") + len("\n### Python\n")
    end = re.search(r"^##", text[start:], flags=re.M).start() + start
    return text[start:end]


BLOCKS = [("README.md", b) for b in python_blocks(readme_python_section())] + \
    [("bindings/README.md", b) for b in python_blocks((ROOT / "bindings" / "README.md").read_text())]


def test_the_documents_have_examples():
    assert [name for name, _ in BLOCKS].count("README.md") >= 1
    assert [name for name, _ in BLOCKS].count("bindings/README.md") >= 1
    assert python_blocks("x\n```python\nprint(1)\n```\n") == ["print(1)\n"]


@pytest.mark.parametrize("index", range(len(BLOCKS)), ids=[f"{n}:{i}" for i, (n, _) in enumerate(BLOCKS)])
def test_example_runs(tmp_path, index):
    name, code = BLOCKS[index]
    (tmp_path / "example.py").write_text(code)
    # the package under test, wherever the working directory is
    env = dict(os.environ, PYTHONPATH=str(pathlib.Path(penumbra.__file__).resolve().parents[1]))
    done = subprocess.run([sys.executable, "example.py"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300, env=env)
    assert done.returncode == 0, f"{name} block {index}:\n{code}\n{done.stderr}"
    # what the examples write exists and is an image
    for written in tmp_path.glob("*.png"):
        assert written.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for written in tmp_path.glob("*.exr"):
        assert written.read_bytes()[:4] == b"\x76\x2f\x31\x01"
