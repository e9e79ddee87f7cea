#!/usr/bin/python3
"""P-log conformance harness: runs the plog2.0 test programs through our `plog`.

Given an extracted plog2.0 checkout (github.com/iensen/plog2.0; GPL-3, so its programs are
read from the checkout at run time and never copied into this repository), every program
under plogapp/tests is run through our `plog` with the default back end (auto) and with
`--backend asp`, and, when a built plog2.0 binary is given, through plog2.0 with both of its
algorithms (naive and dco). Answers are compared to 1e-6 against the reference, which is, in
order: the value plog2.0's own gtests assert for the program (test/*.cpp), else plog2.0's
answer when its two algorithms agree. The programs of plogapp/tests/errors must be refused;
there the harness checks that we report file:line:col and shows plog2.0's expected message.

The report (default docs/plog_conformance.md) is generated, so that its figures cannot go
stale: re-run this script after changing the parser or the back ends.

usage: run.py PLOG2_DIR [--plog PATH] [--plog2 PATH] [--out FILE] [--timeout S]
"""

import argparse
import ast
import json
import operator
import os
import re
import subprocess
import sys
import time

TOL = 1e-6
HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
EXTENSIONS = (".plog", ".plg", ".txt")

# Programs that plog2.0 answers although they have no P-log answer, with the hand check (the
# report prints it in full). We refuse them; the summary counts them as "plog2.0 wrong".
PLOG2_WRONG = {
    "plogapp/tests/aspocp_amai/section1/secondprogram.plog": (
        "`random(a)` over {0, 1, 2} with `pr(a = 0) = pr(a = 1) = pr(a = 2) = 1/2`. Every "
        "value of a has an assigned probability and they sum to 3/2. Baral, Gelfond and "
        "Rushton (2009) ask that the assigned probabilities of an attribute term in a world "
        "sum to 1 when every value has one, and to at most 1 otherwise (their unitary "
        "programs); only then are the pr-atoms the probabilities the program states. This "
        "program is not unitary. Taken mechanically, the unnormalised measure of each of the "
        "three worlds {a = i} is PA = 1/2. The normalised measure is (1/2) / (3/2) = 1/3, and "
        "that is plog2.0's answer to ?a = 1. But the program itself states P(a = 1) = 1/2 "
        "with no condition, so the answer 1/3 contradicts its own pr-atom. We refuse the "
        "program and name the pr-atoms and the sum 1.5 > 1."),
}

# Programs where a reading had to be chosen, with the reasoning (printed in the report).
READINGS = {
    "plogapp/tests/aspocp_amai/section3_notpublished/example6.plog": (
        "`do(a, f, true).` and `alarm :- do(A, f, true), not authorized(A, f).`: `a` is an "
        "agent (no attribute), so the fact is read as plog2.0's agent form do(agent, f, y) "
        "with the flag left out: agent a sets f = true. The body literal holds for the "
        "argument tuples of the program's do statements (A = a). a is not authorized, so "
        "alarm holds in every world: P(alarm) = 1. plog2.0 dco gives 1; its naive "
        "algorithm finds no world."),
    "plogapp/tests/simplecrrule.plog": (
        "Consistency-restoring rules as plog2.0 translates them (libplog statement.cpp: "
        "`appl(r) | -appl(r) :- body`, `head :- body, appl(r)`, `#minimize{1,appl(r,X)}`, "
        "clingo `--opt-mode=optN --project`). The possible worlds are the answer sets that "
        "apply the fewest cr-rule instances over the whole program, each distinct world once. "
        "Here `random(p) :+.` must apply (otherwise q fails and r = true clashes with the "
        "fact r = false), giving two worlds p = true and p = false: 1/2."),
    "plogapp/tests/multipleabdsupports.plog": (
        "Three supports of size 1: {a :+}, {b :+} (both give the world {a, b, c}) and "
        "{c :+} (world {c}). Two distinct worlds: P(a) = 1/2."),
}


def safe_eval(expr):
    """Evaluate a numeric literal expression such as `1.0 / 3.0` from a gtest assertion."""
    ops = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.USub: operator.neg}

    def ev(n):
        if isinstance(n, ast.Constant) and isinstance(n.value, (int, float)):
            return float(n.value)
        if isinstance(n, ast.BinOp) and type(n.op) in ops:
            return ops[type(n.op)](ev(n.left), ev(n.right))
        if isinstance(n, ast.UnaryOp) and type(n.op) in ops:
            return ops[type(n.op)](ev(n.operand))
        raise ValueError(expr)

    return ev(ast.parse(expr.strip(), mode="eval").body)


def expected_answers(root):
    """Map program path (relative to root) -> (value, tolerance, test name) from test/*.cpp.

    Only the assertions of the new version (compute_query) are read; commented-out tests are
    skipped. When two tests assert different values for one program, both are kept."""
    out = {}
    pat = re.compile(r'^\s*TEST\((\w+),\s*(\w+)\)\s*\{\s*ASSERT_NEAR\('
                     r'(?:compute_query|run_old_plog)\("([^"]+)"'
                     r'[^)]*\),\s*([^,]+),\s*([^)]+)\)', re.M)
    tdir = os.path.join(root, "test")
    if not os.path.isdir(tdir):
        return out
    for name in sorted(os.listdir(tdir)):
        if not name.endswith(".cpp"):
            continue
        with open(os.path.join(tdir, name), encoding="utf-8", errors="replace") as f:
            text = f.read()
        for m in pat.finditer(text):
            try:
                val = safe_eval(m.group(4))
            except (ValueError, SyntaxError):
                continue
            path = m.group(3)
            if path.startswith("../../plog/"):  # the classic solver's tests run from elsewhere
                path = path[len("../../plog/"):]
            out.setdefault(path, []).append((val, m.group(5).strip(), m.group(1) + "." + m.group(2)))
    return out


def expected_errors(root):
    """Map error program path -> the message plog2.0's tests expect (test/errors.cpp)."""
    out = {}
    path = os.path.join(root, "test", "errors.cpp")
    if not os.path.exists(path):
        return out
    with open(path, encoding="utf-8", errors="replace") as f:
        text = f.read()
    for m in re.finditer(r'auto error = "((?:[^"\\]|\\.)*)";\s*EXPECT_THAT\(get_error\("([^"]+)"\)',
                         text):
        out[m.group(2)] = m.group(1)
    return out


def run(cmd, timeout, cwd):
    t0 = time.time()
    try:
        p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           timeout=timeout, universal_newlines=True)
        return p.returncode, p.stdout, p.stderr, time.time() - t0
    except subprocess.TimeoutExpired:
        return None, "", "timeout after %g s" % timeout, time.time() - t0


def run_ours(plog, prog, backend, timeout, cwd):
    """Our answers: list of probabilities (one per query), or an error string."""
    cmd = [plog, prog, "--json"]
    if backend:
        cmd += ["--backend", backend]
    rc, out, err, secs = run(cmd, timeout, cwd)
    if rc is None:
        return {"status": "timeout", "error": err, "secs": secs}
    answers, errors, warnings = [], [], []
    for line in out.splitlines():
        line = line.strip()
        if not line.startswith("{"):
            continue
        try:
            d = json.loads(line)
        except ValueError:
            continue
        for wmsg in d.get("warnings", []):
            if wmsg not in warnings:
                warnings.append(wmsg)
        if "probability" in d and d["probability"] is not None:
            answers.append(float(d["probability"]))
        elif "error" in d:
            errors.append(str(d["error"]))
    if rc != 0 or errors:
        msg = (err.strip() or "; ".join(errors) or out.strip()).splitlines()
        return {"status": "rejected", "error": msg[0] if msg else "exit %d" % rc,
                "answers": answers, "secs": secs}
    return {"status": "ok", "answers": answers, "secs": secs, "warnings": warnings}


def run_plog2(plog2, prog, algo, timeout, cwd):
    rc, out, err, secs = run([plog2, prog, "--algo=" + algo], timeout, cwd)
    if rc is None:
        return {"status": "timeout", "secs": secs}
    # plog2.0 prints `answer: 0.300000`
    m = re.search(r"answer:\s*([0-9]+(?:\.[0-9]*)?(?:[eE][+-]?[0-9]+)?)", out)
    if rc != 0 or not m:
        msg = (err.strip() or out.strip()).splitlines()
        return {"status": "fails", "error": msg[0] if msg else "exit %d" % rc, "secs": secs}
    return {"status": "ok", "answers": [float(m.group(1))], "secs": secs}


def has_location(msg, prog_rel):
    """True when an error message starts with file:line:col naming the program."""
    return re.search(re.escape(os.path.basename(prog_rel)) + r":\d+:\d+", msg) is not None


def classify(ours, ref, tol=TOL, plog2_wrong=False):
    if ours["status"] == "timeout":
        return "timeout"
    if ours["status"] == "rejected":
        return "plog2.0 wrong" if plog2_wrong else "rejected"
    if not ours["answers"]:
        return "no query"
    if ref is None:
        return "no reference"
    return "agree" if abs(ours["answers"][0] - ref) <= tol else "wrong"


def md_escape(s):
    return s.replace("|", "\\|").replace("\n", " ")[:160]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("plog2_dir", help="extracted plog2.0 checkout (with plogapp/tests)")
    ap.add_argument("--plog", default=os.path.join(REPO, "catkin_ws/devel/lib/krr_core/plog"))
    ap.add_argument("--plog2", default=None, help="built plog2.0 binary (optional)")
    ap.add_argument("--out", default=os.path.join(REPO, "docs/plog_conformance.md"))
    ap.add_argument("--timeout", type=float, default=30.0, help="seconds per run")
    ap.add_argument("--only", default=None, help="regular expression on program paths")
    args = ap.parse_args()

    root = os.path.abspath(args.plog2_dir)
    tests = os.path.join(root, "plogapp", "tests")
    if not os.path.isdir(tests):
        sys.exit("no plogapp/tests under %s" % root)
    expect = expected_answers(root)
    expect_err = expected_errors(root)
    progs = []
    # plog2.0's own test programs, then the classic solver's examples (classic dialect)
    for top in (tests, os.path.join(root, "oldplog", "Examples")):
        for d, _, files in os.walk(top):
            for f in files:
                p = os.path.relpath(os.path.join(d, f), root)
                if f in ("out.txt", "result.txt") or not (f.endswith(EXTENSIONS) or f == "simple"):
                    continue
                if not args.only or re.search(args.only, p):
                    progs.append(p)
    progs.sort()

    rows, err_rows = [], []
    backends = [("auto", None), ("asp", "asp")]
    for p in progs:
        is_err = "/errors/" in p
        res = {b: run_ours(args.plog, p, flag, args.timeout, root) for b, flag in backends}
        p2 = {}
        if args.plog2 and not is_err:
            for algo in ("naive", "dco"):
                p2[algo] = run_plog2(args.plog2, p, algo, args.timeout, root)
        if is_err:
            r = res["auto"]
            ok = r["status"] == "rejected" and has_location(r.get("error", ""), p)
            err_rows.append((p, ok, r, expect_err.get(p, "")))
            print("%-60s %s" % (p, "refused" if ok else "NOT REFUSED"), flush=True)
            continue
        # reference value
        ref, ref_src, note, tol = None, "", "", TOL
        if p in expect:
            vals = sorted(set(round(v, 9) for v, _, _ in expect[p]))
            ref, ref_src = expect[p][0][0], "plog2.0 test"
            # the asserted value is written with 5-6 digits (0.33333): allow the test's own
            # tolerance when it is wider than ours
            try:
                tol = max(TOL, safe_eval(expect[p][0][1]))
            except (ValueError, SyntaxError):
                pass
            if len(vals) > 1:
                note = "plog2.0's tests assert different values: %s" % vals
        p2_ok = [x["answers"][0] for x in p2.values() if x["status"] == "ok"]
        if p2:
            if len(p2_ok) == 2 and abs(p2_ok[0] - p2_ok[1]) > TOL:
                note += " plog2.0 naive %.6g vs dco %.6g disagree." % tuple(p2_ok)
            if ref is None and p2_ok and (len(p2_ok) == 1 or abs(p2_ok[0] - p2_ok[1]) <= TOL):
                ref, ref_src = p2_ok[0], "plog2.0 run"
            elif ref is not None and p2_ok and abs(p2_ok[0] - ref) > TOL:
                note += " plog2.0 run gives %.6g." % p2_ok[0]
        cls = {b: classify(res[b], ref, tol, p in PLOG2_WRONG) for b, _ in backends}
        if p in PLOG2_WRONG:
            note += " plog2.0 is wrong here: see the notes below."
        elif p in READINGS:
            note += " See the notes below."
        warns = res["auto"].get("warnings", [])
        if warns:
            m = re.match(r"(.*?): warning: value ('[^']*')", warns[0])
            first = ("%s %s" % (os.path.basename(m.group(1)), m.group(2))) if m else warns[0]
            note += " %d ill-sorted fact(s) left out with a warning, first: %s." % (
                len(warns), first)
        # our two back ends must agree with each other even where there is no reference
        a, s = res["auto"], res["asp"]
        if (a["status"] == "ok" and s["status"] == "ok" and a["answers"] and s["answers"] and
                any(abs(x - y) > TOL for x, y in zip(a["answers"], s["answers"]))):
            note += " our back ends disagree: auto %s, asp %s." % (a["answers"], s["answers"])
        rows.append((p, ref, ref_src, res, p2, cls, note.strip()))
        print("%-60s ref=%-10s auto=%-12s asp=%-12s %s" % (
            p, "-" if ref is None else "%.6g" % ref, cls["auto"], cls["asp"], note), flush=True)

    write_report(args, root, rows, err_rows, backends)


def write_report(args, root, rows, err_rows, backends):
    cats = ["agree", "wrong", "rejected", "plog2.0 wrong", "timeout", "no reference",
            "no query"]
    lines = []
    w = lines.append
    w("# P-log conformance: the plog2.0 test programs")
    w("")
    w("Generated by `tools/plog_conformance/run.py` on %s; do not edit by hand, re-run it:" %
      time.strftime("%Y-%m-%d"))
    w("")
    w("```")
    w("python3 tools/plog_conformance/run.py PLOG2_CHECKOUT [--plog2 PLOG2_BINARY]")
    w("```")
    w("")
    w("The programs are those of `plogapp/tests` in plog2.0 and the classic solver's examples "
      "bundled with it (`oldplog/Examples`) (github.com/iensen/plog2.0, GPL-3: "
      "they are read from a checkout, not kept here). The reference answer is the value that "
      "plog2.0's own gtests assert for the program (`test/*.cpp`), otherwise plog2.0's answer "
      "when it was run (`--plog2`) and its two algorithms agree. Answers agree within %g." % TOL)
    w("plog2.0 binary: %s." % (("`%s`" % args.plog2) if args.plog2 else
                               "not given (references from its tests only)"))
    w("")
    w("## Summary")
    w("")
    w("| programs | back end | " + " | ".join(cats) + " |")
    w("|---" * (len(cats) + 2) + "|")
    for label, pred in (("plog2.0 tests (`plogapp/tests`)", lambda p: p.startswith("plogapp/")),
                        ("classic examples (`oldplog/Examples`)", lambda p: p.startswith("oldplog/"))):
        for b, _ in backends:
            sel = [r for r in rows if pred(r[0])]
            counts = [sum(1 for r in sel if r[5][b] == c) for c in cats]
            w("| %s (%d) | %s | %s |" % (label, len(sel), b, " | ".join(str(c) for c in counts)))
    with_ref = [r for r in rows if r[1] is not None]
    w("")
    w("%d programs, %d with a reference answer. Error programs (`plogapp/tests/errors`): "
      "%d of %d refused with file:line:col." % (len(rows), len(with_ref),
                                                sum(1 for e in err_rows if e[1]), len(err_rows)))
    w("")
    w("Categories: *agree* = same answer as the reference; *wrong* = a different answer; "
      "*rejected* = we refuse the program (error shown); *plog2.0 wrong* = we refuse a "
      "program that plog2.0 answers but that has no P-log answer (hand check in the notes); "
      "*timeout* = over %g s; "
      "*no reference* = we answer but plog2.0 gives no value to compare with; "
      "*no query* = the program has no query." % args.timeout)
    w("")
    w("## Programs")
    w("")
    hdr = "| program | reference | auto | asp |"
    if args.plog2:
        hdr += " plog2.0 naive | plog2.0 dco |"
    w(hdr + " note |")
    w("|---" * (hdr.count("|")) + "|")

    def cell(r, c):
        if r["status"] == "ok":
            ans = ", ".join("%.6g" % x for x in r["answers"]) or "-"
            return "%s: %s (%.2f s)" % (c, ans, r["secs"])
        if r["status"] == "timeout":
            return "timeout"
        return "%s: `%s`" % (c, md_escape(r.get("error", "")))

    for p, ref, src, res, p2, cls, note in rows:
        rel = p[len("plogapp/tests/"):] if p.startswith("plogapp/tests/") else p
        line = "| %s | %s | %s | %s |" % (rel, "-" if ref is None else "%.6g" % ref,
                                          cell(res["auto"], cls["auto"]),
                                          cell(res["asp"], cls["asp"]))
        if args.plog2:
            for algo in ("naive", "dco"):
                x = p2.get(algo, {"status": "fails"})
                if x["status"] == "ok":
                    line += " %.6g |" % x["answers"][0]
                else:
                    line += " fails: `%s` |" % md_escape(x.get("error", x["status"]))
        w(line + " %s |" % md_escape(note))
    w("")
    w("## Notes")
    w("")
    for p, text in sorted(list(PLOG2_WRONG.items()) + list(READINGS.items())):
        if any(r[0] == p for r in rows):
            kind = "plog2.0 is wrong" if p in PLOG2_WRONG else "reading"
            w("- `%s` (%s): %s" % (p[len("plogapp/tests/"):] if p.startswith("plogapp/tests/")
                                   else p, kind, text))
    w("- Facts whose constants are outside their declared sort (nasa/F.plog's misspelt "
      "`streering_sensor2`, Poker's `kc(4) = 4` with `#kind = 1..3`) have no well-sorted "
      "ground instance. P-log grounds over sorts, and plog2.0 adds sort atoms for the head's "
      "arguments and value to every rule, so such facts are not in the ground program. We leave "
      "them out too, with a warning at file:line:col naming the value (stderr and the JSON "
      "rows). `plog --strict-sorts` makes them errors.")
    w("")
    w("## Error programs")
    w("")
    w("| program | refused with file:line:col | our message | plog2.0's expected message |")
    w("|---|---|---|---|")
    for p, ok, r, exp in err_rows:
        msg = r.get("error", "") if r["status"] == "rejected" else "accepted: %s" % r.get("answers")
        w("| %s | %s | `%s` | `%s` |" % (os.path.relpath(p, "plogapp/tests"), "yes" if ok else "**no**",
                                         md_escape(msg), md_escape(exp)))
    w("")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as f:
        f.write("\n".join(lines))
    print("wrote %s" % args.out)


if __name__ == "__main__":
    main()
