"""Builds the `penumbra` Python package with CMake (pyproject.toml holds the metadata).

`pip install .` runs build_ext below: it configures the CMake project in a build directory of its
own (tests and benchmarks off, this interpreter's Python), builds the `penumbra_python` target,
and copies the extension, libpenumbra and its OpenImageIO module into the package with the extension's RPATH set to
$ORIGIN, so the installed package needs nothing from the build tree. The pure files
(bindings/python/penumbra: __init__.py, __init__.pyi, py.typed) are packed as they are.

PENUMBRA_CMAKE_BUILD_DIR=<dir> reuses an existing, configured build tree instead (CTest's
python_pip_install does, so the test compiles nothing again): only the target is brought up to
date there. The version is project(VERSION) in CMakeLists.txt, the one place it is set.
"""
import os
import pathlib
import re
import shutil
import subprocess
import sys
import sysconfig

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = pathlib.Path(__file__).resolve().parent


def cmake_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    m = re.search(r"project\(\s*penumbra\s+VERSION\s+([0-9][0-9.]*)", text)
    if not m:
        sys.exit("setup.py: no project(penumbra VERSION x.y.z) in CMakeLists.txt")
    return m.group(1)


def run(cmd):
    print("setup.py:", " ".join(str(c) for c in cmd), flush=True)
    subprocess.run([str(c) for c in cmd], check=True)


class CMakeBuild(build_ext):
    """build_ext for the one extension, penumbra._penumbra, made by CMake."""

    def build_extension(self, ext):
        if REUSED:
            build = pathlib.Path(REUSED).resolve()
            if not (build / "CMakeCache.txt").exists():
                sys.exit(f"setup.py: PENUMBRA_CMAKE_BUILD_DIR={REUSED} is not a configured "
                         "CMake build tree (no CMakeCache.txt)")
        else:
            build = pathlib.Path(self.build_temp).resolve() / "cmake"
            run(["cmake", "-S", ROOT, "-B", build, "-DCMAKE_BUILD_TYPE=Release",
                 "-DPENUMBRA_BUILD_TESTS=OFF", "-DPENUMBRA_BUILD_BENCH=OFF",
                 "-DPENUMBRA_BUILD_PYTHON=ON", f"-DPYTHON_EXECUTABLE={sys.executable}"])
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL") or str(os.cpu_count() or 1)
        run(["cmake", "--build", build, "--target", "penumbra_python", "-j", jobs])

        # bindings/python/CMakeLists.txt lists the extension and the library (by SONAME).
        listed = (build / "bindings" / "python" / "package_files.txt").read_text().split()
        module, library, codec = (pathlib.Path(p) for p in listed[:3])
        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        if not module.name.endswith(suffix):
            sys.exit(f"setup.py: {module.name} was built for another Python than "
                     f"{sys.executable} (extension suffix {suffix}); reconfigure "
                     f"{build} with -DPYTHON_EXECUTABLE={sys.executable}")
        target = pathlib.Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(module, target)
        shutil.copyfile(library, target.parent / library.name)  # the file, not the symlink
        # libpenumbra loads its OpenImageIO module from its own directory.
        shutil.copyfile(codec, target.parent / codec.name)
        # The copies find libpenumbra beside themselves: CMake's own ELF editor rewrites the RPATH
        # (file(RPATH_SET), CMake >= 3.21), so no patchelf is needed.
        script = pathlib.Path(self.build_temp).resolve() / "set_rpath.cmake"
        script.parent.mkdir(parents=True, exist_ok=True)
        script.write_text('file(RPATH_SET FILE "${FILE}" NEW_RPATH "$ORIGIN")\n')
        for packed in (target, target.parent / codec.name):
            run(["cmake", f"-DFILE={packed}", "-P", script])


# With a reused build tree, setuptools' own build directory and egg-info go inside it too, not
# into the source tree.
REUSED = os.environ.get("PENUMBRA_CMAKE_BUILD_DIR")
OPTIONS = {}
if REUSED:
    OPTIONS = {"build": {"build_base": str(pathlib.Path(REUSED).resolve() / "setuptools")},
               "egg_info": {"egg_base": str(pathlib.Path(REUSED).resolve())}}

setup(
    version=cmake_version(),
    options=OPTIONS,
    packages=["penumbra"],
    package_dir={"": "bindings/python"},
    package_data={"penumbra": ["__init__.pyi", "py.typed"]},
    ext_modules=[Extension("penumbra._penumbra", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    zip_safe=False,
)
