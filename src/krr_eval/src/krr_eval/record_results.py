"""Record an evaluation run in docs/eval and regenerate the READMEs' generated blocks from it.

    rosrun krr_eval record_results --from out/eval   # copy the run, add the model report,
                                                   # rewrite README's block
    rosrun krr_eval record_results --check           # exit 1 if README's blocks differ from
                                                   # docs/ (tools test)

The results block is in src/krr_eval/README.md. It also puts docs/example_session.txt (written
by tools/record_session.sh, a real ROS session) into the example-session block of
src/krr_ros/README.md.

`--from DIR` copies the run's report.md, claims.{md,json}, every table (*.md) and figure
(*.png) and a trimmed params.json into docs/eval, runs `delivery_trials --model-report` at
br 0.1 / 0.3 / 0.5 / 0.7 (seed of the run) into docs/eval/model_report.json, and rewrites the
README between the markers below. The README's numbers are therefore never typed by hand:
they are the recorded run's, and `--check` (run by the tools tests) fails when the two drift.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys

from . import paths

ROOT = paths.root()
DOCS = os.path.join(ROOT, "docs", "eval")
README = os.path.join(ROOT, "src", "krr_eval", "README.md")  # the results block
SESSION_README = os.path.join(ROOT, "src", "krr_ros", "README.md")  # the example session
BEGIN = "<!-- recorded-results:begin (rosrun krr_eval record_results writes this block) -->"
END = "<!-- recorded-results:end -->"
SESSION = os.path.join(ROOT, "docs", "example_session.txt")
SESSION_BEGIN = "<!-- example-session:begin (tools/record_session.sh records it) -->"
SESSION_END = "<!-- example-session:end -->"
MODEL_BRS = (0.1, 0.3, 0.5, 0.7)
PARAMS_KEPT = ("seed", "alpha", "trials_scale", "quick", "allow_unconverged", "workers",
               "experiments", "completed", "failed", "times_s", "cpu_s", "versions", "git")


def copy_run(src):
    if not os.path.exists(os.path.join(src, "claims.json")):
        raise SystemExit("record_results: %s has no claims.json (not an evaluation output)" % src)
    if os.path.isdir(DOCS):
        shutil.rmtree(DOCS)
    os.makedirs(DOCS)
    for name in sorted(os.listdir(src)):
        if name.endswith((".md", ".png")) or name == "claims.json":
            shutil.copy(os.path.join(src, name), os.path.join(DOCS, name))
    with open(os.path.join(src, "params.json")) as f:
        params = json.load(f)
    kept = {k: params[k] for k in PARAMS_KEPT if k in params}
    with open(os.path.join(DOCS, "params.json"), "w") as f:
        json.dump(kept, f, indent=1, sort_keys=True)
        f.write("\n")
    return kept


def model_report(seed, trials):
    exe = paths.program("delivery_trials")
    out = {}
    for br in MODEL_BRS:
        r = subprocess.run([exe, "--br", "%g" % br, "--condition", "learned", "--seed",
                            str(seed), "--trials", str(trials), "--model-report", "--root", ROOT],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           universal_newlines=True)
        if r.returncode != 0:
            raise SystemExit("record_results: delivery_trials --model-report --br %g failed:\n%s"
                             % (br, r.stderr[-2000:]))
        out["%g" % br] = json.loads(r.stdout)
    out = {"trials": trials, "brs": out}
    with open(os.path.join(DOCS, "model_report.json"), "w") as f:
        json.dump(out, f, indent=1, sort_keys=True)
        f.write("\n")


def load(name):
    with open(os.path.join(DOCS, name)) as f:
        return json.load(f)


def render():
    """The README block from docs/eval (pure: the same files give the same text)."""
    claims, params, report = load("claims.json"), load("params.json"), load("model_report.json")
    models = report["brs"]
    lines = [BEGIN, ""]
    supported = sum(1 for c in claims if c["verdict"] == "supported")
    times = params.get("times_s", {})
    lines.append("Recorded run (`docs/eval/`, seed %s, %s): %d of %d claims supported; the full "
                 "report with every table, figure and the reason for each unsupported claim is "
                 "[`docs/eval/report.md`](%s) (your own run writes the same "
                 "`report.md` in its `--out` folder). Evaluation time %.0f s wall (%s; the trials "
                 "of every experiment are queued at the start, so one experiment's time is the "
                 "wait for its last chunks plus its analysis)."
                 % (params.get("seed"),
                    "default trial counts" if params.get("trials_scale", 1) == 1
                    and not params.get("quick") else "reduced trial counts",
                    supported, len(claims),
                    os.path.relpath(os.path.join(DOCS, "report.md"), os.path.dirname(README)),
                    sum(times.values()),
                    ", ".join("%s %.0f s" % (k, v) for k, v in sorted(times.items()))))
    lines += ["", "| experiment | claims supported | claims |", "| --- | --- | --- |"]
    order = []
    for c in claims:
        if c["experiment"] not in order:
            order.append(c["experiment"])
    for e in order:
        cs = [c for c in claims if c["experiment"] == e]
        lines.append("| %s | %d / %d | %s |" % (
            e, sum(c["verdict"] == "supported" for c in cs), len(cs),
            "; ".join("%s: %s" % (c["claim"], "yes" if c["verdict"] == "supported" else "no")
                      for c in cs).replace("|", "\\|")))
    lines += ["", "Learned knowledge against the truth (`delivery_trials --model-report`, learned "
              "condition): the largest error of the believed P^N over every room and both "
              "directions; the dialog policy's certified bounds at the prior; the share of "
              "{:,} deliveries served only because the turn limit was reached (at br 0.1, "
              "0.5 and 0.7 these are the trials of Table I's learned condition; br 0.3 is the "
              "outdated model).".format(report["trials"]), "",
              "| br | max abs P^N error | policy bounds (gap) | forced serves |",
              "| --- | --- | --- | --- |"]
    for br in sorted(models, key=float):
        m = models[br]
        pol = m.get("policy", {})
        forced = m.get("forced_serve_rate")
        lines.append("| %s | %.3f | [%.2f, %.2f] (%.2f) | %s |" % (
            br, m["max_abs_error"], pol.get("lower", float("nan")),
            pol.get("upper", float("nan")), pol.get("gap", float("nan")),
            "-" if forced is None else "%.2f %%" % (100.0 * forced)))
    lines += ["", END]
    return "\n".join(lines)


def render_session():
    with open(SESSION) as f:
        body = f.read().rstrip("\n")
    return "\n".join([SESSION_BEGIN, "```", body, "```", SESSION_END])


def readme_block(text, begin=BEGIN, end=END, name="README.md"):
    a, b = text.find(begin), text.find(end)
    if a < 0 or b < a:
        raise SystemExit("record_results: %s has no %s ... %s markers" % (name, begin, end))
    return a, b + len(end)


def blocks():
    """(file, begin marker, end marker, rendered text) of every generated README block."""
    return [(README, BEGIN, END, render()),
            (SESSION_README, SESSION_BEGIN, SESSION_END, render_session())]


def main(argv=None):
    ap = argparse.ArgumentParser(prog="record_results", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--from", dest="src", help="an evaluation output folder to record")
    ap.add_argument("--check", action="store_true",
                    help="only compare the READMEs' blocks with docs/ (exit 1 if they differ)")
    a = ap.parse_args(argv)
    texts = {}
    for path, _, _, _ in blocks():
        if path not in texts:
            with open(path) as f:
                texts[path] = f.read()
    if a.check:
        for path, begin, end, want in blocks():
            text = texts[path]
            i, j = readme_block(text, begin, end, os.path.relpath(path, ROOT))
            if text[i:j] != want:
                sys.stderr.write("record_results: %s's block %s differs from docs/; run "
                                 "rosrun krr_eval record_results to regenerate it\n"
                                 % (os.path.relpath(path, ROOT), begin))
                return 1
        return 0
    if a.src:
        params = copy_run(a.src)
        # As many deliveries as Table I's learned condition had (same seed: the same trials).
        trials = params.get("experiments", {}).get("exp2", {}).get("trials", 10000)
        model_report(params.get("seed", 1), trials)
    new = dict(texts)
    for path, begin, end, want in blocks():
        i, j = readme_block(new[path], begin, end, os.path.relpath(path, ROOT))
        new[path] = new[path][:i] + want + new[path][j:]
    for path, text in new.items():
        tmp = path + ".tmp"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, path)
        print("record_results: %s rewritten from %s" % (os.path.relpath(path, ROOT),
                                                         os.path.relpath(DOCS, ROOT)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
