"""Experiment 1 of the paper: navigation transfer (learn shop-room1, apply to shop-room2).

`run_domain` runs the C++ `nav_transfer` program for one domain and returns its per-episode
table; `smooth` is the paper's 10-episode moving window; `plot` draws both domains side by side
(solid: without extraction, dashed: with extraction, as in the paper's figure).
"""
import csv
import os
import subprocess

from . import paths

DOMAINS = {
    # name: (grid, step limit) -- paper: 30x30 with 200 steps, 50x50 with 300 steps
    "small": ("office_30x30", 200),
    "large": ("office_50x50", 300),
}


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
    """Run nav_transfer on one domain ("small"/"large"); returns (table, summary text)."""
    grid, _ = DOMAINS[domain]
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
        ax.plot(ep, smooth(t["mean_without"], window), "-", label="without extraction")
        ax.plot(ep, smooth(t["mean_with"], window), "--", label="with extraction")
        grid, limit = DOMAINS[d]
        ax.set_title("%s (%s, %d steps)" % (d, grid.split("_")[1], limit))
        ax.set_xlabel("episode")
        ax.set_ylabel("reward (%d-episode window)" % window)
        ax.grid(alpha=0.3)
        ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)
    plt.close(fig)
