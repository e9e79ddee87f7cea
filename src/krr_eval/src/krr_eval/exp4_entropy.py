"""Experiment 4: Table II, belief entropy when the robot decides to deliver."""
import collections

import numpy as np

from . import stats
from .paper import PAPER_TABLE2
from .context import TITLES, _sub, norm_room, policy_report, solver_args
from .exp2_delivery import CHEAP_TRIALS_CHUNK
from .report import Claim, Result, Table
from .runner import TrialSpec


# ---------------------------------------------------------------------------------------------
# Experiment 4: Table II
ENTROPY_COLUMNS = "trial, room, entropy[, action or served or delivered]"
ENTROPY_UNIT = "entropy"  # dialog_entropy: nats (entropy_bits holds the same in bits)


def deliveries_only(t):
    """Rows where a delivery was suggested: by a delivered/serve column, an action column
    starting with serve/deliver, or else a non-empty room."""
    col = t.find("delivered", "serve", "is_delivery")
    if col:
        return t.where_true(col)
    if t.has("served"):  # the served request's name, empty if the action is a question
        return t.select(lambda r: r["served"].strip() != "")
    if t.has("action"):
        return t.select(lambda r: r["action"].strip().lower().startswith(("serve", "deliver")))
    return t.select(lambda r: r["room"].strip() != "")


def _exp2_nav(ctx, room, brs, rooms=None):
    """Measured navigation success (learned condition) from exp2's trials if exp2 ran: for one
    room over `brs` ("0.863 (br 0.1), 0.412 (br 0.7)") or for `rooms` at brs[0]; "" if none."""
    facts = ctx.facts.get("exp2", {})
    if room is not None:
        vals = [(br, facts.get((br, "learned"), {}).get("nav_by_room", {}).get(room))
                for br in brs]
        return ", ".join("%.3f (br %g)" % (v[0], br) for br, v in vals if v) \
            if all(v for _, v in vals) else ""
    by = facts.get((brs[0], "learned"), {}).get("nav_by_room", {})
    if not all(r in by for r in rooms):
        return ""
    return ", ".join("%s %.3f" % (r, by[r][0]) for r in rooms)


def _nav_flat(ctx, room, brs):
    facts = ctx.facts.get("exp2", {})
    v = [facts[br, "learned"]["nav_by_room"][room][0] for br in brs]
    return max(v) - min(v) < 0.02


def entropy_specs(ctx):
    n, cond = ctx.trials("exp4"), ctx.setting("exp4", "condition")
    return collections.OrderedDict(
        (br, TrialSpec("entropy_br%g_%s" % (br, cond), "dialog_entropy",
                       ["--br", "%g" % br, "--condition", cond] + solver_args(ctx, "exp4"),
                       ctx.seed, n,
                       min_chunk=CHEAP_TRIALS_CHUNK)) for br in ctx.setting("exp4", "brs"))


def exp4_table2(ctx):
    res = Result("exp4", TITLES["exp4"])
    n, brs = ctx.trials("exp4"), ctx.setting("exp4", "brs")
    rooms, cond = ctx.setting("exp4", "rooms"), ctx.setting("exp4", "condition")
    specs = entropy_specs(ctx)
    tables = ctx.runner.run(list(specs.values()), label="exp4")
    res.tables.append(policy_report(ctx, "exp4", collections.OrderedDict(
        ("br %g %s" % (br, cond), tables[s.name]) for br, s in specs.items())))
    ent = {}
    rows = []
    for br, s in specs.items():
        t = deliveries_only(tables[s.name])
        room_of, e = [norm_room(r) for r in t.strings("room")], t.floats("entropy")
        row = ["%g" % br, n, len(e)]
        for room in rooms:
            v = _sub(e, [r == room for r in room_of])
            ent[br, room] = v
            pp = PAPER_TABLE2.get(br, {}).get(room)
            if v:
                d = stats.describe(v)
                row += ["%.3f (%.3f)" % (d["mean"], d["std"]), d["max"], d["n"]]
            else:
                row += ["-", None, 0]
            row.append("%.3f (%.3f) / %.3f" % pp if pp else "")
        rows.append(row)
    cols = ["br", "beliefs", "deliveries"]
    for room in rooms:
        cols += ["%s mean (std)" % room, "%s max" % room, "%s n" % room, "%s paper" % room]
    res.tables.append(Table("exp4_table2", "Table II: entropy (column '%s' of the CLI) of "
                            "beliefs under which a delivery is suggested (paper: mean (std) / "
                            "max)" % ENTROPY_UNIT, cols, rows,
                            formats={"%s max" % r: "%.3f" for r in rooms}))
    lo, hi = min(brs), max(brs)
    for room in rooms:
        a, b = ent.get((lo, room), []), ent.get((hi, room), [])
        claim = "%s: entropy at delivery decreases as br grows (%g -> %g)" % (room, lo, hi)
        paper = " > ".join("%.3f" % PAPER_TABLE2[br][room][0] for br in brs
                           if room in PAPER_TABLE2.get(br, {}))
        if len(a) < 2 or len(b) < 2:
            res.claims.append(Claim.too_few_data(
                "4 Table II", claim, paper, "%d deliveries at br %g, %d at br %g"
                % (len(a), lo, len(b), hi)))
        else:
            wt = stats.welch_t_test(a, b)
            means = "br %s: %s" % (", ".join("%g" % br for br in brs), ", ".join(
                "%.3f" % np.mean(ent[br, room]) if ent[br, room] else "-" for br in brs))
            c = Claim("4 Table II", claim, paper, "%s; Welch p (br %g vs %g) = %s"
                      % (means, lo, hi, stats.format_p(wt.p)),
                      np.mean(a) > np.mean(b), wt.p, ctx.alpha)
            if not c.supported:
                ea, eb = stats.mean_ci(a), stats.mean_ci(b)
                c.reason = ("Deliveries to %s are suggested at entropy %.3f ± %.3f (br %g, %d "
                            "beliefs) and %.3f ± %.3f (br %g, %d) nats (Welch p = %s), against the "
                            "paper's %s." % (room, ea.mean, ea.half, lo, len(a), eb.mean, eb.half,
                                             hi, len(b), stats.format_p(wt.p), paper))
                nav = _exp2_nav(ctx, room, (lo, hi))
                if nav:
                    c.reason += (" In the Table I trials navigation to %s succeeds in %s%s" % (
                        room, nav, ", so a higher br hardly makes a delivery there harder."
                        if _nav_flat(ctx, room, (lo, hi)) else "."))
            res.claims.append(c)
    if "room5" in rooms:
        others = [r for r in rooms if r != "room5"]
        for br in brs:
            r5 = ent.get((br, "room5"), [])
            ps, ok, txt = [], True, []
            for o in others:
                v = ent.get((br, o), [])
                if len(v) < 2 or len(r5) < 2:
                    ok = False
                    continue
                ps.append(stats.welch_t_test(r5, v).p)
                ok = ok and np.mean(r5) < np.mean(v)
                txt.append("%s %.3f" % (o, np.mean(v)))
            claim = ("br %g: the robot collects the most information before delivering to "
                     "room5 (lowest entropy)" % br)
            paper = "room5 lowest" if br in PAPER_TABLE2 else "n/a"
            if len(r5) < 2 or len(ps) < len(others):
                res.claims.append(Claim.too_few_data("4 Table II", claim, paper, ", ".join(
                    "%d to %s" % (len(ent.get((br, r), [])), r) for r in rooms)))
            else:
                c = Claim("4 Table II", claim, paper,
                          "room5 %.3f vs %s, max Welch p = %s" % (np.mean(r5), ", ".join(txt),
                                                                 stats.format_p(max(ps))),
                          ok, max(ps), ctx.alpha)
                if not c.supported:
                    low = min(rooms, key=lambda r: np.mean(ent[br, r]))
                    c.reason = ("At br %g the mean entropy at delivery is %s nats (Welch p of "
                                "room5 against each: %s); the lowest is %s's." % (
                                    br, ", ".join("%s %.3f" % (r, np.mean(ent[br, r]))
                                                  for r in rooms),
                                    ", ".join(stats.format_p(p_) for p_ in ps), low))
                    nav = _exp2_nav(ctx, None, (br,), rooms)
                    if nav:
                        c.reason += (" Navigation success in the Table I trials (learned, br "
                                     "%g): %s." % (br, nav))
                res.claims.append(c)
    res.notes.append("%d random beliefs per blocking rate with the %s model; only beliefs "
                     "under which the policy suggests a delivery count." % (n, cond))
    return res
