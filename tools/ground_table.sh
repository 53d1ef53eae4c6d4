#!/usr/bin/env bash
# The ground's occlusion of low lights (README, "How it works"), measured: the default frame and
# hard shadows from the same 64 lights, each with and without --no-ground-visibility, on issue
# 13's four scene/map pairs and four held-out ones, against --spp truths (seed 11) cached in
# OUT/truths. Writes OUT/PAIR.CONFIG.json (penumbra evaluate --json) and OUT/table.md.
# Usage: tools/ground_table.sh PENUMBRA DATA_DIR OUT [SPP]   (committed: bench/results/accuracy/ground,
# SPP 8192, about 17 minutes on the 2-core CPU with the truths computed)
set -euo pipefail
P=$1; D=$2; OUT=$3; SPP=${4:-8192}
mkdir -p "$OUT/truths"
. "$(dirname "$0")/evaluate_cached.sh"
scene_pairs "$D"
CONFIGS=(
  "noground|--no-ground-visibility"
  "default|"
  "hardnoground|--shadows hard --no-ground-visibility"
  "hard|--shadows hard")
evaluate_pairs "$P" "$SPP" "$OUT"
/usr/bin/python3 - "$OUT" "${PAIRS[@]}" <<'PY'
import json, statistics, sys
out, pairs = sys.argv[1], sys.argv[2:]
names = ["noground", "default", "hardnoground", "hard"]
heads = ["default, no ground step", "**default**", "hard-64, no ground step", "hard-64"]
def get(p, n):
    return json.load(open(f"{out}/{p}.{n}.json"))
lines = ["| pair | truth noise | floor (same lights) | " + " | ".join(heads) + " |",
         "| --- | --- | --- | " + " | ".join("---" for _ in names) + " |"]
for p in pairs:
    j = get(p, "default")
    cells = [p, f"{100 * j['total']['noise']:.2f}%", f"{100 * j['floor']['relative_rmse']:.2f}%"]
    for n in names:
        j = get(p, n)
        t, f, q = j["total"], j["floor"], j["technique"]
        c = (f"{100 * t['relative_rmse']:.2f}% / {t['flip']:.4f} "
             f"({t['relative_rmse'] / f['relative_rmse']:.2f}x, {100 * q['relative_rmse']:.2f}%)")
        cells.append(f"**{c}**" if n == "default" else c)
    lines.append("| " + " | ".join(cells) + " |")
for label, group in (("issue 13's four", pairs[:4]), ("held-out four", pairs[4:])):
    cells = [f"median / worst, {label}", "", ""]
    for n in names:
        v = [100 * get(p, n)["total"]["relative_rmse"] for p in group]
        cells.append(f"{statistics.median(v):.2f} / {max(v):.2f}%")
    lines.append("| " + " | ".join(cells) + " |")
lines.append("")
lines.append("Total relative RMSE / mean HDR-FLIP against the environment truth, in brackets the "
             "ratio to the floor and the technique error against the light-set truth.")
open(f"{out}/table.md", "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
