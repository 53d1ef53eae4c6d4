#!/usr/bin/env python3
"""Issue 17's speed targets for a CPU, each measured in this one run and printed beside its target.

  start-up      README's render command (640x360, defaults), whole process, warm kernel cache:
                median of 3 <= 1.0 s wall; `penumbra devices` median of 3 <= 0.3 s
  frame         a warm 640x360 frame with 32 lights and the default technique
                (`render --lights 32 --frames 7 --report`): median of frames 3-7 <= 150 ms
  sat           bench_scan's float4 tables of 256^2, 1024^2 and 2048^2: median time over that of
                a device copy of the same bytes, measured in the same process, >= 0.6 each
  equal error   320x180, built-in scene and courtyard + Wuson: the default frame's whole process
                against `penumbra reference`'s at equal error, >= 8x each

Equal error, as bench/results/cpu_speed.md does it by hand: the truth is the mean of two 4096-spp
seeds (11 and 12, kept in CACHE and reused); its noise s_t is half their relative RMSE
difference; the frame's error e is `compare frame truth`. A reference of N samples per pixel
scores sqrt(2 s_t^2 4096 / N + s_t^2) against that truth, so equal error needs
N = 2 s_t^2 4096 / (e^2 - s_t^2). The reference is run at N with a third seed (13) and timed; its
own error against the truth is printed, as the check that N is right. The frame's time is the
median of 3 whole `render` processes writing PNG.

Usage (from the checkout, after the README's build):
    /usr/bin/python3 tools/cpu_targets.py [--build build] [--cache build/cpu_targets]
                                          [--skip-equal-error] [--verbose]
Prints one line per target. Exit status 0 when every target is met, 1 when one is missed (a frame
whose error is within the truth's noise counts as missed: no equal-error count exists), 2 on a
setup error (a program missing or failing, output it cannot read). The truths are reused while
their files exist: delete CACHE after changing the reference renderer. Takes about five minutes on 2 cores the first time (the truths), three after.
Only the Python standard library; the commands it runs are printed with --verbose.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent
VERBOSE = False


class SetupError(Exception):
    pass


def run(cmd, capture=False):
    if VERBOSE:
        print("  $ " + " ".join(str(c) for c in cmd), file=sys.stderr)
    try:
        res = subprocess.run([str(c) for c in cmd], text=True, stderr=subprocess.PIPE,
                             stdout=subprocess.PIPE if capture else subprocess.DEVNULL)
    except OSError as e:
        raise SetupError("cannot run %s: %s" % (cmd[0], e))
    if res.returncode != 0:
        raise SetupError("%s exited %d: %s" % (cmd[0], res.returncode, res.stderr.strip()[-400:]))
    return res.stdout


def wall(cmd):
    t = time.monotonic()
    run(cmd)
    return time.monotonic() - t


def median_wall(cmd, n=3):
    return statistics.median(wall(cmd) for _ in range(n))


def rel_rmse(cli, a, b):
    value = json.loads(run([cli, "compare", a, b], capture=True))["relative_rmse"]
    if not isinstance(value, (int, float)):
        raise SetupError("compare %s %s gave no relative RMSE" % (a, b))
    return float(value)


def equal_error(cli, cache, tmp, name, scene_args):
    size, base = "320x180", 4096
    seeds = []
    for seed in (11, 12):
        path = cache / ("%s-%d-%d.exr" % (name, base, seed))
        if not path.exists():
            part = path.with_suffix(".part.exr")
            run([cli, "reference", "--size", size, "--spp", base, "--seed", seed, "-o", part] + scene_args)
            part.rename(path)
        seeds.append(path)
    truth = cache / ("%s-%d-truth.exr" % (name, base))
    if not truth.exists():
        part = truth.with_suffix(".part.exr")
        run(["oiiotool", seeds[0], seeds[1], "--add", "--mulc", "0.5", "-o", part])
        part.rename(truth)
    s_t = rel_rmse(cli, seeds[0], seeds[1]) / 2  # the mean of two seeds: half their difference
    frame = tmp / ("%s-frame.exr" % name)
    run([cli, "render", "--size", size, "-o", frame] + scene_args)
    e = rel_rmse(cli, frame, truth)
    if e <= s_t * 1.05:
        return None, "the frame's error %.3f%% is within the truth's noise %.3f%%: no equal-error count" % (
            100 * e, 100 * s_t)
    n = max(1, round(2 * s_t * s_t * base / (e * e - s_t * s_t)))
    ref = tmp / ("%s-ref.exr" % name)
    t_ref = wall([cli, "reference", "--size", size, "--spp", n, "--seed", 13, "-o", ref] + scene_args)
    e_ref = rel_rmse(cli, ref, truth)
    png = tmp / ("%s-frame.png" % name)
    t_frame = median_wall([cli, "render", "--size", size, "-o", png, "-q"] + scene_args)
    ratio = t_ref / t_frame
    return ratio, ("frame %.3f%% (truth noise %.3f%%), reference at %d spp %.3f%% in %.1f s, frame %.2f s" %
                   (100 * e, 100 * s_t, n, 100 * e_ref, t_ref, t_frame))


def main():
    global VERBOSE
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=str(HERE / "build"), help="the build directory (default build)")
    ap.add_argument("--cache", help="where the truths are kept (default BUILD/cpu_targets)")
    ap.add_argument("--skip-equal-error", action="store_true", help="leave out the equal-error ratios")
    ap.add_argument("--verbose", action="store_true", help="print each command on stderr")
    args = ap.parse_args()
    VERBOSE = args.verbose
    build = Path(args.build).resolve()
    cli, scan = build / "penumbra", build / "bench" / "bench_scan"
    for exe in (cli, scan):
        if not os.access(exe, os.X_OK):
            print("cpu_targets: %s is missing: build first (README)" % exe, file=sys.stderr)
            return 2
    cache = Path(args.cache) if args.cache else build / "cpu_targets"
    cache.mkdir(parents=True, exist_ok=True)
    results = []  # (name, value text, met)

    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        run([cli, "render", "-o", tmp / "warm.png", "-q"])  # fills the kernel cache
        t = median_wall([cli, "render", "--out", tmp / "penumbra.png", "-q"])
        results.append(("README render, whole process", "%.2f s (target <= 1.0)" % t, t <= 1.0))
        t = median_wall([cli, "devices"])
        results.append(("penumbra devices", "%.2f s (target <= 0.3)" % t, t <= 0.3))

        report = tmp / "r.json"
        run([cli, "render", "--lights", 32, "--frames", 7, "--report", report, "-o", tmp / "f.png", "-q"])
        frames = json.loads(report.read_text())[2:7]
        ms = statistics.median(f["frame_ms"] for f in frames)
        results.append(("warm 640x360 frame, 32 lights", "%.1f ms (target <= 150)" % ms, ms <= 150))

        # the copies (BM_Copy) run too: each table is measured against the copy of its own bytes
        out = run([scan, "--benchmark_filter=float4/(256|1024|2048)/manual|Copy/(1024|16384|65536)KiB",
                   "--benchmark_repetitions=5", "--benchmark_report_aggregates_only=true",
                   "--benchmark_format=json"], capture=True)
        fractions = {}
        for b in json.loads(out)["benchmarks"]:
            if b.get("aggregate_name") == "median" and b["run_name"].startswith("BM_Sat/"):
                fractions[b["run_name"].split("/")[2]] = b["fraction_of_copy_bw"]
        if sorted(fractions) != ["1024", "2048", "256"]:
            raise SetupError("bench_scan gave tables %s, not 256, 1024 and 2048" % sorted(fractions))
        for side in ("256", "1024", "2048"):
            f = fractions[side]
            results.append(("float4 SAT %s^2 / copy" % side, "%.2f (target >= 0.6)" % f, f >= 0.6))

        if not args.skip_equal_error:
            data = HERE / "tests" / "data"
            scenes = [("builtin", []),
                      ("courtyard-wuson", ["--env", data / "envmaps" / "courtyard.exr",
                                           "--scene", data / "meshes" / "good" / "WusonOBJ.obj"])]
            for name, scene_args in scenes:
                ratio, text = equal_error(cli, cache, tmp, name, scene_args)
                met = ratio is not None and ratio >= 8
                value = ("%.1fx (target >= 8): " % ratio if ratio is not None else "") + text
                results.append(("equal error, " + name, value, met))

    for name, value, met in results:
        print("%-32s %-4s %s" % (name, "ok" if met else "MISS", value))
    return 0 if all(m for _, _, m in results) else 1


if __name__ == "__main__":
    try:
        sys.exit(main())
    except (SetupError, ValueError, KeyError, IndexError, TypeError) as e:
        print("cpu_targets: %s" % e, file=sys.stderr)
        sys.exit(2)
