"""Headless (Agg) plots of the evaluation: dialog-completion CDFs and the belief-change bars
of the paper's Figure 4. The navigation learning curves are in navigation.plot."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from . import stats  # noqa: E402

CONDITION_STYLE = {"outdated": ("-", "without extraction (outdated model)"),
                   "learned": ("--", "with extraction (learned model)")}


def cdf_grid(data, png_path, xlabel="QA cost"):
    """CDF plots: data = {row label: {column label: {condition: [values]}}}; one subplot per
    (row, column), one curve per condition (solid: outdated, dashed: learned)."""
    rows = list(data)
    cols = sorted({c for r in rows for c in data[r]})
    fig, axes = plt.subplots(len(rows), len(cols), figsize=(4.2 * len(cols), 3.0 * len(rows)),
                             squeeze=False, sharex=True, sharey=True)
    for i, r in enumerate(rows):
        for j, c in enumerate(cols):
            ax = axes[i][j]
            for cond, values in sorted(data[r].get(c, {}).items()):
                if not values:
                    continue
                cdf = stats.ecdf(values)
                style, label = CONDITION_STYLE.get(cond, ("-.", cond))
                ax.step(cdf.x, cdf.y, style, where="post",
                        label="%s (n=%d)" % (label, len(values)))
            ax.set_title("%s, %s" % (c, r))
            ax.grid(alpha=0.3)
            ax.set_ylim(0, 1.02)
            if i == len(rows) - 1:
                ax.set_xlabel(xlabel)
            if j == 0:
                ax.set_ylabel("dialog completions")
            ax.legend(loc="lower right", fontsize=7)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)


def belief_bars(turns, dims, png_path):
    """Figure 4: for each turn three stacked bars (one per dimension in `dims`, e.g. item,
    person, room) whose segments are the marginal probabilities of the values.

    turns: [(turn label, {dim: [(value, probability), ...]})]."""
    fig, ax = plt.subplots(figsize=(1.9 * len(turns) + 1.5, 3.8))
    cmap = plt.get_cmap("tab10")
    colours, xticks, xlabels = {}, [], []
    width = 0.8
    for t, (label, marg) in enumerate(turns):
        for k, d in enumerate(dims):
            x = t * (len(dims) + 1) + k
            bottom = 0.0
            for v, p in marg.get(d, []):
                key = (d, v)
                if key not in colours:
                    colours[key] = cmap(len(colours) % 10)
                ax.bar(x, p, width, bottom=bottom, color=colours[key], edgecolor="white",
                       linewidth=0.5, label="%s: %s" % (d, v) if t == 0 else None)
                bottom += p
            xticks.append(x)
            xlabels.append(d[:1].upper())
        ax.text(t * (len(dims) + 1) + (len(dims) - 1) / 2.0, 1.04, label, ha="center",
                fontsize=8)
    ax.set_xticks(xticks)
    ax.set_xticklabels(xlabels, fontsize=7)
    ax.set_ylim(0, 1.12)
    ax.set_ylabel("marginal belief")
    ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=7)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)
