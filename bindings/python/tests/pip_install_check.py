"""CTest python_pip_install: `pip install --no-build-isolation --no-deps --prefix <tmp> <source>`
with the system's setuptools, reusing the CMake build tree (PENUMBRA_CMAKE_BUILD_DIR), then
imports penumbra from that prefix alone (PYTHONPATH is the prefix's site directory and nothing
else, run outside the source tree) and checks what pip installed: the package with its stubs,
the metadata (version from CMake's project(), numpy declared), and that the extension loads the
libpenumbra installed beside it, not the build tree's.

Usage: pip_install_check.py SOURCE_DIR BUILD_DIR (run with the interpreter the build is for)."""
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile

CHECK = r'''
import importlib.metadata as md
import pathlib
import sys

import penumbra

site, version = pathlib.Path(sys.argv[1]), sys.argv[2]
for f in (penumbra.__file__, penumbra._penumbra.__file__):
    assert pathlib.Path(f).resolve().is_relative_to(site), f
assert penumbra.__version__ == version, (penumbra.__version__, version)
assert md.version("penumbra") == version, md.version("penumbra")
assert md.requires("penumbra") == ["numpy"], md.requires("penumbra")
assert md.metadata("penumbra")["Requires-Python"], "no Requires-Python"
dist = md.distribution("penumbra")
assert pathlib.Path(dist.locate_file("penumbra")).resolve().is_relative_to(site)
files = {str(f) for f in dist.files}
for name in ("penumbra/__init__.py", "penumbra/__init__.pyi", "penumbra/py.typed"):
    assert name in files, (name, sorted(files))
# The library the extension runs on is the copy in the package.
libs = {line.split()[-1] for line in open("/proc/self/maps") if "libpenumbra.so" in line}
assert libs and all(pathlib.Path(l).resolve().is_relative_to(site) for l in libs), libs
assert penumbra.builtin_environment(16).width == 16
# Images go through the OpenImageIO module libpenumbra loads from its own directory: the package
# carries it, and `import penumbra` alone does not load OpenImageIO.
assert not any("libOpenImageIO" in line for line in open("/proc/self/maps"))
import numpy as np
import tempfile
with tempfile.TemporaryDirectory() as tmp:
    penumbra.write_image(tmp + "/a.exr", np.full((3, 5, 3), 0.5, np.float32))
    assert penumbra.read_image(tmp + "/a.exr").shape == (3, 5, 3)
codecs = {line.split()[-1] for line in open("/proc/self/maps") if "libpenumbra_oiio.so" in line}
assert codecs and all(pathlib.Path(l).resolve().is_relative_to(site) for l in codecs), codecs
print("pip_install_check: penumbra", version, "from", site)
'''


def main():
    src, build = (pathlib.Path(a).resolve() for a in sys.argv[1:3])
    version = re.search(r'#define PENUMBRA_VERSION "([^"]+)"',
                        (build / "generated/include/penumbra/version.hpp").read_text()).group(1)
    with tempfile.TemporaryDirectory(prefix="penumbra-pip-") as tmp:
        prefix = pathlib.Path(tmp) / "prefix"
        env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "PIP_"))}
        env["PENUMBRA_CMAKE_BUILD_DIR"] = str(build)
        subprocess.run([sys.executable, "-m", "pip", "install", "--no-build-isolation", "--no-deps",
                        "--no-index", "--no-cache-dir", "--disable-pip-version-check", "--quiet",
                        "--prefix", str(prefix), str(src)], check=True, env=env, cwd=tmp)
        inits = list(prefix.rglob("penumbra/__init__.py"))
        assert len(inits) == 1, inits
        site = inits[0].parent.parent
        clean = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "PYTHONPATH": str(site),
                 "PYTHONNOUSERSITE": "1", "PYTHONDONTWRITEBYTECODE": "1"}
        for key in ("PENUMBRA_DEVICE", "OCL_ICD_VENDORS", "POCL_DEVICES", "HOME"):
            if key in os.environ:
                clean[key] = os.environ[key]
        try:
            subprocess.run([sys.executable, "-c", CHECK, str(site), version], check=True,
                           env=clean, cwd=tmp)
        finally:
            # setup.py's staging inside the reused tree (setuptools/, penumbra.egg-info): copies
            # that would go stale
            shutil.rmtree(build / "setuptools", ignore_errors=True)
            shutil.rmtree(build / "penumbra.egg-info", ignore_errors=True)


if __name__ == "__main__":
    main()
