#!/usr/bin/env bash
# One fuzz target's CTest run: replay every regression file of the target (each was once a crash,
# a hang or a leak; all must now pass), then fuzz for SECONDS from the seed corpus. New inputs go to
# WORK (a build directory), never into the source tree; a crash leaves crash-*/timeout-*/oom-*
# files in WORK, to be minimized and added to tests/data/fuzz/crashes/<target>/.
# Usage: run.sh FUZZER TARGET DATA_DIR WORK_DIR SECONDS
set -euo pipefail
fuzzer=$1 target=$2 data=$3 work=$4 seconds=$5
mkdir -p "$work/corpus"
# Limits every run shares: 30 s per input is a hang (a corrupt EXR attribute takes 7 s under ASan,
# most of it the sanitizer's bookkeeping of a 2 GB allocation that OpenEXR never touches; 1 s
# without), 2 GB resident is a memory blow-up.
common=(-timeout=30 -rss_limit_mb=2048)
# Leaks inside third-party readers that penumbra cannot fix (tools/lsan.supp says which and why).
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$(cd "$(dirname "$0")/../.." && pwd)/tools/lsan.supp}
# Full stacks for allocations: the fast unwinder stops at the first library built without frame
# pointers (libstdc++, OpenImageIO), and a suppression can only match frames it sees.
# intercept_tls_get_addr=0: clang 14's misreading of dynamic-TLS blocks (tools/sanitized_tests.sh
# says more) can crash LeakSanitizer's exit scan.
export ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}fast_unwind_on_malloc=0:intercept_tls_get_addr=0
dict=()
if [ -f "$(dirname "$0")/$target.dict" ]; then dict=(-dict="$(dirname "$0")/$target.dict"); fi
shopt -s nullglob
crashes=("$data/crashes/$target"/*)
if [ ${#crashes[@]} -gt 0 ]; then
  echo "replaying ${#crashes[@]} regression file(s) from $data/crashes/$target"
  "$fuzzer" "${common[@]}" "${crashes[@]}"
fi
exec "$fuzzer" "${common[@]}" "${dict[@]}" -max_total_time="$seconds" -print_final_stats=1 \
  -artifact_prefix="$work/" "$work/corpus" "$data/$target"
