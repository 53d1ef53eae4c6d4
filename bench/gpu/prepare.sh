#!/usr/bin/env bash
# Gathers into one folder what bench/gpu/check.sh needs on a GPU machine that is not Debian and has
# no network: the built binaries (stripped), libpenumbra, every shared library they load that a
# bare glibc system lacks, an ICD file naming the NVIDIA driver's OpenCL library, and env.sh.
#
#   bench/gpu/prepare.sh BUILD_DIR OUT_DIR [--limit-mib N]
#
# glibc's own libraries (libc, libm, libpthread, libdl, librt, libresolv, ld-linux) are left out:
# they must match the machine's dynamic loader, and the NVIDIA driver links the machine's glibc.
# libstdc++/libgcc_s are copied: a newer libstdc++ serves older binaries, and a non-Debian machine
# may ship an older one that lacks GLIBCXX_3.4.30. When the folder exceeds the limit (64 MiB by
# default, what travels with a working tree), lib/ is packed into lib.tar.xz, which check.sh
# unpacks on the GPU machine; both sizes are printed.
set -euo pipefail
BUILD=${1:?usage: prepare.sh BUILD_DIR OUT_DIR [--limit-mib N]}
OUT=${2:?usage: prepare.sh BUILD_DIR OUT_DIR [--limit-mib N]}
LIMIT_MIB=64
if [[ ${3:-} == --limit-mib ]]; then LIMIT_MIB=${4:?}; fi
BUILD=$(cd "$BUILD" && pwd)
rm -rf "$OUT"; mkdir -p "$OUT/bin" "$OUT/lib" "$OUT/etc/OpenCL/vendors"
OUT=$(cd "$OUT" && pwd)

# The binaries the check runs; the GL ones only where the build made them.
bins=(penumbra tests/penumbra_tests bench/bench_frame bench/bench_bitmask bench/bench_gl gl_integration)
present=()
for b in "${bins[@]}"; do
  if [[ -x $BUILD/$b ]]; then
    cp -L "$BUILD/$b" "$OUT/bin/"; present+=("$OUT/bin/$(basename "$b")")
  else
    echo "prepare: $b not built, left out" >&2
  fi
done
cp -L "$BUILD/libpenumbra.so.0.1" "$OUT/lib/"
# The OpenImageIO module libpenumbra loads from its own directory (nothing links it, so ldd
# below does not find it; its own libraries are found through it).
module=$(cd "$BUILD" && ls libpenumbra_oiio.so.* | head -1)
cp -L "$BUILD/$module" "$OUT/lib/"
strip --strip-unneeded "${present[@]}" "$OUT/lib/libpenumbra.so.0.1" "$OUT/lib/$module"

glibc='^(libc|libm|libpthread|libdl|librt|libresolv|libutil|ld-linux-x86-64|linux-vdso)\.so'
# ldd gives the whole closure; copy each library under its SONAME (the name the loader asks for).
for f in "${present[@]}" "$OUT/lib/libpenumbra.so.0.1" "$OUT/lib/$module"; do ldd "$f"; done |
  awk '$2 == "=>" && $3 ~ /^\// {print $1, $3}' | sort -u |
  while read -r name path; do
    [[ $name =~ $glibc ]] && continue
    [[ $name == libpenumbra.so* ]] && continue
    cp -L "$path" "$OUT/lib/$name"
  done

# The ocl-icd loader reads every *.icd in OCL_ICD_VENDORS; the driver's library is found through
# the machine's own library path.
echo libnvidia-opencl.so.1 > "$OUT/etc/OpenCL/vendors/nvidia.icd"

cat > "$OUT/env.sh" <<'ENV'
# Sourced by check.sh: the folder's libraries first, the NVIDIA ICD unless OCL_ICD_VENDORS is set.
PREP_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
export LD_LIBRARY_PATH="$PREP_DIR/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export OCL_ICD_VENDORS="${OCL_ICD_VENDORS:-$PREP_DIR/etc/OpenCL/vendors}"
export PATH="$PREP_DIR/bin:$PATH"
ENV

# Paths compiled into penumbra_tests (PENUMBRA_CLI, PENUMBRA_TEST_DATA): check.sh links them to the
# folder's copies when the GPU machine's tree lies elsewhere.
{
  echo "build_dir=$BUILD"
  echo "cli=$BUILD/penumbra"
  echo "test_data=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$BUILD/CMakeCache.txt")/tests/data"
  # the newest glibc symbol version anything in the folder asks for: the GPU machine needs at least it
  echo "glibc_min=$(objdump -T "$OUT"/bin/* "$OUT"/lib/* 2>/dev/null | grep -o 'GLIBC_[0-9.]*' |
    sort -uV | tail -1)"
} > "$OUT/manifest.txt"

size() { du -sb "$1" | awk '{printf "%.1f", $1/1048576}'; }
echo "prepare: bin $(size "$OUT/bin") MiB, lib $(size "$OUT/lib") MiB ($(ls "$OUT/lib" | wc -l) files)"
if (( $(du -sb "$OUT" | cut -f1) > LIMIT_MIB * 1048576 )); then
  tar -C "$OUT" -cf - lib | xz -T2 -9 > "$OUT/lib.tar.xz"
  rm -rf "$OUT/lib"
  echo "prepare: over ${LIMIT_MIB} MiB, lib/ packed: lib.tar.xz $(size "$OUT/lib.tar.xz") MiB"
fi
echo "prepare: total $(size "$OUT") MiB in $OUT"
if (( $(du -sb "$OUT" | cut -f1) > LIMIT_MIB * 1048576 )); then
  echo "prepare: WARNING still over ${LIMIT_MIB} MiB: it cannot travel with the tree (bench/gpu/README.md)" >&2
fi
cat "$OUT/manifest.txt"
