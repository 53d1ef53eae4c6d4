#!/bin/bash
# The accuracy table of bench/results/accuracy.md: `penumbra evaluate` on the four scenes of
# issue 13 at 320x180 for every configuration below, each against an Embree environment truth of
# SPP samples per pixel (its own noise estimated from two half sample sets and printed beside
# every figure), and the light-set floor (Embree, exact visibility of the same lights).
# usage: tools/accuracy_table.sh PENUMBRA_CLI DATA_DIR OUT_DIR [SPP]
#   DATA_DIR: the shared test data (envmaps/, meshes/good/); OUT_DIR gets truths/ (a cache that
#   later runs reuse), one JSON per scene and configuration, and table.md.
set -euo pipefail
P=$1; D=$2; OUT=$3; SPP=${4:-4096}
mkdir -p "$OUT/truths"
declare -A SCENE=(
  [builtin]=""
  [courtyard]="--env $D/envmaps/courtyard.exr --scene $D/meshes/good/WusonOBJ.obj"
  [interior]="--env $D/envmaps/interior.exr --scene $D/meshes/good/spider.obj"
  [studio]="--env $D/envmaps/studio.exr --scene $D/meshes/good/WusonOBJ.obj")
# The table is of 32 lights (the default until 2026-12-05) and `auto` at its defaults then.
COMMON="--lights 32 --auto-exact 1 --auto-filtered -1"
CONFIGS=(
  "hard|--shadows hard"
  "pcss|--shadows pcss"
  "hard-nocontact|--shadows hard --no-contact-shadows"
  "mssm4-eq7|--shadows mssm4 --no-upper-bound --no-contact-shadows"
  "mssm4-nocontact|--shadows mssm4 --no-contact-shadows"
  "hard-nohorizon|--shadows hard --no-horizon-visibility"
  "mssm4-nohorizon|--shadows mssm4 --no-horizon-visibility"
  "mssm4-axis|--shadows mssm4 --no-cosine-centroid --leak-reduction 0"
  "mssm4-nocentroid|--shadows mssm4 --no-cosine-centroid"
  "mssm4-noleak|--shadows mssm4 --leak-reduction 0"
  "hard-256|--shadows hard --shadow-map-size 256"
  "mssm4-256|--shadows mssm4 --shadow-map-size 256"
  "mssm4|--shadows mssm4"
  "mssm4-512|--shadows mssm4 --shadow-map-size 512"
  "auto-exact0|--shadows auto --auto-exact 0"
  "auto|--shadows auto")
# shellcheck source=tools/evaluate_cached.sh
. "$(dirname "$0")/evaluate_cached.sh"
for s in builtin courtyard interior studio; do
  for c in "${CONFIGS[@]}"; do
    # shellcheck disable=SC2086
    evaluate_cached "$P" "$SPP" "$OUT" "$s" "${c%%|*}" ${SCENE[$s]} $COMMON ${c#*|}
  done
done
/usr/bin/python3 - "$OUT" <<'PY'
import json, sys, os
out = sys.argv[1]
scenes = ["builtin", "courtyard", "interior", "studio"]
configs = ["hard-nocontact", "hard-nohorizon", "hard-256", "hard", "pcss", "mssm4-eq7", "mssm4-nocontact", "mssm4-nohorizon", "mssm4-axis", "mssm4-nocentroid", "mssm4-noleak", "mssm4-256", "mssm4", "mssm4-512", "auto-exact0", "auto"]
def load(s, c):
    with open(os.path.join(out, f"{s}.{c}.json")) as f: return json.load(f)
rows = ["Total error against the environment truth over all geometry pixels: relative RMSE / mean HDR-FLIP.",
        "", "| scene | truth noise | floor (exact visibility, same lights) | " + " | ".join(configs) + " |",
        "| --- | --- | --- | " + " | ".join("---" for _ in configs) + " |"]
for s in scenes:
    b = [load(s, c) for c in configs]
    fl = b[0]["floor"]
    cells = [f"{x['total']['relative_rmse']*100:.2f}% / {x['total']['flip']:.4f}" for x in b]
    rows.append(f"| {s} | {b[0]['truth_noise']['environment']*100:.2f}% | {fl['relative_rmse']*100:.2f}% / {fl['flip']:.4f} | " + " | ".join(cells) + " |")
def section(title, cell):
    rows.extend(["", title, "", "| scene | " + " | ".join(configs) + " |",
                 "| --- | " + " | ".join("---" for _ in configs) + " |"])
    for s in scenes:
        b = [load(s, c) for c in configs]
        rows.append(f"| {s} | " + " | ".join(cell(x, b[0]["floor"]["relative_rmse"]) for x in b) + " |")
section("Technique error against the light-set truth (relative RMSE), and the total's ratio to the floor:",
        lambda x, fl: f"{x['technique']['relative_rmse']*100:.2f}% ({x['total']['relative_rmse']/fl:.2f}x floor)")
section("Total error over the penumbra pixels (2%..98% of the lights' irradiance arrives): relative RMSE / mean HDR-FLIP:",
        lambda x, fl: f"{x['total']['relative_rmse_penumbra']*100:.2f}% / {x['total']['flip_penumbra']:.4f}")
section("Frame time (ms, warm, as `evaluate` times it; 320x180; this machine's load varies):",
        lambda x, fl: f"{x['frame_ms']:.0f}")
with open(os.path.join(out, "table.md"), "w") as f: f.write("\n".join(rows) + "\n")
print("\n".join(rows))
PY
