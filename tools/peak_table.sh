#!/usr/bin/env bash
# Bright sources apart (README, "Bright sources"), measured: the default frame and hard shadows
# from the same 64 lights, each with the map's bright sources as lights of their own
# (--peak-ratio, with auto's exact visibility for them, --auto-exact-share) and without, on issue
# 13's four scene/map pairs and four held-out ones, against --spp truths (seed 11) cached in
# OUT/truths. Writes OUT/PAIR.CONFIG.json (penumbra evaluate --json) and OUT/table.md.
# Usage: tools/peak_table.sh PENUMBRA DATA_DIR OUT [SPP] [NEW_OPTIONS] [OLD_OPTIONS]
# (NEW_OPTIONS default: none, today's defaults; OLD_OPTIONS, when not given: both turned off, and
# "" is today's defaults. Committed:
# bench/results/accuracy/peaks, SPP 8192.) Another comparison names its two settings in
# OLD_LABEL and NEW_LABEL (the table's column heads; defaults: the bright sources'), e.g.
# OLD_LABEL="contact maps off" NEW_LABEL="contact maps on" tools/peak_table.sh P D OUT 8192 ""
# "--no-contact-maps".
set -euo pipefail
P=$1; D=$2; OUT=$3; SPP=${4:-8192}
NEW=${5:-}
OLD=${6---peak-ratio 0 --auto-exact-share 0}
mkdir -p "$OUT/truths"
. "$(dirname "$0")/evaluate_cached.sh"
scene_pairs "$D"
CONFIGS=(
  "old|$OLD"
  "default|$NEW"
  "hardold|--shadows hard $OLD"
  "hard|--shadows hard $NEW")
evaluate_pairs "$P" "$SPP" "$OUT"
OLD_LABEL=${OLD_LABEL:-median cut alone} NEW_LABEL=${NEW_LABEL:-bright sources apart} \
/usr/bin/python3 - "$OUT" "${PAIRS[@]}" <<'PY'
import json, os, statistics, sys
out, pairs = sys.argv[1], sys.argv[2:]
old, new = os.environ["OLD_LABEL"], os.environ["NEW_LABEL"]
names = ["old", "default", "hardold", "hard"]
heads = [old, f"**{new}**", f"hard-64, {old}", f"hard-64, {new}"]
def get(p, n):
    return json.load(open(f"{out}/{p}.{n}.json"))
lines = [f"| pair | truth noise | floor, {old} | floor, {new} | "
         + " | ".join(heads) + " |",
         "| --- | --- | --- | --- | " + " | ".join("---" for _ in names) + " |"]
for p in pairs:
    o, j = get(p, "old"), get(p, "default")
    cells = [p, f"{100 * j['total']['noise']:.2f}%",
             f"{100 * o['floor']['relative_rmse']:.2f}% / {o['floor']['flip']:.4f}",
             f"{100 * j['floor']['relative_rmse']:.2f}% / {j['floor']['flip']:.4f}"]
    for n in names:
        j = get(p, n)
        t, f, q = j["total"], j["floor"], j["technique"]
        c = (f"{100 * t['relative_rmse']:.2f}% / {t['flip']:.4f} "
             f"({t['relative_rmse'] / f['relative_rmse']:.2f}x, {100 * q['relative_rmse']:.2f}%)")
        cells.append(f"**{c}**" if n == "default" else c)
    lines.append("| " + " | ".join(cells) + " |")
for label, group in (("issue 13's four", pairs[:4]), ("held-out four", pairs[4:])):
    cells = [f"median / worst, {label}", "", "", ""]
    for n in names:
        v = [100 * get(p, n)["total"]["relative_rmse"] for p in group]
        cells.append(f"{statistics.median(v):.2f} / {max(v):.2f}%")
    lines.append("| " + " | ".join(cells) + " |")
lines.append("")
lines.append("Total relative RMSE / mean HDR-FLIP against the environment truth, in brackets the "
             "ratio to the floor of the same lights and the technique error against their "
             "light-set truth.")
open(f"{out}/table.md", "w").write("\n".join(lines) + "\n")
print("\n".join(lines))
PY
