#!/usr/bin/env bash
# Installs the build into a fresh prefix, then builds and runs tests/consumer against it twice:
# through find_package(penumbra) and through pkg-config; runs the installed CLI, and imports the
# installed Python module from outside the source tree. Usage: run.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
src=$(cd "$2" && pwd)
work="$build/consumer-test"
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
cmake -S "$src/tests/consumer" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release > "$work/configure.log"
cmake --build "$work/build" > "$work/build.log"
# the installed library is found through the consumer's build RPATH (CMake adds it)
"$work/build/consumer"
libdir=$(dirname "$(find "$work/prefix" -name penumbra.pc | head -1)")
PKG_CONFIG_PATH="$libdir" c++ -std=c++17 "$src/tests/consumer/main.cpp" -o "$work/consumer-pc" \
  $(PKG_CONFIG_PATH="$libdir" pkg-config --cflags --libs penumbra)
LD_LIBRARY_PATH="$(dirname "$libdir")" "$work/consumer-pc"
# the installed CLI runs from the prefix (its RPATH points at ../lib)
"$work/prefix/bin/penumbra" --version
"$work/prefix/bin/penumbra" render --size 32x18 --out "$work/cli.png" > /dev/null
test -s "$work/cli.png"
# the installed Python package imports from outside the source tree and makes a map
pkg=$(find "$work/prefix" -path '*python*' -path '*/penumbra/__init__.py' | head -1)
if [ -z "$pkg" ]; then echo "run.sh: no installed Python package under $work/prefix" >&2; exit 1; fi
(cd "$work" && PYTHONPATH="$(dirname "$(dirname "$pkg")")" /usr/bin/python3 -c "
import penumbra
assert penumbra.__file__.startswith('$work/prefix'), penumbra.__file__
assert penumbra._penumbra.__file__.startswith('$work/prefix'), penumbra._penumbra.__file__
env = penumbra.builtin_environment(64)
print('python module', penumbra.__file__, 'version', getattr(penumbra, '__version__', '?'))
")
