"""The evaluation suite behind `rosrun krr_eval evaluate`: run (or replay) the paper's experiments,
write tables, plots, params.json and report.md, print tables and the time per experiment."""
import argparse
import collections
import hashlib
import json
import os
import platform
import resource
import subprocess
import sys
import time
import traceback

from . import experiments, paths, rosnode
from .report import Table, claims_table, write_report
from .runner import Runner

DEFAULT_OUT = "krr_eval_out"  # without --out / --replay: in the current directory
USAGE = """\
Reproduce the paper's Section IV headlessly: run every experiment's trials on all cores (or a
Dask cluster), print the tables, write Markdown + CSV tables, PNG plots, params.json (seed,
parameters, versions, trial files) and report.md (the paper's numbers beside ours, one line
per claim with its verdict) into --out.

experiments: %s

examples:
  rosrun krr_eval evaluate --out out/eval          # paper's trial counts
  rosrun krr_eval evaluate --quick                 # small counts (CI), into ./%s
  rosrun krr_eval evaluate --out out/e --only exp2,exp3 --trials exp2=2000
  rosrun krr_eval evaluate --out out/e --trials-scale 0.1 --scheduler tcp://10.0.0.5:8786
  rosrun krr_eval evaluate --replay out/eval       # recompute tables from saved trials
  rosrun krr_eval evaluate --only exp2 --site config/sites/lab --out out/lab  # another building
  rosrun krr_eval evaluate _out:=/tmp/e _quick:=true   # as a ROS node
Works from any directory: config/ and the programs are found through the package
(KRR_ROOT overrides the repository root, KRR_BIN_DIR the programs' folder).
""" % (", ".join("%s (%s)" % (k, v.split(". ", 1)[1].split(":")[0].split(" (")[0])
                for k, v in experiments.TITLES.items()), DEFAULT_OUT)

FLAGS = ("quick", "ros", "no-ros", "no-progress", "allow-unconverged")


def parse_trials(values, parser):
    """--trials N (all experiments) or --trials exp2=N[,exp4=M] (repeatable)."""
    out = {}
    for v in values or []:
        for part in v.split(","):
            part = part.strip()
            if not part:
                continue
            key, _, num = part.rpartition("=")
            try:
                n = int(num)
            except ValueError:
                parser.error("--trials %s: '%s' is not an integer" % (v, num))
            if n < 2:
                parser.error("--trials %s: at least 2 trials are needed" % v)
            if key and key not in experiments.EXPERIMENTS:
                parser.error("--trials %s: unknown experiment '%s' (%s)"
                             % (v, key, ", ".join(experiments.EXPERIMENTS)))
            for k in ([key] if key else experiments.EXPERIMENTS):
                out[k] = n
    return out


def build_parser():
    ap = argparse.ArgumentParser(prog="evaluate", description=USAGE,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", help="output folder (default: ./%s; with --replay: the replayed "
                    "folder)" % DEFAULT_OUT)
    ap.add_argument("--only", help="comma-separated experiments (default: all)")
    ap.add_argument("--trials", action="append", metavar="N|EXP=N",
                    help="trials for all experiments or per experiment (repeatable)")
    ap.add_argument("--trials-scale", type=float, default=1.0,
                    help="multiply the paper's trial counts (default 1)")
    ap.add_argument("--quick", action="store_true", help="small trial counts (CI smoke run)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--alpha", type=float, default=0.05, help="significance level of claims")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                    help="CLI processes at a time (default: all cores)")
    ap.add_argument("--scheduler", help="Dask distributed scheduler address, tcp://host:port")
    ap.add_argument("--chunks-per-worker", type=int, default=4)
    ap.add_argument("--replay", metavar="DIR", help="recompute from DIR/trials/*.csv")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    ap.add_argument("--solver-trials", type=int, metavar="N",
                    help="dialog solver's trial budget for exp2-exp4 (default: "
                         "config/experiments/delivery_trials.yaml's, certified; a smaller "
                         "budget is faster, and its tables need --allow-unconverged)")
    ap.add_argument("--allow-unconverged", action="store_true",
                    help="report tables resting on dialog policies not certified to "
                         "config/dialog.yaml's precision (the report says so; a --quick "
                         "smoke run does this without the flag)")
    ap.add_argument("--site", metavar="DIR",
                    help="run on a site folder (config/sites/NAME, relative: to the current "
                         "directory, else the repository root) instead of the paper's office: "
                         "exp2 only (Table I-style delivery with the site's rooms, people and "
                         "items); the paper's office comparisons are skipped")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--ros", action="store_true", help="run as a ROS node (needs a master)")
    g.add_argument("--no-ros", action="store_true", help="never start a ROS node")
    return ap


def _sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def versions(programs):
    """Python packages, git commit of the repository, and the CLIs used (path, sha256)."""
    import matplotlib
    import numpy
    import scipy
    v = collections.OrderedDict([
        ("python", platform.python_version()), ("numpy", numpy.__version__),
        ("scipy", scipy.__version__), ("matplotlib", matplotlib.__version__),
        ("platform", platform.platform())])
    try:
        import distributed
        v["distributed"] = distributed.__version__
    except ImportError:
        pass
    try:
        commit = subprocess.run(["git", "-C", paths.root(), "rev-parse", "HEAD"],
                                capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", paths.root(), "status", "--porcelain"],
                               capture_output=True, text=True, timeout=10).stdout
        v["git"] = {"commit": commit or None, "modified_files": len(dirty.splitlines())}
    except (OSError, subprocess.SubprocessError):
        v["git"] = None
    progs = collections.OrderedDict()
    for name in sorted(programs):
        try:
            p = paths.program(name)
            st = os.stat(p)
            progs[name] = {"path": p, "sha256": _sha256(p), "bytes": st.st_size,
                           "modified": time.strftime("%Y-%m-%dT%H:%M:%S",
                                                     time.localtime(st.st_mtime))}
        except OSError as e:
            progs[name] = {"error": str(e)}
    v["programs"] = progs
    return v


def cpu_seconds():
    """CPU seconds used so far by this process and its finished child processes."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + ch.ru_utime + ch.ru_stime


def write_json(path, obj):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(obj, f, indent=2, sort_keys=False)
        f.write("\n")
    os.replace(tmp, path)


SITE_EXPERIMENTS = ("exp2",)  # the experiments that run on any site (--site)


def resolve_site(site, only, ap):
    """--site DIR as an absolute site folder, refused (ap.error) when it is no site folder or an
    experiment of `only` is one of the paper's office-specific ones."""
    other = [k for k in only if k not in SITE_EXPERIMENTS]
    if other:
        ap.error("--site supports %s only: %s %s the paper's office experiments (their places, "
                 "utterances and claims are the office's); run --only %s --site %s"
                 % (", ".join(SITE_EXPERIMENTS), ", ".join(other),
                    "is one of" if len(other) == 1 else "are", ",".join(SITE_EXPERIMENTS), site))
    for d in (site, paths.repo(site)):
        if os.path.isfile(os.path.join(d, "site.yaml")):
            return os.path.realpath(d)
    ap.error("--site %s: no site folder there (a folder with site.yaml, relative to the current "
             "directory or to %s)" % (site, paths.root()))


def main(argv=None, stdout=sys.stdout, stderr=sys.stderr):
    """Run the suite; returns the exit code (0: every experiment ran; 1: one failed; 2: usage)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    own, ros_args, private = rosnode.split_ros_args(argv)
    ap = build_parser()
    try:
        own += rosnode.params_to_args(private, FLAGS)
    except ValueError as e:
        ap.error(str(e))
    a = ap.parse_args(own)
    say = lambda m="": (stdout.write(m + "\n"), stdout.flush())  # noqa: E731

    recorded, rec_params = None, {}
    if a.replay:
        pj = os.path.join(a.replay, "params.json")
        if not os.path.exists(pj):
            ap.error("--replay %s: no params.json there (not an evaluation output folder)"
                     % a.replay)
        with open(pj) as f:
            rec_params = json.load(f)
        recorded = rec_params.get("experiments", {})
        a.seed = rec_params.get("seed", a.seed)
        a.site = a.site or rec_params.get("site")
        a.alpha = rec_params.get("alpha", a.alpha) if "--alpha" not in own else a.alpha
    out = a.out or a.replay or DEFAULT_OUT
    if a.only:
        only = [x.strip() for x in a.only.split(",") if x.strip()]
        bad = [x for x in only if x not in experiments.EXPERIMENTS]
        if bad:
            ap.error("--only: unknown experiment(s) %s (%s)"
                     % (", ".join(bad), ", ".join(experiments.EXPERIMENTS)))
    elif recorded is not None:
        only = [k for k in experiments.EXPERIMENTS if k in rec_params.get("completed", recorded)]
    else:
        only = list(experiments.EXPERIMENTS)
    if a.workers < 1 or a.chunks_per_worker < 1:
        ap.error("--workers and --chunks-per-worker must be at least 1")
    if a.trials_scale <= 0:
        ap.error("--trials-scale must be positive")
    trials = parse_trials(a.trials, ap)
    site = None
    if a.site:  # a replay keeps the recorded folder's path: it runs nothing there
        replayed = recorded is not None and a.site == rec_params.get("site")
        site = a.site if replayed else resolve_site(a.site, only, ap)
    os.makedirs(out, exist_ok=True)

    node = rosnode.start("krr_evaluate", "on" if a.ros else "off" if a.no_ros else "auto",
                         ros_args, log=lambda m: stderr.write(m + "\n"))
    note = node.progress if node else (lambda m: None)

    try:
        runner = Runner(workers=a.workers, scheduler=a.scheduler, record_dir=out,
                        replay_dir=a.replay, chunks_per_worker=a.chunks_per_worker,
                        progress=None if a.no_progress else stderr)
        if a.scheduler and not a.replay:
            say("Dask scheduler %s: %d worker threads" % (a.scheduler, runner.slots()))
    except (OSError, ValueError) as e:  # no trials/ to replay, scheduler unreachable
        stderr.write("evaluate: %s\n" % e)
        return 2
    ctx = experiments.Context(out, runner, seed=a.seed, scale=a.trials_scale, trials=trials,
                              quick=a.quick, alpha=a.alpha, recorded=recorded, log=say,
                              allow_unconverged=a.allow_unconverged,
                              solver_trials=a.solver_trials, site=site)
    params = collections.OrderedDict([
        ("tool", "rosrun krr_eval evaluate"), ("argv", argv), ("seed", a.seed), ("alpha", a.alpha),
        ("trials_scale", a.trials_scale), ("trials_overrides", trials), ("quick", a.quick),
        ("allow_unconverged", a.allow_unconverged), ("solver_trials", a.solver_trials),
        ("site", site),
        ("workers", a.workers), ("scheduler", a.scheduler),
        ("chunks_per_worker", a.chunks_per_worker), ("replayed_from", a.replay),
        ("experiments", ctx.params), ("completed", []), ("failed", {}),
        ("trial_sets", runner.records), ("times_s", collections.OrderedDict()),
        ("cpu_s", collections.OrderedDict()),
        ("cli_columns", experiments.COLUMNS)])
    results, times = [], params["times_s"]
    say("KRR-RL evaluation: %s%s, seed %d, %s%s -> %s" % (
        ", ".join(only), " on site %s" % site if site else "", a.seed,
        "replaying %s" % a.replay if a.replay else
        ("Dask scheduler %s" % a.scheduler if a.scheduler else "%d workers" % a.workers),
        " (quick)" if a.quick else "", out))
    try:
        # Every experiment's trials go to the workers now, in order, so no worker idles while
        # one experiment's last chunks run and its tables are computed.
        try:
            for key in only:  # one call per experiment: each is split as run() would split it
                runner.prefetch(experiments.trial_sets(ctx, [key]))
        except (OSError, ValueError) as e:  # e.g. a CLI is missing: each experiment reports it
            say("prefetch skipped: %s" % e)
        for key in only:
            say("\n== %s" % experiments.TITLES[key])
            note("starting %s" % key)
            t0, c0 = time.monotonic(), cpu_seconds()
            try:
                res = experiments.EXPERIMENTS[key](ctx)
            except Exception as e:  # report, go on with the other experiments
                times[key] = time.monotonic() - t0
                params["cpu_s"][key] = cpu_seconds() - c0
                params["failed"][key] = "%s: %s" % (type(e).__name__, e)
                say("%s FAILED after %.1f s: %s: %s" % (key, times[key], type(e).__name__, e))
                if os.environ.get("KRR_EVAL_DEBUG"):
                    traceback.print_exc(file=stderr)
                continue
            times[key] = res.seconds = time.monotonic() - t0
            params["cpu_s"][key] = cpu_seconds() - c0
            params["completed"].append(key)
            results.append(res)
            for t in res.tables:
                t.save(out)
                if not t.name.startswith("exp1_curve"):
                    say(t.text())
                    say()
            for c in res.claims:
                say("  claim: %s -- %s [%s]" % (c.claim, c.ours, c.verdict))
            for f in res.figures:
                say("  figure: %s" % os.path.join(out, f))
            say("%s done in %.1f s" % (key, times[key]))
            note("%s done in %.1f s" % (key, times[key]))
            write_json(os.path.join(out, "params.json"), params)
    finally:
        runner.close()

    if a.replay and os.path.abspath(a.replay) == os.path.abspath(out):
        # replaying part of a folder into itself: keep what the other experiments recorded
        for k, v in rec_params.get("trial_sets", {}).items():
            runner.records.setdefault(k, v)
        for k, v in recorded.items():
            ctx.params.setdefault(k, v)
        params["completed"] = [k for k in experiments.EXPERIMENTS
                               if k in params["completed"] or k in rec_params.get("completed", [])]
    params["versions"] = versions({r["program"] for r in runner.records.values()})
    write_json(os.path.join(out, "params.json"), params)
    claims = [c for r in results for c in r.claims]
    ct = claims_table(claims)
    ct.save(out)
    with open(os.path.join(out, "claims.json"), "w") as f:
        json.dump([c.as_dict() for c in claims], f, indent=2)
    header = ["# KRR-RL: the paper's experiments (Sec. IV) reproduced", "",
              "Seed %d; trials per set: %s; significance level %.2f. %s" % (
                  a.seed, ", ".join("%s %s" % (k, v["trials"]) for k, v in ctx.params.items()
                                    if "trials" in v), a.alpha,
                  "Recomputed from the trials recorded in `%s`." % a.replay if a.replay else
                  "Trials: `trials/*.csv`; all parameters and versions: `params.json`."),
              "Command: `rosrun krr_eval evaluate %s`" % " ".join(argv)]
    if site:
        header += ["", "Site: `%s` (not the paper's office: the comparisons with the paper are "
                   "skipped)." % site]
    if params["failed"]:
        header += ["", "**Failed experiments:** " + "; ".join(
            "%s (%s)" % kv for kv in params["failed"].items())]
    write_report(os.path.join(out, "report.md"), header, results, times, params["cpu_s"])
    cpu = params["cpu_s"]
    tt = Table("times", "Time per experiment (CPU: this process and its CLI processes; not "
               "counted on a Dask cluster)", ["experiment", "wall s", "CPU s"],
               [[k, v, cpu.get(k)] for k, v in times.items()] +
               [["total", sum(times.values()), sum(cpu.values())]],
               formats={"wall s": "%.1f", "CPU s": "%.1f"})
    say("\n" + ct.text() if claims else "\n(no claims)" if not site else
        "\n(no claims: the paper's claims are about its office and are skipped on site %s)"
        % os.path.basename(site))
    say("\n%d of %d claims supported" % (sum(c.supported for c in claims), len(claims)))
    say("\n" + tt.text())
    say("\nreport: %s" % os.path.join(out, "report.md"))
    if node:
        node.report(os.path.abspath(os.path.join(out, "report.md")))
        node.shutdown()
    return 1 if params["failed"] else 0
