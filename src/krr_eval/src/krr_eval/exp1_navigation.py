"""Experiment 1: navigation transfer (the paper's learning curves with and without extraction)."""
import collections

import numpy as np

from . import navigation, stats
from .context import TITLES
from .report import Claim, Est, P, Result, Table
from .runner import TrialSpec


# ---------------------------------------------------------------------------------------------
# Experiment 1: navigation transfer
NAV_COLUMNS = "trial, episode, condition (with/without), reward[, success]"


# Relative CPU per nav_transfer trial on the paper's two domains (measured 2026-12-01 on the
# office: 0.06 s on 30x30, 0.18 s on 50x50), so the runner splits the two sets into chunks of
# equal work.
NAV_TRIAL_COST = {"small": 1.0, "large": 3.0}


def nav_spec(ctx, domain, trials, episodes=None):
    """nav_transfer for one domain; everything else (M, Rmax, episodes, br, ...) comes from
    config/experiments/nav_transfer.yaml unless `episodes` is given."""
    grid, _ = navigation.resolve_domain(domain)
    args = ["--domain", grid]
    if episodes:
        args += ["--target-episodes", str(episodes)]
    return TrialSpec("nav_transfer_%s" % domain, "nav_transfer", args, ctx.seed, trials,
                     trials_flag="--trials-out", scratch_flags=("--out",),
                     cost=NAV_TRIAL_COST.get(domain, 1.0))


def exp1_specs(ctx):
    n, eps = ctx.trials("exp1"), ctx.setting("exp1", "target_episodes")
    return collections.OrderedDict((d, nav_spec(ctx, d, n, eps))
                                   for d in ctx.setting("exp1", "domains"))


def exp1_nav_transfer(ctx):
    res = Result("exp1", TITLES["exp1"])
    n = ctx.trials("exp1")
    window, early = ctx.setting("exp1", "window"), ctx.setting("exp1", "early_episodes")
    domains = ctx.setting("exp1", "domains")
    specs = exp1_specs(ctx)
    tables = ctx.runner.run(list(specs.values()), label="exp1")
    curves, gains, rows = {}, {}, []
    for d in domains:
        episodes, rew, succ = navigation.trial_matrices(tables[specs[d].name])
        curve = navigation.curve_table(episodes, rew, succ)
        curves[d] = curve
        cols = [c for c in ("episode", "mean_with", "ci95_with", "mean_without", "ci95_without",
                            "success_with", "success_without") if c in curve]
        ct = Table("exp1_curve_%s" % d, "Learning curve, %s domain (mean over %d trials)" % (d, n),
                   cols, [[curve[c][k] for c in cols] for k in range(len(episodes))],
                   formats={"episode": "%.0f"})
        ct.save(ctx.out_dir)
        w, wo = rew["with"].mean(axis=1), rew["without"].mean(axis=1)
        gains[d] = w - wo
        e = min(early, len(episodes))
        early_gain = rew["with"][:, :e].mean(axis=1) - rew["without"][:, :e].mean(axis=1)
        pt = stats.paired_t_test(w, wo)
        grid, limit = navigation.resolve_domain(d)
        g = stats.mean_ci(gains[d])
        n_eps = len(episodes)
        rows.append([d, navigation.grid_size(grid), limit, n, n_eps,
                     Est(*stats.mean_ci(w)[:2]), Est(*stats.mean_ci(wo)[:2]), Est(g.mean, g.half),
                     P(pt.p), Est(*stats.mean_ci(early_gain)[:2])])
        c = Claim("1 nav", "with extraction the robot learns faster (%s domain)" % d,
                  "dashed above solid", "gain %+.2f ± %.2f reward/episode, paired p = %s"
                  % (g.mean, g.half, stats.format_p(pt.p)), g.mean > 0, pt.p, ctx.alpha)
        if not c.supported:
            eg = stats.mean_ci(early_gain)
            c.reason = ("On the %s domain (%d trials, %d target episodes) the robot earns %.2f "
                        "reward per episode with extraction and %.2f without: a gain of %+.2f ± "
                        "%.2f (paired p = %s); over the first %d episodes the gain is %+.2f ± "
                        "%.2f." % (d, n, len(episodes), float(np.mean(w)), float(np.mean(wo)),
                                   g.mean, g.half, stats.format_p(pt.p), e, eg.mean, eg.half))
        res.claims.append(c)
    res.tables.append(Table(
        "exp1_nav_transfer", "Navigation transfer: mean reward per target episode (95% CI)",
        ["domain", "grid", "step limit", "trials", "episodes", "with extraction",
         "without extraction", "gain", "p (paired t)",
         "gain, first %d episodes" % min(early, n_eps)], rows,
        note="Gain = per-trial mean reward over all target episodes, with minus without "
             "extraction (the area between the learning curves)."))
    if "small" in gains and "large" in gains:
        wt = stats.welch_t_test(gains["large"], gains["small"])
        gl, gs = float(np.mean(gains["large"])), float(np.mean(gains["small"]))
        c = Claim("1 nav", "the improvement is more significant in the larger domain",
                  "larger gap in 50x50", "gain %+.2f (large) vs %+.2f (small), Welch p = %s"
                  % (gl, gs, stats.format_p(wt.p)), gl > gs, wt.p, ctx.alpha)
        if not c.supported:
            el, es = stats.mean_ci(gains["large"]), stats.mean_ci(gains["small"])
            c.reason = ("Extraction gains %+.2f ± %.2f reward per episode on the 50x50 domain and "
                        "%+.2f ± %.2f on the 30x30 one (Welch p = %s over %d trials each): the "
                        "larger domain's gain is %s." % (
                            el.mean, el.half, es.mean, es.half, stats.format_p(wt.p), n,
                            "smaller" if gl <= gs else "larger but not significantly so"))
        res.claims.append(c)
    png = "exp1_nav_transfer.png"
    navigation.plot(curves, ctx.path(png), window=window)
    res.figures.append(png)
    res.notes.append("Each point: mean over %d trials; curves smoothed over %d episodes; step "
                     "limits 200 (30x30) and 300 (50x50) as in the paper; R-Max and experiment "
                     "settings from config/experiments/nav_transfer.yaml." % (n, window))
    return res
