"""Experiment 1 of the paper: navigation transfer (learn the source task, apply to the target
task of config/experiments/nav_transfer.yaml).

`run_domain` runs the C++ `nav_transfer` program for one domain and returns its per-episode
table; `smooth` is the paper's 10-episode moving window; `plot` draws the domains side by side
(solid: without extraction, dashed: with extraction, as in the paper's figure).
"""
import csv
import os
import subprocess

import numpy as np
import yaml

from . import paths

# The names the paper's figure gives its two domains: the navigation config's domains with the
# fewest and the most cells (the bundled office: 30x30 with 200 steps, 50x50 with 300 steps, as
# in the paper), so that every site has them.
PAPER_NAMES = ("small", "large")


class UnknownDomainError(ValueError):
    """A navigation domain that is neither one of the paper's names nor in the navigation
    config; the message names the domain and where the known ones come from."""


def _domain_table(config):
    """{name: (cols, rows, step limit)} of the navigation config's domains, in the file's
    order."""
    with open(config) as f:
        data = yaml.safe_load(f) or {}
    domains = data.get("domains") or {}
    if not isinstance(domains, dict):
        raise UnknownDomainError("%s: field 'domains' must map names to {cols, rows, step_limit}"
                                 % config)
    table = {}
    for name, d in domains.items():
        d = d if isinstance(d, dict) else {}
        table[name] = (d.get("cols"), d.get("rows"), d.get("step_limit"))
    return table


def config_domains(config=None):
    """(name, step limit) of every domain of the navigation config (default: the repository's
    config/navigation.yaml), in the file's order."""
    config = config or paths.repo("config", "navigation.yaml")
    return [(name, d[2]) for name, d in _domain_table(config).items()]


def _cells(dims):
    cols, rows, _ = dims
    return (cols or 0) * (rows or 0)


def resolve_domain(name, config=None):
    """(grid, step limit) of `name`: a domain of the navigation config, or one of the paper's
    names small / large (its domains with the fewest / the most cells; a config needs two
    domains for them), so that a site's own domains run too. Raises UnknownDomainError."""
    config = config or paths.repo("config", "navigation.yaml")
    table = _domain_table(config)
    if name in table:
        return name, table[name][2]
    if name in PAPER_NAMES:
        if len(table) < 2:
            raise UnknownDomainError(
                "navigation domain '%s' is the paper's name for the %s of two domains, but %s has "
                "%d: %s" % (name, "smaller" if name == "small" else "larger", config, len(table),
                            ", ".join(table) or "none"))
        pick = min if name == "small" else max
        grid = pick(table, key=lambda g: _cells(table[g]))
        return grid, table[grid][2]
    raise UnknownDomainError(
        "unknown navigation domain '%s': the known ones are the domains of %s: %s, and %s (the "
        "paper's names for its domains with the fewest and the most cells)"
        % (name, config, ", ".join(table) or "none", ", ".join(PAPER_NAMES)))


def grid_size(grid, config=None):
    """'COLSxROWS' of a domain of the navigation config (e.g. '30x30')."""
    config = config or paths.repo("config", "navigation.yaml")
    cols, rows, _ = _domain_table(config).get(grid, (None, None, None))
    return "%sx%s" % (cols, rows) if cols and rows else grid


def transfer_tasks(options=None):
    """(start, source, target) of the navigation experiment: the nav_transfer section of its
    options file (default: the repository's config/experiments/nav_transfer.yaml), the start
    defaulting to the site's shop (config/dialog.yaml navigation.shop), as nav_transfer reads
    them."""
    options = options or paths.repo("config", "experiments", "nav_transfer.yaml")
    with open(options) as f:
        section = (yaml.safe_load(f) or {}).get("nav_transfer") or {}
    start = section.get("start")
    if not start:
        with open(paths.repo("config", "dialog.yaml")) as f:
            start = ((yaml.safe_load(f) or {}).get("navigation") or {}).get("shop")
    return start, section.get("source"), section.get("target")


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
    # The program derives the navigation config, the domain's geometry and the knowledge
    # from the root, as it does for a user.
    cmd = [paths.program("nav_transfer"), "--root", paths.root(), "--domain", grid,
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

    names = list(tables)  # any domains, in the caller's order (the paper: small, large)
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
        grid, limit = resolve_domain(d)
        title = "%s (%s, %s steps)" % (d, grid_size(grid), limit)
        ax.set_title(title if d in PAPER_NAMES else "%s (%s steps)" % (grid, limit))
        ax.set_xlabel("episode")
        ax.set_ylabel("reward (%d-episode window)" % window)
        ax.grid(alpha=0.3)
        ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)
