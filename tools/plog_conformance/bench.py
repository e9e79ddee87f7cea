#!/usr/bin/python3
"""P-log back-end benchmark: native, asp and auto (and plog2.0) on community-style programs.

Every program is run through our `plog` three times, once per back end (`--backend native`,
`--backend asp`, `--backend auto`), and, when a built plog2.0 binary is given, through plog2.0
with both of its algorithms (the faster one that answers is reported). The figure is the
wall-clock time of the whole process (parse, ground, infer, print), the median of --repeat
runs. The check is the target of issue 13: auto never more than 2x slower than the faster of
native and asp; times below --floor seconds count as equal (process start-up and clingo's
own start-up are a few milliseconds and dominate tiny programs).

Programs: plog2.0's `plogapp/tests` (the error programs excepted) and the classic solver's
examples (`oldplog/Examples`) from a plog2.0 checkout (GPL-3: read at run time, never copied
here), and our own knowledge bases (`config/office.plog`, the dialog and the navigation
knowledge with a query each).

The report (default docs/plog_backend_bench.md) is generated; re-run this script rather than
editing it.

usage: bench.py PLOG2_DIR [--plog PATH] [--plog2 PATH] [--out FILE] [--timeout S] [--only RE]
"""

import argparse
import datetime
import os
import re
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import run as harness  # noqa: E402  (the conformance harness: same runners)

REPO = harness.REPO


def own_programs():
    """Our knowledge bases: (name, command-line arguments after `plog`)."""
    nav30 = ["maps/office_30x30_geometry.plog", "config/navigation.plog"]
    nav50 = ["maps/office_50x50_geometry.plog", "config/navigation.plog"]
    return [
        ("ours: config/office.plog", ["config/office.plog"]),
        ("ours: office + dialog, ?heard_item", ["config/office.plog", "config/dialog.plog",
                                                "--query", "?{heard_item=coke}"]),
        ("ours: navigation 30x30, one move", nav30 + [
            "--query", "?{next_cell=13} | do(curr_cell=12), do(act_move=right)"]),
        ("ours: navigation 50x50, one move", nav50 + [
            "--query", "?{next_cell=%(b)s} | do(curr_cell=%(a)s), do(act_move=right)"]),
        # As the robot asks: several queries of one knowledge base in one process.
        ("ours: navigation 50x50, 8 moves", nav50 + sum(
            (["--query", "?{next_cell=%s} | do(curr_cell=%s), do(act_move=%s)" % (to, frm, m)]
             for frm, to in (("%(a)s", "%(b)s"), ("%(b)s", "%(a)s"))
             for m in ("up", "down", "left", "right")), [])),
    ]


def first_cells(path):
    """The first two cells of a geometry file's `cell` sort (a left/right neighbour pair)."""
    with open(os.path.join(REPO, path), encoding="utf-8") as f:
        text = f.read()
    m = re.search(r"^cell\s*=\s*\{([^}]*)\}", text, re.M)
    cells = [c.strip() for c in m.group(1).split(",")]
    return cells[0], cells[1]


def timed(fns, repeat):
    """Median time of `repeat` runs of each of `fns` (name -> run), interleaved round by
    round so that a slow spell of the machine falls on every back end alike; a run that fails
    or times out is not repeated."""
    results = {name: [] for name in fns}
    for _ in range(repeat):
        for name, fn in fns.items():
            if results[name] and results[name][0]["status"] != "ok":
                continue
            results[name].append(fn())
    out = {}
    for name, rs in results.items():
        ok = [r for r in rs if r["status"] == "ok"]
        if not ok:
            out[name] = rs[0]
            continue
        best = dict(ok[0])
        best["secs"] = statistics.median(r["secs"] for r in ok)
        out[name] = best
    return out


def fmt(r):
    if r is None:
        return "-"
    if r["status"] == "timeout":
        return "timeout"
    if r["status"] != "ok":
        return "fails"
    return "%.2f" % r["secs"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("plog2_dir", help="extracted plog2.0 checkout (with plogapp/tests)")
    ap.add_argument("--plog", default=os.path.join(REPO, "catkin_ws/devel/lib/krr_core/plog"))
    ap.add_argument("--plog2", default=None, help="built plog2.0 binary (optional)")
    ap.add_argument("--out", default=os.path.join(REPO, "docs/plog_backend_bench.md"))
    ap.add_argument("--timeout", type=float, default=30.0, help="seconds per run")
    ap.add_argument("--repeat", type=int, default=1, help="runs per back end (median)")
    ap.add_argument("--floor", type=float, default=0.05,
                    help="times below this many seconds count as equal")
    ap.add_argument("--only", default=None, help="regular expression on program paths")
    args = ap.parse_args()

    root = os.path.abspath(args.plog2_dir)
    progs = []
    for top in (os.path.join(root, "plogapp", "tests"), os.path.join(root, "oldplog", "Examples")):
        for d, _, files in os.walk(top):
            for f in files:
                p = os.path.relpath(os.path.join(d, f), root)
                if "/errors/" in p or f in ("out.txt", "result.txt"):
                    continue
                if not (f.endswith(harness.EXTENSIONS) or f == "simple"):
                    continue
                progs.append((p, [p], root))
    progs.sort()
    c50 = first_cells("maps/office_50x50_geometry.plog")
    for name, argv in own_programs():
        argv = [a % {"a": c50[0], "b": c50[1]} if "%(" in a else a for a in argv]
        progs.append((name, argv, REPO))
    if args.only:
        progs = [p for p in progs if re.search(args.only, p[0])]

    def ours(argv, backend, cwd):
        cmd = [args.plog] + argv + ["--json", "--backend", backend]
        rc, out, err, secs = harness.run(cmd, args.timeout, cwd)
        if rc is None:
            return {"status": "timeout", "secs": secs}
        if rc != 0:
            return {"status": "fails", "secs": secs, "error": (err.strip() or out.strip())[:120]}
        used = sorted(set(re.findall(r'"backend": "(\w+)"', out)))
        return {"status": "ok", "secs": secs, "used": "+".join(used)}

    rows = []
    for name, argv, cwd in progs:
        res = timed({b: (lambda b=b: ours(argv, b, cwd)) for b in ("native", "asp", "auto")},
                    args.repeat)
        p2 = None
        if args.plog2 and cwd == root:
            tries = [harness.run_plog2(args.plog2, argv[0], a, args.timeout, root)
                     for a in ("naive", "dco")]
            ok = [t for t in tries if t["status"] == "ok"]
            p2 = min(ok, key=lambda t: t["secs"]) if ok else tries[0]
        fast = [res[b]["secs"] for b in ("native", "asp") if res[b]["status"] == "ok"]
        if res["auto"]["status"] != "ok":
            verdict = "no" if fast else "none answers"
        elif not fast:
            verdict = "yes (only auto answers)"
        else:
            best = min(fast)
            ok = res["auto"]["secs"] <= 2 * max(best, args.floor)
            verdict = ("yes" if ok else "NO") + " (%.1fx)" % (res["auto"]["secs"] / max(best, 1e-3))
        rows.append((name, res, p2, verdict))
        print("%-60s native %-8s asp %-8s auto %-8s (%s) plog2 %-8s %s" % (
            name[-60:], fmt(res["native"]), fmt(res["asp"]), fmt(res["auto"]),
            res["auto"].get("used", "-"), fmt(p2), verdict), flush=True)

    within = sum(1 for r in rows if r[3].startswith("yes"))
    measured = sum(1 for r in rows if r[3] != "none answers")
    # the community's programs (the target) and our knowledge bases, counted apart
    ours_rows = [r for r in rows if r[0].startswith("ours:")]
    ours_within = sum(1 for r in ours_rows if r[3].startswith("yes"))
    ours_measured = sum(1 for r in ours_rows if r[3] != "none answers")
    with open(args.out, "w", encoding="utf-8") as f:
        w = f.write
        w("# P-log back ends: native, asp and auto on community-style programs\n\n")
        w("Generated by `tools/plog_conformance/bench.py` on %s; do not edit by hand, re-run it:\n\n"
          % datetime.date.today().isoformat())
        w("```\n/usr/bin/python3 tools/plog_conformance/bench.py PLOG2_CHECKOUT "
          "[--plog2 PLOG2_BINARY] [--timeout %g] [--repeat %d]\n```\n\n" % (args.timeout, args.repeat))
        w("Wall-clock seconds of the whole `plog` process per back end (median of %d run(s), "
          "the back ends interleaved round by round), timeout %g s. *auto used*: the "
          "engine(s) that answered under auto. *within 2x*: auto takes at most twice the faster of native and asp (times under %g s count as %g s: "
          "process start-up). plog2.0: the faster of its two algorithms that answers. "
          "Programs: plog2.0's `plogapp/tests` (without the error programs), the classic "
          "solver's examples (`oldplog/Examples`), and our knowledge bases.\n\n"
          % (args.repeat, args.timeout, args.floor, args.floor))
        w("Auto within 2x of the faster path: **%d of %d** programs that some path answers "
          "(the community's programs: %d of %d; our knowledge bases: %d of %d).\n\n"
          % (within, measured, within - ours_within, measured - ours_measured, ours_within,
             ours_measured))
        w("| program | native s | asp s | auto s | auto used | plog2.0 s | within 2x |\n")
        w("|---|---|---|---|---|---|---|\n")
        for name, res, p2, verdict in rows:
            w("| %s | %s | %s | %s | %s | %s | %s |\n" % (
                name, fmt(res["native"]), fmt(res["asp"]), fmt(res["auto"]),
                res["auto"].get("used", "-"), fmt(p2), verdict))
    print("wrote %s (%d of %d within 2x)" % (args.out, within, measured))


if __name__ == "__main__":
    main()
