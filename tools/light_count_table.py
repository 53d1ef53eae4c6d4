#!/usr/bin/env python3
"""The light-count predictor against the measured floor, and --lights auto against the truth
(bench/results/light_count.md; issue 13, item 5).

For each scene at 320x180: the environment truth is the mean of two `penumbra reference` seeds
(11, 12) at --truth-spp; its own relative noise is half the two seeds' relative RMSE. The floor at
N median-cut lights is `penumbra reference --lights N` (exact visibility, ambient unshadowed) at
--floor-spp; its noise is the one the reference prints. Each floor is also given with both noises
removed in quadrature. The prediction is bench/light_count's lightSetProbeError. Then `render
--lights auto` at each target, compared with the truth.

Usage: light_count_table.py CLI LIGHT_COUNT DATA_DIR WORK_DIR [--truth-spp 4096] [--floor-spp 2048]
WORK_DIR keeps the truths between runs (<scene>.ref11.exr, <scene>.ref12.exr).
"""
import argparse, json, math, os, re, subprocess, sys

SCENES = {
    "builtin": [],
    "courtyard": ["--env", "{d}/envmaps/courtyard.exr", "--scene", "{d}/meshes/good/WusonOBJ.obj"],
    "interior": ["--env", "{d}/envmaps/interior.exr", "--scene", "{d}/meshes/good/spider.obj"],
    "studio": ["--env", "{d}/envmaps/studio.exr", "--scene", "{d}/meshes/good/WusonOBJ.obj"],
}
COUNTS = [4, 8, 16, 32, 64, 128]
TARGETS = [0.03, 0.02]


def run(args):
    p = subprocess.run(args, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(args)}\n{p.stderr}")
    return p


def rel_rmse(cli, a, b):
    return json.loads(run([cli, "compare", a, b]).stdout)["relative_rmse"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("cli"); ap.add_argument("light_count"); ap.add_argument("data"); ap.add_argument("work")
    ap.add_argument("--truth-spp", type=int, default=4096)
    ap.add_argument("--floor-spp", type=int, default=2048)
    o = ap.parse_args()
    os.makedirs(o.work, exist_ok=True)
    size = ["--size", "320x180"]
    floor_rows, auto_rows = [], []
    for s, tmpl in SCENES.items():
        scene = [t.format(d=o.data) for t in tmpl]
        truth = os.path.join(o.work, f"{s}.gt.exr")
        seeds = []
        for seed in (11, 12):
            path = os.path.join(o.work, f"{s}.ref{seed}.exr")
            if not os.path.exists(path):
                run([o.cli, "reference", "-q", *size, *scene, "--spp", str(o.truth_spp), "--seed",
                     str(seed), "-o", path])
            seeds.append(path)
        run(["oiiotool", seeds[0], seeds[1], "--add", "--mulc", "0.5", "-o", truth])
        truth_noise = rel_rmse(o.cli, seeds[0], seeds[1]) / 2
        env = scene[scene.index("--env") + 1] if "--env" in scene else "builtin"
        pred = {}
        out = run([o.light_count, "-e", env, "-l", ",".join(map(str, COUNTS))]).stdout
        for line in out.splitlines():
            j = json.loads(line)
            pred[j["asked"]] = j["predicted"]
        for n in COUNTS:
            path = os.path.join(o.work, f"{s}.floor{n}.exr")
            err = run([o.cli, "reference", "-q", *size, *scene, "--lights", str(n), "--spp",
                       str(o.floor_spp), "--seed", "3", "-o", path]).stdout
            noise = float(re.search(r"relative noise ([0-9.]+)%", err).group(1)) / 100
            r = rel_rmse(o.cli, path, truth)
            clean = math.sqrt(max(0.0, r * r - truth_noise ** 2 - noise ** 2))
            floor_rows.append((s, n, r, truth_noise, noise, clean, pred[n]))
        for t in TARGETS:
            path = os.path.join(o.work, f"{s}.auto{t}.exr")
            p = run([o.cli, "render", *size, *scene, "--lights", "auto", "--target-error", str(t),
                     "-o", path])
            chosen = int(re.search(r"--lights auto: (\d+) lights", p.stderr).group(1))
            auto_rows.append((s, t, chosen, rel_rmse(o.cli, path, truth), truth_noise))
        path = os.path.join(o.work, f"{s}.default.exr")
        run([o.cli, "render", *size, *scene, "-o", path])
        auto_rows.append((s, None, 32, rel_rmse(o.cli, path, truth), truth_noise))
    pct = lambda v: f"{100 * v:.2f}%"
    print("| scene | lights | floor | truth noise | floor truth noise | floor, noises removed "
          "| predicted | predicted / floor (noises removed) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    xs, ys = [], []
    for s, n, r, tn, fn, c, p in floor_rows:
        ratio = f"{p / c:.2f}" if c > 0 else "-"
        print(f"| {s} | {n} | {pct(r)} | {pct(tn)} | {pct(fn)} | {pct(c)} | {pct(p)} | {ratio} |")
        if c > 0:
            xs.append(math.log(p)); ys.append(math.log(c))
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    cor = sum((a - mx) * (b - my) for a, b in zip(xs, ys)) / math.sqrt(
        sum((a - mx) ** 2 for a in xs) * sum((b - my) ** 2 for b in ys))
    print(f"\nCorrelation of log(predicted) with log(floor, noises removed): {cor:.3f}\n")
    print("| scene | lights | count | total (mssm4) | truth noise |")
    print("| --- | --- | --- | --- | --- |")
    for s, t, n, r, tn in auto_rows:
        what = f"auto, target {pct(t)}" if t else "32 (default)"
        print(f"| {s} | {what} | {n} | {pct(r)} | {pct(tn)} |")


if __name__ == "__main__":
    main()
