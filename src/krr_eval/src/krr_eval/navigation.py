"""Experiment 1 of the paper: navigation transfer (learn shop-room1, apply to shop-room2).

`run_domain` runs the C++ `nav_transfer` program for one domain and returns its per-episode
table; `smooth` is the paper's 10-episode moving window; `plot` draws both domains side by side
(solid: without extraction, dashed: with extraction, as in the paper's figure).
"""
import csv
import os
import subprocess

import numpy as np
import yaml

from . import paths

DOMAINS = {
    # The paper's office domains under the names its figure uses.
    # name: (grid, step limit) -- paper: 30x30 with 200 steps, 50x50 with 300 steps
    "small": ("office_30x30", 200),
    "large": ("office_50x50", 300),
}


class UnknownDomainError(ValueError):
    """A navigation domain that is neither one of the paper's names nor in the navigation
    config; the message names the domain and where the known ones come from."""


def config_domains(config=None):
    """(name, step limit) of every domain of the navigation config (default: the repository's
    config/navigation.yaml), in the file's order."""
    config = config or paths.repo("config", "navigation.yaml")
    with open(config) as f:
        data = yaml.safe_load(f) or {}
    domains = data.get("domains") or {}
    if not isinstance(domains, dict):
        raise UnknownDomainError("%s: field 'domains' must map names to {cols, rows, step_limit}"
                                 % config)
    return [(name, (d or {}).get("step_limit")) for name, d in domains.items()]


def resolve_domain(name, config=None):
    """(grid, step limit) of `name`: one of DOMAINS (the paper's small / large) or a domain of
    the navigation config, so that a site's own domains run too. Raises UnknownDomainError."""
    if name in DOMAINS:
        return DOMAINS[name]
    config = config or paths.repo("config", "navigation.yaml")
    known = config_domains(config)
    for grid, limit in known:
        if grid == name:
            return grid, limit
    raise UnknownDomainError(
        "unknown navigation domain '%s': the known ones are %s (the paper's) and the domains of "
        "%s: %s" % (name, ", ".join(sorted(DOMAINS)), config,
                    ", ".join(g for g, _ in known) or "none"))


def smooth(values, window=10):
    """Trailing moving average over `window` episodes (shorter at the start)."""
    if window < 1:
        raise ValueError("window must be at least 1, got %r" % (window,))
    out, acc = [], 0.0
    for i, v in enumerate(values):
        acc += v
        if i >= window:
            acc -= values[i - window]
        out.append(acc / min(i + 1, window))
    return out


def read_table(path):
    """Read a nav_transfer CSV into a dict of column name -> list of floats."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError("%s: no rows" % path)
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def run_domain(domain, out_dir, trials, seed, threads, target_episodes=100, extra=()):
    """Run nav_transfer on one domain ("small"/"large" or a domain of config/navigation.yaml);
    returns (table, summary text)."""
    grid, _ = resolve_domain(domain)
    csv_path = os.path.join(out_dir, "nav_transfer_%s.csv" % domain)
    cmd = [paths.program("nav_transfer"),
           "--config", paths.repo("config", "navigation.yaml"),
           "--domain", grid,
           "--geometry", paths.repo("maps", grid + "_geometry.plog"),
           "--knowledge", paths.repo("config", "navigation.plog"),
           "--trials", str(trials), "--threads", str(threads), "--seed", str(seed),
           "--target-episodes", str(target_episodes), "--out", csv_path] + list(extra)
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError("nav_transfer failed (%d): %s" % (res.returncode, res.stderr.strip()))
    return read_table(csv_path), res.stdout.strip()


def condition_of(label):
    """'with' or 'without' extraction from a CLI condition label (with/without, extraction/
    baseline, 1/0, ...); ValueError otherwise."""
    v = label.strip().lower()
    if v in ("without", "without_extraction", "no_extraction", "scratch", "baseline", "0",
             "false", "no"):
        return "without"
    if v in ("with", "with_extraction", "extraction", "transfer", "1", "true", "yes"):
        return "with"
    raise ValueError("unknown navigation condition '%s' (expected with/without)" % label)


def trial_matrices(trials):
    """Per-trial learning curves from the CLI's per-trial rows (a krr_eval.trials.TrialTable).

    Long format: columns trial, episode, condition, reward[, success], one row per (trial,
    episode, condition); wide format: trial, episode, reward_with, reward_without[,
    success_with, success_without]. Returns (episodes, {"with": R, "without": R},
    {"with": S, "without": S} or None) with R, S arrays of shape trials x episodes, rows in
    trial order."""
    tcol = trials.trial_column()
    idx, ep = trials.ints(tcol), trials.ints("episode")
    t_ids, e_ids = sorted(set(idx)), sorted(set(ep))
    ti = {t: k for k, t in enumerate(t_ids)}
    ei = {e: k for k, e in enumerate(e_ids)}
    shape = (len(t_ids), len(e_ids))
    conds = ([condition_of(c) for c in trials.strings("condition")]
             if trials.has("condition") else None)
    rewards, succ = {}, {}
    for kind, out in (("reward", rewards), ("success", succ)):
        for c in ("with", "without"):
            out[c] = np.full(shape, np.nan)
        if conds is not None:
            if not trials.has(kind):
                continue
            vals = trials.floats(kind)
            for t, e, c, v in zip(idx, ep, conds, vals):
                out[c][ti[t], ei[e]] = v
        else:
            for c in ("with", "without"):
                col = "%s_%s" % (kind, c)
                if not trials.has(col):
                    if kind == "reward":
                        trials.floats(col)  # raises: names the missing column
                    continue
                for t, e, v in zip(idx, ep, trials.floats(col)):
                    out[c][ti[t], ei[e]] = v
    for c in ("with", "without"):
        missing = np.argwhere(np.isnan(rewards[c]))
        if missing.size:
            t, e = missing[0]
            raise ValueError("%s: no reward for trial %d, episode %d, condition %s (%d cells "
                             "missing)" % (trials.source, t_ids[t], e_ids[e], c, len(missing)))
    if any(np.isnan(succ[c]).all() for c in succ):
        succ = None
    return e_ids, rewards, succ


def curve_table(episodes, rewards, success=None):
    """Per-episode means and 95% t-CI half-widths over trials in read_table's layout."""
    from . import stats
    t = {"episode": [float(e) for e in episodes]}
    for c in ("with", "without"):
        est = [stats.mean_ci(rewards[c][:, k]) for k in range(len(episodes))]
        t["mean_" + c] = [e.mean for e in est]
        t["ci95_" + c] = [e.half for e in est]
        if success is not None:
            t["success_" + c] = [float(np.mean(success[c][:, k])) for k in range(len(episodes))]
    return t


def advantage(table, first=None):
    """Mean reward gain of extraction over the first `first` episodes (all if None)."""
    w, wo = table["mean_with"], table["mean_without"]
    n = len(w) if first is None else min(first, len(w))
    return sum(w[:n]) / n - sum(wo[:n]) / n


def plot(tables, png_path, window=10):
    """Learning curves for each domain in `tables` ({"small": table, ...}) into one PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [d for d in ("small", "large") if d in tables]
    fig, axes = plt.subplots(1, len(names), figsize=(5 * len(names), 3.6), squeeze=False)
    for ax, d in zip(axes[0], names):
        t = tables[d]
        ep = t["episode"]
        for cond, style, label in (("without", "-", "without extraction"),
                                   ("with", "--", "with extraction")):
            m = smooth(t["mean_" + cond], window)
            line, = ax.plot(ep, m, style, label=label)
            ci = t.get("ci95_" + cond)
            if ci is not None and all(c == c for c in ci):  # skip bands with NaN (1 trial)
                h = smooth(ci, window)
                ax.fill_between(ep, [a - b for a, b in zip(m, h)], [a + b for a, b in zip(m, h)],
                                color=line.get_color(), alpha=0.15, linewidth=0)
        grid, limit = DOMAINS[d]
        ax.set_title("%s (%s, %d steps)" % (d, grid.split("_")[1], limit))
        ax.set_xlabel("episode")
        ax.set_ylabel("reward (%d-episode window)" % window)
        ax.grid(alpha=0.3)
        ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)
