#!/bin/bash
# The "Light count against technique" table of bench/results/accuracy.md: for each configuration
# below, `penumbra evaluate` at 320x180 on the four scenes of issue 13 and on four held-out
# scene/map pairs, against Embree environment truths of SPP samples per pixel (their own noise
# printed beside every figure); each configuration's floor is that of its own light set. Then the
# cost: the warm 640x360 frame of the README's render command with each configuration's options
# (built-in scene, `render --frames 6`, median of frames 3-6), ROUNDS rounds with the
# configurations in turn, as the median of the per-round ratios to the default's frame.
# usage: tools/light_count_table.sh PENUMBRA_CLI DATA_DIR OUT_DIR [SPP] [ROUNDS]
#   OUT_DIR gets truths/ (a cache that later runs reuse), one JSON per pair and configuration,
#   cost.txt and table.md.
set -euo pipefail
P=$1; D=$2; OUT=$3; SPP=${4:-8192}; ROUNDS=${5:-3}
mkdir -p "$OUT/truths"
. "$(dirname "$0")/evaluate_cached.sh"
scene_pairs "$D"
CONFIGS=(
  "mssm4-32|--lights 32 --shadows mssm4"
  "hard-32|--lights 32 --shadows hard"
  "hard-64|--lights 64 --shadows hard"
  "auto-64-f8|--lights 64 --shadows auto --auto-exact 0 --auto-filtered 8"
  "auto-64-f16|--lights 64 --shadows auto --auto-exact 0 --auto-filtered 16"
  "auto-64-f24|--lights 64 --shadows auto --auto-exact 0 --auto-filtered 24"  # the default
  "auto-64-f32|--lights 64 --shadows auto --auto-exact 0 --auto-filtered 32"
  "mssm4-64|--lights 64 --shadows mssm4")  # last: its floor is the 64-light column
# shellcheck source=tools/evaluate_cached.sh
for s in "${PAIRS[@]}"; do
  for c in "${CONFIGS[@]}"; do
    # shellcheck disable=SC2086
    evaluate_cached "$P" "$SPP" "$OUT" "$s" "${c%%|*}" ${SCENE[$s]} ${c#*|}
  done
done
: > "$OUT/cost.txt"
for ((r = 1; r <= ROUNDS; ++r)); do
  for c in "${CONFIGS[@]}"; do
    name=${c%%|*}; args=${c#*|}
    # shellcheck disable=SC2086
    "$P" render --frames 6 $args --report "$OUT/cost.$name.json" --out "$OUT/cost.png" -q
    /usr/bin/python3 -c "
import json, statistics, sys
j = json.load(open(sys.argv[1]))
print(sys.argv[2], sys.argv[3], statistics.median(f['frame_ms'] for f in j[2:]))
" "$OUT/cost.$name.json" "$r" "$name" >> "$OUT/cost.txt"
  done
done
rm -f "$OUT"/cost*.png
/usr/bin/python3 - "$OUT" "${PAIRS[@]}" -- "${CONFIGS[@]%%|*}" <<'PY'
import json, os, statistics, sys
out = sys.argv[1]
k = sys.argv.index("--")
pairs, configs = sys.argv[2:k], sys.argv[k + 1:]
ms = {}
for line in open(os.path.join(out, "cost.txt")):
    r, name, v = line.split()
    ms.setdefault(r, {})[name] = float(v)
base = configs[0]
cost = {c: (statistics.median(ms[r][c] / ms[r][base] for r in ms),
            statistics.median(ms[r][c] for r in ms)) for c in configs}
def load(s, c):
    with open(os.path.join(out, f"{s}.{c}.json")) as f: return json.load(f)
rows = ["Total error against the environment truth (relative RMSE / mean HDR-FLIP); in brackets the "
        "total's ratio to its own light set's floor. The first four are issue 13's scenes, the last "
        "four held out. `--lights 64` gives studio.exr 62 (median cut drops cells that hold no "
        "light).", "",
        "| pair | truth noise | floor, 32 lights | floor, 64 lights | " + " | ".join(configs) + " |",
        "| --- | --- | --- | --- | " + " | ".join("---" for _ in configs) + " |"]
for s in pairs:
    b = [load(s, c) for c in configs]
    f32, f64 = load(s, configs[0])["floor"], load(s, configs[-1])["floor"]
    cells = [f"{x['total']['relative_rmse']*100:.2f}% / {x['total']['flip']:.4f} "
             f"({x['total']['relative_rmse']/x['floor']['relative_rmse']:.2f}x)" for x in b]
    rows.append(f"| {s} | {b[0]['truth_noise']['environment']*100:.2f}% | "
                f"{f32['relative_rmse']*100:.2f}% | {f64['relative_rmse']*100:.2f}% | " + " | ".join(cells) + " |")
for label, sel in (("issue 13's four", pairs[:4]), ("held-out four", pairs[4:])):
    t = {c: [load(s, c)["total"]["relative_rmse"] * 100 for s in sel] for c in configs}
    rows.append(f"| median / worst, {label} | | | | " +
                " | ".join(f"{statistics.median(t[c]):.2f}% / {max(t[c]):.2f}%" for c in configs) + " |")
rows.append("| frame, 640x360, built-in (ms; ratio to " + base + ") | | | | " +
            " | ".join(f"{cost[c][1]:.0f} ({cost[c][0]:.2f}x)" for c in configs) + " |")
with open(os.path.join(out, "table.md"), "w") as f: f.write("\n".join(rows) + "\n")
print("\n".join(rows))
PY
