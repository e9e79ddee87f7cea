"""Benchmark of the evaluation suite: time per experiment at the default trial counts.

    rosrun krr_eval bench_evaluate [--out DIR] [--workers W] [--scheduler ADDR]
        full default suite (all six experiments at the default trial counts: the paper's,
        exp2 40,000), then the time per experiment and the total against the 3-minute
        target (issue 11). Cold by default:
        learned knowledge and dialog policies go to a fresh cache (KRR_CACHE_DIR), so
        learning and solving are counted as on a fresh clone; --warm reuses the user's cache
    rosrun krr_eval bench_evaluate --scales 0.01,0.03 [--only exp2,exp4]
        runs the suite at reduced trial counts instead and extrapolates each experiment's
        time linearly (t = a + b * scale; a holds start-up costs) to scale 1

Prints one table; the per-run outputs (tables, report.md, trials) stay in --out
(default: a temporary folder, removed unless --keep).
"""
import argparse
import io
import json
import os
import shutil
import sys
import tempfile
import time

from . import experiments, suite

TARGET_S = 180.0


def run(out, scale, args):
    # --allow-unconverged: the benchmark measures time; the dialog policies' certified gap is
    # reported by policy_report / bench_dialog_pomdp, and the main job says so too.
    cmd = ["--out", out, "--trials-scale", repr(scale), "--workers", str(args.workers),
           "--no-progress", "--no-ros", "--seed", str(args.seed), "--allow-unconverged"]
    if args.only:
        cmd += ["--only", args.only]
    if args.scheduler:
        cmd += ["--scheduler", args.scheduler]
    log = io.StringIO()
    t0 = time.monotonic()
    rc = suite.main(cmd, stdout=log, stderr=sys.stderr)
    wall = time.monotonic() - t0
    with open(os.path.join(out, "params.json")) as f:
        p = json.load(f)
    if rc != 0:
        sys.stderr.write("bench: scale %g: failed experiments: %s\n" % (scale, p["failed"]))
    return p["times_s"], wall, p


def main(argv=None):
    ap = argparse.ArgumentParser(prog="bench_evaluate", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", help="keep the runs' outputs here")
    ap.add_argument("--keep", action="store_true", help="keep the temporary output folder")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--scheduler")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--only", help="comma-separated experiments (default: all)")
    ap.add_argument("--warm", action="store_true",
                    help="reuse the user's learned-knowledge / policy cache (default: a fresh one)")
    ap.add_argument("--scales", help="two or more reduced scales to extrapolate from, e.g. "
                    "0.01,0.03 (default: one run at the default counts)")
    a = ap.parse_args(argv)
    scales = [1.0]
    if a.scales:
        try:
            scales = sorted(float(x) for x in a.scales.split(","))
        except ValueError:
            ap.error("--scales: comma-separated numbers expected, got %r" % a.scales)
        if len(scales) < 2 or scales[0] <= 0 or len(set(scales)) != len(scales):
            ap.error("--scales needs at least two distinct positive scales")
    base = a.out or tempfile.mkdtemp(prefix="krr_bench_eval_")
    if not a.warm:
        os.environ["KRR_CACHE_DIR"] = os.path.join(base, "cache")
    print("bench_evaluate: %d workers%s, scales %s, %s cache, outputs in %s" % (
        a.workers, " on %s" % a.scheduler if a.scheduler else "",
        ", ".join("%g" % s for s in scales), "warm" if a.warm else "cold", base))
    times, cpus, trials = {}, {}, {}
    try:
        for s in scales:
            out = os.path.join(base, "scale_%g" % s)
            t, wall, p = run(out, s, a)
            times[s], cpus[s] = t, p.get("cpu_s", {})
            trials[s] = {k: v.get("trials") for k, v in p["experiments"].items()}
            print("  scale %g: %.1f s wall (%s)" % (s, wall, ", ".join(
                "%s %s" % (k, v) for k, v in trials[s].items() if v)))
    finally:
        if not a.out and not a.keep:
            shutil.rmtree(base, ignore_errors=True)
    keys = [k for k in experiments.EXPERIMENTS if all(k in times[s] for s in scales)]
    print()
    local = not a.scheduler
    note = ("CPU: this process + its CLI processes; 'idle' = CPU / %d workers, the wall time on "
            "an otherwise idle machine with %d cores" % (a.workers, a.workers)) if local else ""
    if len(scales) == 1:
        t1, c1 = times[1.0], cpus[1.0]
        print("%-6s %9s %9s %9s  %s" % ("exp", "wall s", "CPU s", "idle s", "trials per set"))
        for k in keys:
            print("%-6s %9.1f %9.1f %9.1f  %s" % (k, t1[k], c1.get(k, 0), c1.get(k, 0) / a.workers,
                                                trials[1.0].get(k, "") or ""))
        total, ctot = sum(t1[k] for k in keys), sum(c1.get(k, 0) for k in keys)
        print("%-6s %9.1f %9.1f %9.1f  target %.0f s: %s" % (
            "total", total, ctot, ctot / a.workers, TARGET_S,
            "met" if total < TARGET_S else "NOT met"))
        print(note)
        return 0
    print("%-6s %s  %s  %10s %10s %10s" % ("exp", "  ".join("wall@%g" % s for s in scales),
                                          "  ".join("CPU@%g" % s for s in scales),
                                          "wall@1", "CPU@1", "idle@1"))
    tot = [0.0, 0.0]
    for k in keys:
        w = fit(scales, [times[s][k] for s in scales])
        c = fit(scales, [cpus[s].get(k, 0.0) for s in scales])
        tot[0] += w
        tot[1] += c
        print("%-6s %s  %s  %10.1f %10.1f %10.1f" % (
            k, "  ".join("%*.1f" % (len("wall@%g" % s), times[s][k]) for s in scales),
            "  ".join("%*.1f" % (len("CPU@%g" % s), cpus[s].get(k, 0.0)) for s in scales),
            w, c, c / a.workers))
    print("%-6s %s  %s  %10.1f %10.1f %10.1f" % (
        "total", " " * len("  ".join("wall@%g" % s for s in scales)),
        " " * len("  ".join("CPU@%g" % s for s in scales)), tot[0], tot[1], tot[1] / a.workers))
    print("extrapolated linearly (t = a + b * scale) to the default trial counts; target %.0f s "
          "(wall): %s; idle-machine estimate: %s" % (
              TARGET_S, "met" if tot[0] < TARGET_S else "NOT met",
              "met" if tot[1] / a.workers < TARGET_S else "NOT met"))
    print(note)
    return 0


def fit(xs, ys):
    """Least-squares line through (x, y), evaluated at x = 1 (slope and intercept >= 0)."""
    n = float(len(xs))
    mx, my = sum(xs) / n, sum(ys) / n
    b = max(0.0, sum((x - mx) * (y - my) for x, y in zip(xs, ys)) /
            sum((x - mx) ** 2 for x in xs))
    return max(0.0, my - b * mx) + b


if __name__ == "__main__":
    sys.exit(main())
