#!/usr/bin/env bash
# The sanitizer half of the test command (README, "Fuzzing and sanitizers"; .ci/run): builds the
# library, the CLI, the unit tests and the libFuzzer targets with AddressSanitizer + UBSan (clang,
# PENUMBRA_SANITIZE=ON) in build-san/, then runs under CTest every unit test except the oclgrind
# ones (which run in the normal build) with leak checking on, and each fuzz target: a replay of its
# regression files in tests/data/fuzz/crashes/<target>/ and a short run from its seed corpus.
# Any sanitizer report fails the run. Environment: PENUMBRA_SAN_BUILD (build directory, default
# build-san), PENUMBRA_FUZZ_SECONDS (each target's run, default 20).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${PENUMBRA_SAN_BUILD:-build-san}
seconds=${PENUMBRA_FUZZ_SECONDS:-20}

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang-14 \
  -DCMAKE_CXX_COMPILER=clang++-14 -DPENUMBRA_SANITIZE=ON -DPENUMBRA_BUILD_PYTHON=OFF \
  -DPENUMBRA_BUILD_BENCH=OFF -DPENUMBRA_FUZZ_SECONDS="$seconds"
cmake --build "$build" -j2 --target penumbra_cli penumbra_tests first_program fuzz_envmap fuzz_mesh \
  fuzz_lightset fuzz_compare

# halt_on_error: the first report ends the process, so the test that hit it fails.
# detect_leaks: LeakSanitizer at exit; tools/lsan.supp names the only leaks let through (in
# third-party code, none in penumbra's own).
# intercept_tls_get_addr=0: the sanitizer runtime of clang 14 (LLVM 17 dropped the check) takes a
# dynamic-TLS block whose start lies at offset 16 of a page for one with glibc 2.19's header and
# reads a bogus range from the two words before it; LeakSanitizer's exit scan then dies with
# "Tracer caught signal 11" after the test has passed. Where the blocks land depends on malloc, so
# the crash moved between tests from run to run (PoCL and OpenImageIO's plugins use dynamic TLS).
# Reproduced 3 of 3 by `penumbra lights --extract center-surround --stop 0.05 --sizes 8` under
# this build, clean 3 of 3 with the option. Static TLS and every other root are still scanned.
export ASAN_OPTIONS=halt_on_error=1:detect_leaks=1:intercept_tls_get_addr=0
export LSAN_OPTIONS=suppressions=$PWD/tools/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# Symbolized reports without llvm-symbolizer on PATH (Debian installs it as llvm-symbolizer-14).
if [ -x /usr/lib/llvm-14/bin/llvm-symbolizer ]; then
  export ASAN_SYMBOLIZER_PATH=/usr/lib/llvm-14/bin/llvm-symbolizer
fi
# The tests' scratch files (gtest's TempDir, the fuzz targets' mkdtemp) go to a directory of this
# build, apart from any other run of the suite on the machine.
mkdir -p "$build/tmp"
TEST_TMPDIR=$(cd "$build/tmp" && pwd)
export TEST_TMPDIR TMPDIR=$TEST_TMPDIR
# Labels left out: oclgrind (the simulator runs in the normal build), install and gl (programs
# built outside this configuration's instrumentation).
ctest --test-dir "$build" --output-on-failure -j2 -LE 'oclgrind|install|gl'
