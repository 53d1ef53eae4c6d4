"""Summary of a bench/gpu/check.sh run: reads the run folder (steps.tsv, devices.log, tests.json or
tests.log, the Google Benchmark JSON files) and writes summary.json and summary.md there. Standard
library only: the GPU machine's python3 is not this project's."""
import argparse
import json
import os
import re
import sys


def read(path):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.read()
    except OSError:
        return None


def device_name(devices_log, selector):
    """The line of `penumbra devices` the selector picks (Context's rule: index, else name
    fragment, else device 0)."""
    lines = [l for l in (devices_log or "").splitlines() if re.match(r"^\d+: ", l)]
    if not lines:
        return None
    if selector == "":
        return lines[0]
    if selector.isdigit():
        return next((l for l in lines if l.startswith(selector + ": ")), None)
    return next((l for l in lines if selector.lower() in l.lower()), None)


def test_counts(run):
    """Counts from GoogleTest's JSON; from the console log when the run was cut short."""
    data = read(os.path.join(run, "tests.json"))
    if data:
        j = json.loads(data)
        failed = [f"{s['name']}.{t['name']}" for s in j.get("testsuites", [])
                  for t in s.get("testsuite", []) if t.get("failures")]
        skipped = sum(1 for s in j.get("testsuites", []) for t in s.get("testsuite", [])
                      if t.get("result") == "SKIPPED")
        total = j.get("tests", 0) - j.get("disabled", 0)
        return {"source": "tests.json", "total": total, "failed": len(failed),
                "skipped": skipped, "passed": total - len(failed) - skipped,
                "failed_tests": failed}
    log = read(os.path.join(run, "tests.log")) or ""
    ok = len(re.findall(r"^\[       OK \]", log, re.M))
    failed = re.findall(r"^\[  FAILED  \] (\S+) \(", log, re.M)
    skipped = len(re.findall(r"^\[  SKIPPED \] \S+ \(", log, re.M))
    return {"source": "tests.log (no JSON: the run was cut short)",
            "total": ok + len(failed) + skipped, "passed": ok, "failed": len(failed),
            "skipped": skipped, "failed_tests": failed}


SUFFIX = {"k": 1e3, "M": 1e6, "G": 1e9, "m": 1e-3, "u": 1e-6, "n": 1e-9}


def console_rows(log):
    """The rows Google Benchmark printed before a timeout cut it short (its JSON is written only at
    the end): name, time, unit, cpu, unit, iterations, then counters as name=value[k|M|...]."""
    rows = []
    for m in re.finditer(r"^(BM_\S+)\s+([\d.]+) (ns|us|ms|s)\s+[\d.]+ \S+\s+(\d+)(.*)$", log, re.M):
        counters = {}
        for k, v, s in re.findall(r"(\S+)=([\d.eE+-]+)([kMGmun]?)/?s?", m.group(5)):
            counters[k] = float(v) * SUFFIX.get(s, 1.0)
        rows.append({"name": m.group(1), "iterations": int(m.group(4)),
                     "real_time": float(m.group(2)), "time_unit": m.group(3),
                     "counters": counters, "source": "console (cut short)"})
    return rows


def benchmarks(run, name):
    """Google Benchmark's JSON: per benchmark the mean real time and every user counter."""
    data = read(os.path.join(run, name + ".json"))
    try:
        j = json.loads(data) if data else None
    except ValueError:
        j = None
    if j is None:
        log = read(os.path.join(run, name + ".log"))
        return (console_rows(log) or None) if log else None
    skip = {"name", "run_name", "run_type", "family_index", "per_family_instance_index",
            "repetitions", "repetition_index", "threads", "iterations", "real_time", "cpu_time",
            "time_unit", "items_per_second", "aggregate_name", "aggregate_unit"}
    out = []
    for b in j.get("benchmarks", []):
        row = {"name": b["name"], "iterations": b.get("iterations"),
               "real_time": b.get("real_time"), "time_unit": b.get("time_unit")}
        row["counters"] = {k: v for k, v in b.items()
                           if k not in skip and isinstance(v, (int, float))}
        if "error_message" in b:
            row["error"] = b["error_message"]
        out.append(row)
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run")
    ap.add_argument("--device", default="")
    ap.add_argument("--quick", default="0")
    a = ap.parse_args()
    steps = []
    for line in (read(os.path.join(a.run, "steps.tsv")) or "").splitlines():
        name, rc, secs, limit = line.split("\t")
        steps.append({"step": name, "exit": int(rc), "seconds": float(secs),
                      "limit_s": int(limit), "timed_out": rc in ("124", "137")})
    summary = {
        "device_selector": a.device,
        "device": device_name(read(os.path.join(a.run, "devices.log")), a.device),
        "quick": a.quick == "1",
        "total_seconds": round(sum(s["seconds"] for s in steps), 2),
        "steps": steps,
        "tests": test_counts(a.run),
        "benchmarks": {n: benchmarks(a.run, n) for n in ("bench_frame", "bench_bitmask", "bench_gl")},
    }
    with open(os.path.join(a.run, "summary.json"), "w") as f:
        json.dump(summary, f, indent=1)
    with open(os.path.join(a.run, "summary.md"), "w") as f:
        f.write(markdown(summary))
    sys.stdout.write(markdown(summary))


def markdown(s):
    t = s["tests"]
    md = [f"# GPU check{' (quick)' if s['quick'] else ''}", "",
          f"Device: {s['device'] or 'unknown'} (selector `{s['device_selector'] or 'default'}`)",
          f"Total: {s['total_seconds']} s", "",
          "| step | exit | seconds | limit |", "|---|---|---|---|"]
    for st in s["steps"]:
        mark = " (timed out)" if st["timed_out"] else ""
        md.append(f"| {st['step']} | {st['exit']}{mark} | {st['seconds']:.1f} | {st['limit_s']} |")
    md += ["", f"Tests: {t['passed']} passed, {t['failed']} failed, {t['skipped']} skipped of "
           f"{t['total']} ({t['source']})"]
    md += [f"- failed: {n}" for n in t["failed_tests"]]
    for name, rows in s["benchmarks"].items():
        md += ["", f"## {name}", ""]
        if rows is None:
            md.append("no results (step missing, failed or timed out)")
            continue
        md += ["| benchmark | time | counters |", "|---|---|---|"]
        for r in rows:
            c = ", ".join(f"{k} {v:.3g}" for k, v in sorted(r["counters"].items()))
            if "error" in r:
                c = "error: " + r["error"]
            md.append(f"| {r['name']} | {r['real_time']:.3f} {r['time_unit']} | {c} |")
    return "\n".join(md) + "\n"


if __name__ == "__main__":
    main()
