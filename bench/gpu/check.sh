#!/usr/bin/env bash
# The GPU check of issue 18, run from a folder made by bench/gpu/prepare.sh: the device list, the
# GoogleTest suite on the chosen device (oclgrind-only tests left out), bench_frame, bench_bitmask
# at 128 and 1024 samples, bench_gl (EGL, surfaceless). Every step is bounded by `timeout` so the
# whole run stays within about 8 minutes; a step that fails or times out is recorded and the next
# one still runs. Writes OUT/summary.json and OUT/summary.md (bench/gpu/summarize.py), and each
# step's log and Google Benchmark/Test JSON beside them.
#
#   bench/gpu/check.sh [--device SELECTOR] [--quick] [--prep DIR] [--out DIR] [--vendors DIR]
#
# --device: PENUMBRA_DEVICE for every step (an index or a name fragment; default: device 0).
# --quick: a small subset (a few test suites, one frame configuration) for a dry run on PoCL.
# --prep: the prepared folder (default bench/gpu/prepared). --out: default $OUT, else
# /tmp/penumbra-gpu-check. --vendors: the ICD folder (default the prepared one, naming the NVIDIA
# driver; the PoCL dry run passes /etc/OpenCL/vendors).
set -uo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
REPO=$(cd "$HERE/../.." && pwd)
DEVICE="" QUICK=0 PREP="$HERE/prepared" RESULTS="${OUT:-/tmp/penumbra-gpu-check}" VENDORS=""
while (($#)); do
  case $1 in
    --device) DEVICE=$2; shift 2 ;;
    --quick) QUICK=1; shift ;;
    --prep) PREP=$2; shift 2 ;;
    --out) RESULTS=$2; shift 2 ;;
    --vendors) VENDORS=$2; shift 2 ;;
    *) echo "check.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
PREP=$(cd "$PREP" && pwd) || { echo "check.sh: no prepared folder" >&2; exit 2; }
mkdir -p "$RESULTS"; RESULTS=$(cd "$RESULTS" && pwd)
[[ -n $VENDORS ]] && export OCL_ICD_VENDORS=$VENDORS
# lib.tar.xz: prepare.sh packed lib/ to fit the 64 MiB a working tree carries.
if [[ ! -d $PREP/lib && -f $PREP/lib.tar.xz ]]; then
  echo "check.sh: unpacking lib.tar.xz"; tar -C "$PREP" -xJf "$PREP/lib.tar.xz"
fi
# shellcheck source=/dev/null
source "$PREP/env.sh"
export PENUMBRA_DEVICE=$DEVICE
[[ -z $DEVICE ]] && unset PENUMBRA_DEVICE
export EGL_PLATFORM=${EGL_PLATFORM:-surfaceless}

# penumbra_tests names the CLI and the test data by their build-machine paths; where this tree
# lies elsewhere, link those paths to the folder's CLI and this tree's tests/data.
cli=$(sed -n 's/^cli=//p' "$PREP/manifest.txt") data=$(sed -n 's/^test_data=//p' "$PREP/manifest.txt")
for pair in "$cli:$PREP/bin/penumbra" "$data:$REPO/tests/data"; do
  want=${pair%%:*} have=${pair#*:}
  if [[ ! -e $want ]]; then
    mkdir -p "$(dirname "$want")" 2>/dev/null && ln -s "$have" "$want" 2>/dev/null &&
      echo "check.sh: linked $want -> $have" || echo "check.sh: cannot create $want; tests that use it fail"
  fi
done

: > "$RESULTS/steps.tsv"
# step NAME LIMIT_S CMD...: runs CMD under timeout, logs to NAME.log, records exit code and seconds.
step() {
  local name=$1 limit=$2; shift 2
  echo "== $name (limit ${limit}s): $*"
  local t0 t1 rc secs
  t0=$EPOCHREALTIME  # bash 5; awk does the arithmetic (bc may be missing on the GPU machine)
  timeout -k 10 "$limit" "$@" > "$RESULTS/$name.log" 2>&1; rc=$?
  t1=$EPOCHREALTIME
  secs=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }')
  printf '%s\t%s\t%s\t%s\n' "$name" "$rc" "$secs" "$limit" >> "$RESULTS/steps.tsv"
  echo "   exit $rc, $secs s"
  tail -n 3 "$RESULTS/$name.log" | sed 's/^/   | /'
}
bench() {  # bench NAME LIMIT BINARY FILTER: Google Benchmark with its JSON written beside the log
  step "$1" "$2" "$PREP/bin/$3" --benchmark_filter="$4" \
    --benchmark_out="$RESULTS/$1.json" --benchmark_out_format=json
}

if ((QUICK)); then
  tests='Context.*:Frame.*:MSSM4.*:BitmaskDeterminism.*:CliDevices.*:-Oclgrind*'
  frame='BM_FrameUnshadowed/|BM_FrameMSSM4/32/384/'
  bitmask='BM_BitmaskSamples/128/'  # 1024 samples take over a minute on 2 PoCL cores
  gl='BM_FrameGL/0'
else
  bitmask='BM_BitmaskSamples/(128|1024)/'
  tests='-Oclgrind*'
  frame='.'
  gl='.'
fi
step devices 60 "$PREP/bin/penumbra" devices
step tests 270 "$PREP/bin/penumbra_tests" --gtest_filter="$tests" --gtest_output="json:$RESULTS/tests.json"
bench bench_frame 90 bench_frame "$frame"
bench bench_bitmask 60 bench_bitmask "$bitmask"
[[ -x $PREP/bin/bench_gl ]] && bench bench_gl 60 bench_gl "$gl"

# Whichever python3 the machine has: summarize.py uses the standard library only.
PY=$(command -v python3 || echo /usr/bin/python3)
"$PY" "$HERE/summarize.py" "$RESULTS" --device "${DEVICE}" --quick "$QUICK"
