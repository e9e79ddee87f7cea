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
    (row, column), one curve per condition (solid: outdated, dashed: learned). One row gives
    the paper's Figure 5 layout (room2 left, room4 right)."""
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


def belief_bars(turns, dims, png_path, captions=None):
    """Figure 4: for each turn a group of stacked bars, one per dimension in `dims` (item,
    person, room, in the paper's order), whose segments are the marginal probabilities of the
    values (bottom to top in the CLI's order, as in the paper).

    turns: [(turn label, {dim: [(value, probability), ...]})]; captions: optional text under
    each group (e.g. the robot's question and the user's answer)."""
    fig, ax = plt.subplots(figsize=(2.1 * len(turns) + 2.0, 4.4 if captions else 3.8))
    cmaps = {"item": "Reds", "person": "Greens", "room": "Blues"}
    colours, xticks, xlabels = {}, [], []
    width = 0.8
    for t, (label, marg) in enumerate(turns):
        for k, d in enumerate(dims):
            x = t * (len(dims) + 1) + k
            bottom = 0.0
            values = marg.get(d, [])
            for j, (v, p) in enumerate(values):
                key = (d, v)
                if key not in colours:
                    cmap = plt.get_cmap(cmaps.get(d, "Greys"))
                    colours[key] = cmap(0.3 + 0.6 * j / max(1, len(values) - 1))
                ax.bar(x, p, width, bottom=bottom, color=colours[key], edgecolor="white",
                       linewidth=0.5, label="%s: %s" % (d, v) if t == 0 else None)
                if p >= 0.12:
                    ax.text(x, bottom + p / 2, v, ha="center", va="center", fontsize=5.5,
                            rotation=90)
                bottom += p
            xticks.append(x)
            xlabels.append(d[:1].upper())
        centre = t * (len(dims) + 1) + (len(dims) - 1) / 2.0
        ax.text(centre, 1.04, label, ha="center", fontsize=8)
        if captions and t < len(captions) and captions[t]:
            ax.text(centre, -0.1, captions[t], ha="center", va="top", fontsize=6,
                    transform=ax.get_xaxis_transform(), wrap=True)
    ax.set_xticks(xticks)
    ax.set_xticklabels(xlabels, fontsize=7)
    ax.set_ylim(0, 1.12)
    ax.set_ylabel("marginal belief")
    ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=7)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)
