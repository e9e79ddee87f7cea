"""Reproduce the paper's navigation figure: learning curves of the target task with and without
knowledge extracted from the source task (config/experiments/nav_transfer.yaml), on the paper's
small and large domains (the navigation config's domains with the fewest and the most cells).

    rosrun krr_eval nav_transfer --out out/nav [--trials 1000] [--episodes 100] [--seed 1]

Writes nav_transfer_{small,large}.csv, nav_transfer.png and nav_transfer.md in --out.
"""
import argparse
import os
import sys

from . import navigation


def main(argv=None):
    ap = argparse.ArgumentParser(prog="nav_transfer", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--trials", type=int, default=1000, help="trials per point (paper: 1000)")
    ap.add_argument("--episodes", type=int, default=100, help="target-task episodes")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--domains", default="small,large",
                    help="comma-separated: small, large (the paper's names: the navigation "
                         "config's domains with the fewest and the most cells) or domains of "
                         "config/navigation.yaml")
    a = ap.parse_args(argv)
    if a.trials < 1 or a.episodes < 1:
        ap.error("--trials and --episodes must be at least 1")
    for d in a.domains.split(","):  # every name checked before anything runs
        try:
            navigation.resolve_domain(d)
        except (navigation.UnknownDomainError, OSError) as e:
            ap.error("--domains: %s" % e)
    os.makedirs(a.out, exist_ok=True)
    start, source, target = navigation.transfer_tasks()
    tables, lines = {}, ["# Navigation transfer (%s-%s -> %s-%s)" % (start, source, start, target),
                         "",
                         "seed %d, %d trials per point, %d episodes, 10-episode smoothing" %
                         (a.seed, a.trials, a.episodes), "",
                         "| domain | mean reward with | without | gain, first 30 episodes | gain, all |",
                         "|---|---|---|---|---|"]
    for d in a.domains.split(","):
        t, summary = navigation.run_domain(d, a.out, a.trials, a.seed, a.threads, a.episodes)
        print(summary)
        tables[d] = t
        n = len(t["mean_with"])
        lines.append("| %s | %.2f | %.2f | %+.2f | %+.2f |" % (
            d, sum(t["mean_with"]) / n, sum(t["mean_without"]) / n,
            navigation.advantage(t, 30), navigation.advantage(t)))
    navigation.plot(tables, os.path.join(a.out, "nav_transfer.png"))
    if "small" in tables and "large" in tables:
        gs, gl = navigation.advantage(tables["small"], 30), navigation.advantage(tables["large"], 30)
        lines += ["", "Paper: extraction learns faster, more so in the large domain. Ours: gain %+.2f "
                  "(small) vs %+.2f (large) over the first 30 episodes: %s." %
                  (gs, gl, "supported" if gl > gs > 0 else "NOT supported")]
    with open(os.path.join(a.out, "nav_transfer.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
