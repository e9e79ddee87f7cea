"""Experiment 5: new circumstances (merged controller vs random pick vs oracle)."""
import collections

import numpy as np

from . import stats
from .paper import PAPER_NEW_CIRCUMSTANCES
from .context import TITLES
from .report import Claim, Est, Result, Table
from .runner import TrialSpec


# ---------------------------------------------------------------------------------------------
# Experiment 5: new circumstances
MERGED_COLUMNS = ("trial, success_merged, success_baseline[, success_oracle, true_setting (or "
                  "setting), possible_settings (a+b), baseline_pick, learning_run, "
                  "success_own_<s>..., p_merged, p_baseline, p_oracle, p_own_<s>... (exact, in the "
                  "true setting), p_self_<s>... (own controller in its own setting)]")
# new_circumstances learns each learning run it needs (about 0.9 s of CPU) and then runs a trial
# in well under a millisecond, so more processes would only learn the same runs again.
EXP5_MIN_CHUNK = 5000
EXP5_LABELS = collections.OrderedDict([
    ("merged", "KRR-RL: merged model of the possible settings"),
    ("baseline", "random pick of a possible setting's own controller (paper's baseline)"),
    ("oracle", "oracle: the true setting's own controller (not in the paper)")])


def _exp5_pct(x):
    return "%.1f%%" % (100.0 * x)


def _exp5_key_label(key):
    return EXP5_LABELS.get(key, "own controller of %s, whatever the truth" % key[4:])


def _exp5_short(key):
    return {"merged": "merged", "baseline": "random pick", "oracle": "oracle"}.get(
        key, "own " + key[4:])


def exp5_evidence(t):
    """The per-trial outcomes of a new_circumstances table, by controller: success (bool) and,
    where the CLI wrote them, exact success probabilities in the true setting; the draw of each
    trial (possible settings, true setting, pick) and its learning run."""
    for c in ("success_merged", "success_baseline"):
        if not t.has(c):
            raise ValueError("%s: no column '%s' (expected one row per trial with every "
                             "controller's success: %s)" % (t.source, c, MERGED_COLUMNS))
    if len(t) < 1:
        raise ValueError("%s: no trials" % t.source)
    settings = [h[len("success_own_"):] for h in t.header if h.startswith("success_own_")]
    keys = ["merged", "baseline"] + (["oracle"] if t.has("success_oracle") else [])
    keys += ["own:" + s for s in settings]
    col = {"merged": "merged", "baseline": "baseline", "oracle": "oracle"}
    succ, exact = collections.OrderedDict(), collections.OrderedDict()
    for k in keys:
        name = col.get(k, "own_" + k[4:])
        succ[k] = t.bools("success_" + name)
        if t.has("p_" + name):
            exact[k] = t.floats("p_" + name)
    truth_col = t.find("true_setting", "setting")
    pick_col = t.find("baseline_pick", "baseline_choice")
    ev = {"n": len(t), "keys": keys, "settings": settings, "succ": succ, "exact": exact,
          "truth": t.strings(truth_col) if truth_col else None,
          "possible": t.strings("possible_settings") if t.has("possible_settings") else None,
          "pick": t.strings(pick_col) if pick_col else None,
          "run": t.ints("learning_run") if t.has("learning_run") else None,
          "self": collections.OrderedDict((s, t.floats("p_self_" + s)) for s in settings
                                          if t.has("p_self_" + s))}
    if ev["possible"] is not None:
        for i, (p, u) in enumerate(zip(ev["possible"], ev["truth"] or [])):
            if u not in p.split("+"):
                raise ValueError("%s data row %d: true setting '%s' is not one of the possible "
                                 "settings '%s'" % (t.source, i + 1, u, p))
    return ev


def _exp5_groups(ev):
    """Trial indices per (possible settings, true setting), in the settings' order."""
    if ev["truth"] is None:
        return collections.OrderedDict()
    order = {s: i for i, s in enumerate(ev["settings"])}
    poss = ev["possible"] or ["?"] * ev["n"]
    groups = collections.defaultdict(list)
    for i, (p, u) in enumerate(zip(poss, ev["truth"])):
        groups[(p, u)].append(i)

    def rank(g):
        return ([order.get(s, len(order)) for s in g[0].split("+")], order.get(g[1], len(order)))
    return collections.OrderedDict((g, groups[g]) for g in sorted(groups, key=rank))


def _exp5_rate(ev, key, idx=None, exact=True):
    """Mean success of a controller over trials idx: exact probabilities if written, else the
    observed success rate."""
    v = ev["exact"][key] if exact and key in ev["exact"] else ev["succ"][key]
    idx = range(ev["n"]) if idx is None else idx
    return float(np.mean([float(v[i]) for i in idx]))


def _exp5_pick_expectation(ev, idx=None):
    """The random pick's expected success (exact) in trials idx: the mean, over the possible
    settings, of their own controllers' exact success in the true setting; None if unknown."""
    if ev["possible"] is None or not ev["settings"] or not all(
            "own:" + s in ev["exact"] for s in ev["settings"]):
        return None
    idx = range(ev["n"]) if idx is None else idx
    vals = [np.mean([ev["exact"]["own:" + s][i] for s in ev["possible"][i].split("+")])
            for i in idx]
    return float(np.mean(vals))


def _exp5_other_rate(ev):
    """Mean exact success, in the true setting, of the possible settings' own controllers other
    than the true one (what a wrong pick gets); None if unknown."""
    if ev["possible"] is None or not ev["settings"] or not all(
            "own:" + s in ev["exact"] for s in ev["settings"]):
        return None
    vals = []
    for i in range(ev["n"]):
        others = [s for s in ev["possible"][i].split("+") if s != ev["truth"][i]]
        vals.append(np.mean([ev["exact"]["own:" + s][i] for s in others]))
    return float(np.mean(vals))


def _exp5_by_run(ev, key):
    """Mean (exact, else observed) success per learning run, with a t interval over the runs:
    it carries the spread between learning runs that per-trial intervals leave out."""
    if ev["run"] is None:
        return None
    v = ev["exact"][key] if key in ev["exact"] else [float(x) for x in ev["succ"][key]]
    per = collections.defaultdict(list)
    for r, x in zip(ev["run"], v):
        per[r].append(x)
    if len(per) < 2:
        return None
    return stats.mean_ci([np.mean(x) for x in per.values()])


def exp5_tables(ev):
    """The success table (every controller), the table per (possible settings, true setting)
    and the matrix of exact success probabilities behind the random pick."""
    tables = []
    has_exact = bool(ev["exact"])
    runs = len(set(ev["run"])) if ev["run"] is not None else 0
    cols = ["controller", "trials", "success rate (95% CI)"]
    if has_exact:
        cols.append("exact P(success) (mean, 95% CI)")
    if runs >= 2:
        cols.append("over learning runs (mean, 95% CI)")
    cols.append("paper")
    rows = []
    for k in ev["keys"]:
        v = ev["succ"][k]
        row = [_exp5_key_label(k), len(v),
               Est.of(stats.proportion_ci(sum(v), len(v)), "%.3f", asymmetric=True)]
        if has_exact:
            row.append(Est.of(stats.mean_ci(ev["exact"][k]), "%.3f") if k in ev["exact"]
                       else None)
        if runs >= 2:
            e = _exp5_by_run(ev, k)
            row.append(Est.of(e, "%.3f") if e is not None else None)
        row.append(PAPER_NEW_CIRCUMSTANCES.get(k))
        rows.append(row)
    mc = stats.mcnemar_exact(*_exp5_discordant(ev, "merged", "baseline"))
    note = ("Success: the goal reached within the step limit, one episode per controller and "
            "trial, all controllers of a trial on the same random numbers. Test (merged vs "
            "random pick): exact McNemar (paired), p = %s." % stats.format_p(mc.p))
    if has_exact:
        note += (" Exact P(success): the controller's success probability in the true setting "
                 "(absorbing chain of the simulator's dynamics), computed by the CLI.")
    if runs >= 2:
        note += (" Over learning runs: the mean per learning run and its t interval over the %d "
                 "runs (it includes the spread between learning runs, which the per-trial "
                 "intervals, conditional on the learned controllers, leave out)." % runs)
    tables.append(Table("exp5_new_circumstances", "Navigation success rate, setting unknown "
                        "(one of %s settings, drawn per trial)" % (
                            "two" if not ev["possible"] else
                            "%d" % len(ev["possible"][0].split("+"))),
                        cols, rows, note=note))

    groups = _exp5_groups(ev)
    if groups:
        cols = ["possible settings", "true setting", "trials"]
        cols += [_exp5_short(k) for k in ev["keys"]]
        pick_exp = _exp5_pick_expectation(ev) is not None
        if pick_exp:
            cols.append("random pick, expected (exact)")
        rows = []
        for (p, u), idx in groups.items():
            row = [p.replace("+", " or "), u, len(idx)]
            for k in ev["keys"]:
                v = [ev["succ"][k][i] for i in idx]
                row.append(Est.of(stats.proportion_ci(sum(v), len(v)), "%.3f", asymmetric=True))
            if pick_exp:
                row.append(_exp5_pick_expectation(ev, idx))
            rows.append(row)
        tables.append(Table("exp5_by_setting", "Success rate (95% CI) per possible settings "
                            "and true setting", cols, rows,
                            note="Random pick, expected: the mean of the possible settings' own "
                            "controllers' exact success in the true setting (the pick's "
                            "expectation without its coin flip)."))

    if has_exact and groups and ev["settings"] and all("own:" + s in ev["exact"]
                                                       for s in ev["settings"]):
        truths = [s for s in ev["settings"] if s in set(ev["truth"])]
        cols = ["controller"] + ["in %s" % u for u in truths]
        rows = []
        for s in ev["settings"]:
            rows.append(["own controller of %s" % s] + [
                _exp5_rate(ev, "own:" + s, [i for i in range(ev["n"]) if ev["truth"][i] == u])
                for u in truths])
        if ev["possible"] is not None:
            for p in collections.OrderedDict((g[0], None) for g in groups):
                row = ["merged %s" % p.replace("+", " or ")]
                for u in truths:
                    idx = groups.get((p, u))
                    row.append(_exp5_rate(ev, "merged", idx) if idx else None)
                rows.append(row)
        tables.append(Table("exp5_exact_matrix", "Exact P(success) of each controller in each "
                            "true setting (mean over trials)", cols, rows,
                            note="A random pick between the settings of a pair, in true setting "
                            "u, expects the mean of the pair's two own-controller entries in "
                            "column u; the oracle gets the diagonal."))
    return tables


def _exp5_discordant(ev, a, b):
    x, y = ev["succ"][a], ev["succ"][b]
    return (sum(1 for p, q in zip(x, y) if p and not q),
            sum(1 for p, q in zip(x, y) if q and not p))


def _exp5_extremes(ev, a, b):
    """(largest a - b, smallest a - b) over (possible settings, truth) groups, each as
    (group, rate a, rate b), using exact probabilities where written; None without groups."""
    groups = _exp5_groups(ev)
    if not groups:
        return None
    d = [(g, _exp5_rate(ev, a, idx), _exp5_rate(ev, b, idx)) for g, idx in groups.items()]
    d.sort(key=lambda x: x[1] - x[2])
    return d[-1], d[0]


def _exp5_group_text(g):
    (p, u), ra, rb = g
    where = ("may be in %s and is in %s" % (p.replace("+", " or "), u) if p != "?"
             else "is in %s" % u)
    return "when the robot %s (%s vs %s)" % (where, _exp5_pct(ra), _exp5_pct(rb))


def exp5_claims(ev, alpha=0.05):
    """The paper's claim (merged beats a random pick), what its numbers imply (merged beats
    even knowing the setting), and its magnitudes, each with a reason from our numbers."""
    claims = []
    n, k_exact = ev["n"], "exact, " if ev["exact"] else ""
    m, b = np.mean(ev["succ"]["merged"]), np.mean(ev["succ"]["baseline"])
    only_m, only_b = _exp5_discordant(ev, "merged", "baseline")
    test = stats.mcnemar_exact(only_m, only_b)
    ext = _exp5_extremes(ev, "merged", "baseline")
    reason = ("Over %d paired trials the merged controller succeeded in %s and the random pick "
              "in %s (only merged: %d trials, only the pick: %d; exact McNemar p = %s). "
              % (n, _exp5_pct(m), _exp5_pct(b), only_m, only_b, stats.format_p(test.p)))
    if m <= b:
        reason += "Merging did not help on average"
    elif test.p >= alpha:
        reason += "The difference of %.1f points is within the noise of %d trials" % (
            100 * (m - b), n)
    else:
        reason += "Merging helps"
    if ext:
        reason += ("; it gains most %s and least %s (%smerged vs pick)." % (
            _exp5_group_text(ext[0]), _exp5_group_text(ext[1]), k_exact))
    else:
        reason += "."
    claims.append(Claim(
        "5 new circ.", "merging learned models beats a random pick of one", "26.8% -> 83.8%",
        "%s -> %s, McNemar p = %s" % (_exp5_pct(b), _exp5_pct(m), stats.format_p(test.p)),
        m > b, test.p, alpha, reason=reason))

    paper_b, paper_m = PAPER_NEW_CIRCUMSTANCES["baseline"], PAPER_NEW_CIRCUMSTANCES["merged"]
    k = len(ev["possible"][0].split("+")) if ev["possible"] else 2
    oracle_cap = k * paper_b  # a random pick is right 1/k of the time: pick >= oracle / k
    if "oracle" in ev["succ"]:
        o = np.mean(ev["succ"]["oracle"])
        om, oo = _exp5_discordant(ev, "merged", "oracle")
        t2 = stats.mcnemar_exact(om, oo)
        ext = _exp5_extremes(ev, "merged", "oracle")
        reason = ("The oracle, driving the true setting's own controller, succeeded in %s and "
                  "the merged controller, one plan for every possible setting, in %s (only "
                  "merged: %d, only the oracle: %d; McNemar p = %s)." % (
                      _exp5_pct(o), _exp5_pct(m), om, oo, stats.format_p(t2.p)))
        if ext:
            reason += (" Merging can beat knowing the setting only where that setting's own "
                       "controller is poorly learned: it does best against the oracle %s and "
                       "worst %s (%smerged vs oracle)." % (
                           _exp5_group_text(ext[0]), _exp5_group_text(ext[1]), k_exact))
        claims.append(Claim(
            "5 new circ.", "implied by 26.8%% vs 83.8%%: the merged controller beats even the "
            "oracle that knows the setting (a random pick is right 1 time in %d, so the "
            "oracle is at most %s)" % (k, _exp5_pct(oracle_cap)),
            "oracle <= %s < 83.8%%" % _exp5_pct(oracle_cap),
            "oracle %s vs merged %s, McNemar p = %s" % (_exp5_pct(o), _exp5_pct(m),
                                                         stats.format_p(t2.p)),
            m > o, t2.p, alpha, reason=reason))

    mci = stats.proportion_ci(sum(ev["succ"]["merged"]), n)
    bci = stats.proportion_ci(sum(ev["succ"]["baseline"]), n)
    both = mci.lo <= paper_m <= mci.hi and bci.lo <= paper_b <= bci.hi
    claims.append(Claim(
        "5 new circ.", "the paper's rates: random pick 26.8%, merged 83.8% (each inside our 95% "
        "CI)", "26.8%, 83.8%", "%s [%s, %s], %s [%s, %s]" % (
            _exp5_pct(b), _exp5_pct(bci.lo), _exp5_pct(bci.hi), _exp5_pct(m),
            _exp5_pct(mci.lo), _exp5_pct(mci.hi)),
        both, reason=exp5_magnitude_reason(ev, k)))
    return claims


def exp5_magnitude_reason(ev, k=2):
    """When and why the paper's 83.8% vs 26.8% can or cannot arise, from our per-setting rates,
    in two sentences.

    A random pick among k possible settings takes the true setting's own controller (the
    oracle's) with probability 1/k and another one otherwise, so it expects
    oracle / k + (1 - 1/k) * other; 26.8% therefore needs an oracle of at most k * 26.8%, while
    the merged controller reaches 83.8%."""
    paper_b, paper_m = PAPER_NEW_CIRCUMSTANCES["baseline"], PAPER_NEW_CIRCUMSTANCES["merged"]
    cap = k * paper_b
    m = _exp5_rate(ev, "merged")
    first = ("A random pick takes the true setting's own controller 1 time in %d, so the paper's "
             "26.8%% needs an oracle of at most %s, and merging at 83.8%% would beat knowing the "
             "setting by at least %.0f points: possible only if the per-setting controllers are "
             "poorly learned even in their own setting and fail out of it." % (
                 k, _exp5_pct(cap), 100 * (paper_m - cap)))
    if "oracle" not in ev["succ"]:
        return first + " Ours: merged %s, random pick %s (no oracle column)." % (
            _exp5_pct(m), _exp5_pct(_exp5_rate(ev, "baseline")))
    o = _exp5_rate(ev, "oracle")
    other = _exp5_other_rate(ev)
    src = "exact" if "oracle" in ev["exact"] else "observed"
    selfs = []
    if ev["truth"] is not None:
        selfs = ["%s %s" % (s, _exp5_pct(_exp5_rate(ev, "own:" + s, [
            i for i in range(ev["n"]) if ev["truth"][i] == s]))) for s in ev["settings"]
            if s in set(ev["truth"])]
    parts = ["Ours (%s): oracle %s%s" % (src, _exp5_pct(o), " (%s)" % ", ".join(selfs) if selfs
                                          else "")]
    if other is not None:
        parts.append(", wrong picks %s, so the pick expects %s (observed %s)" % (
            _exp5_pct(other), _exp5_pct(o / k + (1 - 1.0 / k) * other),
            _exp5_pct(np.mean(ev["succ"]["baseline"]))))
    else:
        parts.append(", random pick %s" % _exp5_pct(_exp5_rate(ev, "baseline")))
    if o / k > paper_b:
        parts.append(" and cannot fall below %s even if every wrong pick failed" % _exp5_pct(o / k))
    else:
        parts.append(" and would reach 26.8%% with wrong picks at about %s" % _exp5_pct(
            max(0.0, (paper_b - o / k) / (1 - 1.0 / k))))
    parts.append("; merged %s, %s the oracle" % (
        _exp5_pct(m), "below" if m < o else "at or above"))
    groups = _exp5_groups(ev)
    if groups and _exp5_pick_expectation(ev) is not None:
        low = [(g, _exp5_pick_expectation(ev, idx), _exp5_rate(ev, "merged", idx))
               for g, idx in groups.items()]
        low = [x for x in low if x[1] <= paper_b]
        if low:
            parts.append("; the pick expects 26.8%% or less only %s" % " and ".join(
                "in %s when the truth is %s (%s, merged %s)" % (
                    g[0].replace("+", " or "), g[1], _exp5_pct(e), _exp5_pct(r))
                for g, e, r in low))
        else:
            parts.append("; the pick expects more than 26.8% for every pair and true setting")
    return first + " " + "".join(parts) + "."


def exp5_notes(ev):
    """How the trials were drawn and how much the learned controllers vary between runs."""
    notes = []
    if ev["possible"] is not None:
        pairs = sorted(set(ev["possible"]))
        notes.append("Per trial the possible settings are drawn uniformly among %s, the true "
                     "setting uniformly among them and the random pick independently of the "
                     "truth; every controller of a trial drives the same episode randomness "
                     "(common random numbers)." % ", ".join(p.replace("+", " or ")
                                                         for p in pairs))
    if ev["run"] is not None and ev["self"]:
        per_run = collections.OrderedDict()
        for i, r in enumerate(ev["run"]):
            per_run.setdefault(r, i)
        parts = []
        for s, v in ev["self"].items():
            x = [v[i] for i in per_run.values()]
            parts.append("%s %.3f (sd %.3f, %.3f..%.3f)" % (s, np.mean(x), stats.std(x),
                                                            min(x), max(x)))
        notes.append("Learned knowledge: %d learning run(s), trial i uses run i mod R (R from "
                     "config/experiments/new_circumstances.yaml learning_runs or --learning-runs); each "
                     "setting's own controller in its own setting, exact success over the runs: "
                     "%s." % (len(per_run), "; ".join(parts)))
    return notes


def exp5_analysis(t, alpha=0.05):
    """Tables, claims and notes of a new_circumstances trial table."""
    ev = exp5_evidence(t)
    return exp5_tables(ev), exp5_claims(ev, alpha), exp5_notes(ev)


def exp5_spec(ctx):
    runs = ctx.setting("exp5", "learning_runs")
    args = [] if runs is None else ["--learning-runs", int(runs)]
    return TrialSpec("new_circumstances", "new_circumstances", args, ctx.seed,
                     ctx.trials("exp5"), min_chunk=EXP5_MIN_CHUNK)


def exp5_new_circumstances(ctx):
    res = Result("exp5", TITLES["exp5"])
    n = ctx.trials("exp5")
    spec = exp5_spec(ctx)
    t = ctx.runner.run([spec], label="exp5")[spec.name]
    tables, claims, notes = exp5_analysis(t, ctx.alpha)
    res.tables += tables
    res.claims += claims
    res.notes += notes
    return res
