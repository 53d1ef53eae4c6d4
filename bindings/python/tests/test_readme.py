# The Python examples of the documentation run as written: every ```python block of README.md's
# "### Python" section and of bindings/README.md, each as a script in an empty directory, with
# the package under test.
import pathlib
import re

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
def test_example_runs(tmp_path, monkeypatch, index):
    # In this interpreter (its OpenCL platform is up already), as a script run in an empty
    # directory: its own globals, relative paths land in tmp_path.
    name, code = BLOCKS[index]
    monkeypatch.chdir(tmp_path)
    exec(compile(code, f"{name} python block {index}", "exec"), {"__name__": "__main__"})
    written = list(tmp_path.iterdir())
    for path in written:  # what the examples write is a whole image
        if path.suffix == ".png":
            assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
            assert penumbra.read_image(path).shape[2] == 3
        elif path.suffix == ".exr":
            assert penumbra.read_image(path).shape[2] == 4
    assert written
