#!/bin/bash
# Sourced by tools/accuracy_table.sh, tools/light_count_table.sh, tools/ground_table.sh and
# tools/peak_table.sh.
# evaluate_cached PENUMBRA_CLI SPP OUT_DIR PAIR NAME ARGS...: `penumbra evaluate` at 320x180, seed
# 11, truths cached in OUT_DIR/truths, into OUT_DIR/PAIR.NAME.json (and its console output into
# .txt); skipped when that JSON exists, written under another name until complete so that an
# interrupted run leaves no JSON to skip.
evaluate_cached() {
  local P=$1 SPP=$2 OUT=$3 pair=$4 name=$5
  shift 5
  local j="$OUT/$pair.$name.json"
  [ -f "$j" ] && return 0
  "$P" evaluate --size 320x180 --spp "$SPP" --seed 11 "$@" \
    --truth "$OUT/truths" --json "$OUT/$pair.$name.part.json" > "$OUT/$pair.$name.txt" 2>&1
  mv "$OUT/$pair.$name.part.json" "$j"
  echo "$pair $name done"
}

# Issue 13's four scene/map pairs, then four held-out ones (bench/results/accuracy.md): sets
# SCENE[pair] to the pair's scene options for data directory $1 and PAIRS to their order.
scene_pairs() {
  local D=$1
  declare -gA SCENE=(
    [builtin]=""
    [courtyard]="--env $D/envmaps/courtyard.exr --scene $D/meshes/good/WusonOBJ.obj"
    [interior]="--env $D/envmaps/interior.exr --scene $D/meshes/good/spider.obj"
    [studio]="--env $D/envmaps/studio.exr --scene $D/meshes/good/WusonOBJ.obj"
    [courtyard-spider]="--env $D/envmaps/courtyard.exr --scene $D/meshes/good/spider.obj"
    [interior-wuson]="--env $D/envmaps/interior.exr --scene $D/meshes/good/WusonOBJ.obj"
    [studio-spider]="--env $D/envmaps/studio.exr --scene $D/meshes/good/spider.obj"
    [courtyard-builtin]="--env $D/envmaps/courtyard.exr")
  PAIRS=(builtin courtyard interior studio courtyard-spider interior-wuson studio-spider
         courtyard-builtin)
}

# evaluate_pairs PENUMBRA_CLI SPP OUT_DIR: evaluate_cached for every pair of PAIRS (scene_pairs)
# with every "name|options" entry of the array CONFIGS.
evaluate_pairs() {
  local P=$1 SPP=$2 OUT=$3 s c
  for s in "${PAIRS[@]}"; do
    for c in "${CONFIGS[@]}"; do
      # shellcheck disable=SC2086
      evaluate_cached "$P" "$SPP" "$OUT" "$s" "${c%%|*}" ${SCENE[$s]} ${c#*|}
    done
  done
}
