#!/usr/bin/python3
"""PomdpX conformance: our reader on SARSOP's own example files, and our benchmark set in both formats.

    pomdpx_conformance.py [--sarsop-dir /tmp/krr/sarsop_build/src] [--budget 5]
                          [--ours catkin_ws/devel/lib/krr_core/pomdp_solve] [--dir DIR]
                          [--problems rocksample_4_4,...] [--memory-budget MiB] [--output FILE.md]

Not a CI test (it needs a SARSOP build, which is not part of the project; its directory is an
argument). Two tables:

1. Every examples/POMDPX/*.pomdpx of SARSOP loads, and `pomdp_solve --timeout B` on it gives
   bounds consistent with SARSOP's (`pomdpsol --timeout B`, same file): both are bounds on the
   same optimal value, so each lower bound must lie below the other solver's upper bound. Where
   SARSOP also ships the problem as .pomdp (examples/POMDP), our bounds on that file are shown
   too.
2. gen_pomdp.py writes each benchmark problem as .pomdp (flat) and .pomdpx (factored); the flat
   sizes of both and the bounds of both solvers on both files are compared (consistent bounds
   on every pair: the two files are the same problem).

Runs are sequential (two cores, timed solvers); the helpers of compare.py do the timing and
parse both solvers' output.
"""

import argparse
import time
import glob
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import compare  # noqa: E402  (run_ours, run_sarsop, timed, GEN)

DEFAULT_SARSOP = "/tmp/krr/sarsop_build/src"
DEFAULT_PROBLEMS = "rocksample_4_4,rocksample_5_5,rocksample_5_7,tag"


def ours(binary, path, budget, memory):
    """compare.run_ours plus the flat sizes from our header line."""
    cmd = [binary, path, "--timeout", str(budget)]
    if memory:
        cmd += ["--memory-budget", str(memory)]
    rc, text, wall, mem = compare.timed(cmd, budget * 3 + 120)
    r = dict(lower=None, upper=None, wall=wall, mem=mem, error=None, sizes=None)
    for line in text.splitlines():
        m = re.match(r"# .*: (\d+) states, (\d+) actions, (\d+) observations", line)
        if m:
            r["sizes"] = tuple(int(x) for x in m.groups())
        f = line.split()
        if len(f) == 5 and not line.startswith("#"):
            try:
                r["lower"], r["upper"] = float(f[1]), float(f[2])
            except ValueError:
                pass
    if rc != 0 or r["lower"] is None:
        lines = [l for l in text.splitlines() if l.strip() and "[killed" not in l]
        r["error"] = (lines[-1] if lines else "exit status %d" % rc)[-200:]
        r["lower"] = r["upper"] = None
    return r


def consistent(a, b):
    """Both runs are valid bounds on one value: each lower bound is below the other's upper."""
    if a["lower"] is None or b["lower"] is None:
        return "—"
    tol = 1e-3 * max(1.0, abs(a["lower"]), abs(b["lower"]))
    ok = a["lower"] <= b["upper"] + tol and b["lower"] <= a["upper"] + tol
    return "yes" if ok else "**no**"


def bounds(r):
    if r is None:
        return "—"
    if r["error"]:
        return "error: " + r["error"].replace("|", "/")
    return "%.3f / %.3f" % (r["lower"], r["upper"])


def sizes(r):
    return "%d / %d / %d" % r["sizes"] if r and r.get("sizes") else "—"


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sarsop-dir", default=DEFAULT_SARSOP,
                    help="SARSOP source tree with src/pomdpsol and examples/ (%s)" % DEFAULT_SARSOP)
    ap.add_argument("--ours", default=compare.DEFAULT_OURS)
    ap.add_argument("--budget", type=float, default=5.0, help="seconds per run (5)")
    ap.add_argument("--dir", default="/tmp/pomdpx_conformance", help="generated files")
    ap.add_argument("--problems", default=DEFAULT_PROBLEMS)
    ap.add_argument("--memory-budget", type=float, default=0.0,
                    help="MiB for pomdp_solve (default: its own, 1 GiB)")
    ap.add_argument("--sarsop-skip", default="",
                    help="example stems SARSOP is not run on (comma separated), e.g. "
                         "RockSample_11_11, whose preprocessing outlasts the hard timeout")
    ap.add_argument("--output", help="also write the tables to this Markdown file")
    args = ap.parse_args(argv)
    sarsop = os.path.join(args.sarsop_dir, "src", "pomdpsol")
    examples = sorted(glob.glob(os.path.join(args.sarsop_dir, "examples", "POMDPX", "*.pomdpx")))
    if not os.access(sarsop, os.X_OK) or not examples:
        raise SystemExit("pomdpx_conformance: need %s and examples/POMDPX/*.pomdpx under %s"
                         % (sarsop, args.sarsop_dir))
    if not os.access(args.ours, os.X_OK):
        raise SystemExit("pomdpx_conformance: %s not built" % args.ours)
    os.makedirs(args.dir, exist_ok=True)
    b = args.budget
    out = ["## SARSOP's example files (budget %g s each)" % b, "",
           "| file | flat S / A / O (ours) | ours on .pomdpx | ours on SARSOP's .pomdp | "
           "SARSOP on .pomdpx | consistent |", "|---|---|---|---|---|---|"]
    print("\n".join(out), flush=True)
    for path in examples:
        stem = os.path.splitext(os.path.basename(path))[0]
        x = ours(args.ours, path, b, args.memory_budget)
        twin = os.path.join(args.sarsop_dir, "examples", "POMDP", stem + ".pomdp")
        p = ours(args.ours, twin, b, args.memory_budget) if os.path.exists(twin) else None
        s = (dict(lower=None, upper=None, error="not run (--sarsop-skip)")
             if stem in args.sarsop_skip.split(",") else compare.run_sarsop(sarsop, path, b, args.dir))
        row = "| %s | %s | %s | %s | %s | %s |" % (
            os.path.basename(path), sizes(x), bounds(x), bounds(p), bounds(s), consistent(x, s))
        out.append(row)
        print(row, flush=True)
    head = ["", "## gen_pomdp.py: .pomdp (flat) and .pomdpx (factored) (budget %g s each)" % b, "",
            "| problem | S / A / O .pomdp | S / A / O .pomdpx | ours .pomdp | ours .pomdpx | "
            "SARSOP .pomdp | SARSOP .pomdpx | consistent |", "|---|---|---|---|---|---|---|---|"]
    out += head
    print("\n".join(head), flush=True)
    for problem in args.problems.split(","):
        files = {}
        for fmt in ("pomdp", "pomdpx"):
            path = os.path.join(args.dir, "%s.%s" % (problem, fmt))
            gen = ["tag"] if problem == "tag" else ["rocksample"] + problem.split("_")[1:]
            subprocess.run([sys.executable, compare.GEN] + gen + ["--format", fmt, "-o", path],
                           check=True, stderr=subprocess.DEVNULL)
            files[fmt] = path
        r = {f: ours(args.ours, files[f], b, args.memory_budget) for f in files}
        s = {f: compare.run_sarsop(sarsop, files[f], b, args.dir) for f in files}
        runs = [r["pomdp"], r["pomdpx"], s["pomdp"], s["pomdpx"]]
        ok = all(consistent(u, v) != "**no**" for u in runs for v in runs)
        row = "| %s | %s | %s | %s | %s | %s | %s | %s |" % (
            problem, sizes(r["pomdp"]), sizes(r["pomdpx"]), bounds(r["pomdp"]), bounds(r["pomdpx"]),
            bounds(s["pomdp"]), bounds(s["pomdpx"]), "yes" if ok else "**no**")
        out.append(row)
        print(row, flush=True)
    if args.output:
        with open(args.output, "w") as f:
            f.write("# PomdpX conformance\n\nGenerated by `tools/pomdp_bench/pomdpx_conformance.py` on %s "
                    "(%d CPUs); do not edit by hand. Reproduce (needs a SARSOP build):\n\n    %s\n\n"
                    "*consistent*: each solver's lower bound is at or below the other's upper bound "
                    "(both bound the same value).\n\n"
                    % (time.strftime("%Y-%m-%d %H:%M"), os.cpu_count() or 0,
                       " ".join(["tools/pomdp_bench/pomdpx_conformance.py"] + sys.argv[1:]))
                    + "\n".join(out) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
