#!/usr/bin/env python3
"""A fake of the core's trial CLIs for the tools' tests, following the same contract:

    PROGRAM [options] --seed S --trials N --trial-begin K [--threads T] --out FILE.csv

one CSV row (nav_transfer: one per episode and condition, to --trials-out) per trial, trial
index first, trial i depending only on (seed, i) and the options. Invoke as
`fake_cli.py PROGRAM ARGS...` (make_bin_dir writes one wrapper per program name).

FAKE_KRR_MODE changes behaviour for error tests: fail (exit 3), bad_header (chunks starting
after 0 write another header), skip_trial (drops trial 1), garbage (non-numeric reward),
reverse (the learned/extraction/merged condition is worse instead of better), noisy (the
effects are buried in noise: nothing is significant at small trial counts).
FAKE_KRR_LOG: append one line per invocation (to count chunks). FAKE_KRR_OLD: delivery_trials
writes only the old columns (trial, room, reward, fulfilled, qa_cost, turns, entropy).
"""
import math
import os
import random
import stat
import sys

ROOMS = ["room1", "room2", "room3", "room4", "room5"]
PROGRAMS = ["nav_transfer", "delivery_trials", "dialog_entropy", "new_circumstances",
            "dialog_script"]


def parse(argv):
    opts, i = {}, 0
    while i < len(argv):
        if argv[i] in ("--no-policy", "--json", "--deliver"):
            opts[argv[i][2:]] = "1"
            i += 1
            continue
        if not argv[i].startswith("--") or i + 1 >= len(argv):
            sys.stderr.write("fake: bad argument %r\n" % argv[i])
            sys.exit(2)
        if argv[i] == "--utterance":
            opts.setdefault("utterances", []).append(argv[i + 1])
        elif argv[i] == "--question":
            opts.setdefault("questions", []).append(argv[i + 1])
        else:
            opts[argv[i][2:]] = argv[i + 1]
        i += 2
    return opts


def rng_for(program, opts, i, keys):
    return random.Random("%s|%s|%d|%s" % (program, opts.get("seed", "1"), i,
                                         "|".join(opts.get(k, "") for k in keys)))


def sign():
    return -1.0 if os.environ.get("FAKE_KRR_MODE") == "reverse" else 1.0


def scale():
    return 0.0 if os.environ.get("FAKE_KRR_MODE") == "noisy" else 1.0


def nav_rows(opts, i):
    r = rng_for("nav", opts, i, ["domain", "target-episodes"])
    large = "50" in opts.get("domain", "")
    limit = 300 if large else 200
    eps = int(opts.get("target-episodes", "100"))
    tau = {"with": 5.0, "without": (30.0 if large else 12.0)}
    if sign() < 0:
        tau["with"], tau["without"] = tau["without"], tau["with"]
    rows = []
    for e in range(1, eps + 1):
        for cond in ("with", "without"):
            t = tau[cond] if scale() else 10.0
            learn = 1 - math.exp(-e / t)
            reward = -limit * (1 - learn) - 20 * learn + r.gauss(0, 15)
            rows.append([i, e, cond, "%.3f" % reward, int(r.random() < learn)])
    return ["trial", "episode", "condition", "reward", "success"], rows


DELIVERY_HEADER = ["trial", "room", "reward", "fulfilled", "qa_cost", "turns", "entropy",
                   "request", "served", "served_room", "correct", "forced", "served_probability",
                   "max_probability", "trips", "nav_moves", "nav_failed", "redelivered",
                   "delivery_reward", "nav_cost", "penalty", "policy_lower", "policy_upper",
                   "expected_reward", "reward_error"]
REACH = {"room1": 0.0, "room2": 0.3, "room3": 0.2, "room4": 0.0, "room5": 0.4}


def site_names(site):
    """The rooms, items and persons of a site folder's knowledge.plog (its `room = {...}.`
    lines), as delivery_trials --site takes them from the site."""
    names = {}
    with open(os.path.join(site, "knowledge.plog")) as f:
        for line in f:
            for sort in ("room", "item", "person"):
                if line.startswith(sort + " = {"):
                    names[sort] = [v.strip() for v in line.split("{")[1].split("}")[0].split(",")]
    return names["room"], names["item"], names["person"]


def delivery_row(opts, i):
    """Like delivery_trials: trial i of both conditions at the same br and seed shares the
    request and the random draws of the person and the walkers (paired rows); the learned
    condition identifies more, asks less and fails navigation a little less. FAKE_KRR_OLD=1
    writes the old columns only (no identification, navigation or expected reward)."""
    br = float(opts.get("br", "0.3"))
    learned = opts.get("condition") == "learned"
    shared = rng_for("delivery", opts, i, ["br"])  # same draws in both conditions
    own = rng_for("delivery", opts, i, ["br", "condition"])
    if "site" in opts:  # the site's names; reach by position in the room list
        rooms, items, persons = site_names(opts["site"])
        reach_of = dict(zip(rooms, [REACH[r] for r in ROOMS] * len(rooms)))
    else:
        rooms, items, persons, reach_of = ROOMS, ["coke", "coffee", "soda"], ["john", "bob"], REACH
    room = rooms[shared.randrange(len(rooms))]
    person = persons[-1] if rooms.index(room) in (1, 3) else persons[0]
    request = "%s_%s_%s" % (items[shared.randrange(len(items))], room, person)
    good = (1 if learned else -1) * sign() * scale()
    u_id, u_nav, z_qa = shared.random(), shared.random(), shared.gauss(0, 3.0)
    correct = u_id < 0.93 + 0.03 * good
    served_room = room if correct else rooms[(rooms.index(room) + 1) % len(rooms)]
    served = request if correct else "%s_%s_%s" % (items[-1], served_room, persons[0])
    reach = 1 - br * reach_of[served_room]
    nav_failed = u_nav > reach + 0.02 * good
    fulfilled = not nav_failed
    qa = max(1.5, {"room4": 12.0, "room2": 17.0}.get(room, 15.0) - 1.0 * good + z_qa
             + own.gauss(0, 1.0))
    turns = int(qa // 1.8) + 1
    nav_cost = 20.0 * (1 if correct else 3)
    penalty = 0.0 if correct else 120.0
    delivery = 80.0 if fulfilled else -80.0
    reward = delivery - qa - nav_cost - penalty
    expected = (160 * reach - 80) - qa - nav_cost - penalty
    lower = -10.0 - 80 * br + 5 * good
    row = [i, room, "%.4f" % reward, int(fulfilled), "%.1f" % qa, turns,
           "%.4f" % abs(own.gauss(0.2, 0.05)), request, served, served_room, int(correct), 0,
           "%.4f" % (0.94 + 0.01 * good), "%.4f" % (0.94 + 0.01 * good), 1 if correct else 3,
           25, int(nav_failed), int(not correct), "%.0f" % delivery, "%.0f" % nav_cost,
           "%.0f" % penalty, "%.4f" % lower, "%.4f" % (lower + 0.5), "%.4f" % expected,
           "%.4f" % (0.05 * br)]
    if os.environ.get("FAKE_KRR_OLD"):
        keep = ["trial", "room", "reward", "fulfilled", "qa_cost", "turns", "entropy"]
        return keep, [row[DELIVERY_HEADER.index(k)] for k in keep]
    return list(DELIVERY_HEADER), row


def entropy_row(opts, i):
    br = float(opts.get("br", "0.3"))
    r = rng_for("entropy", opts, i, ["br", "condition", "samples"])
    if r.random() < 0.3:
        return ["trial", "action", "room", "entropy"], [i, "ask_item", "", "%.4f" % r.random()]
    room = ROOMS[r.randrange(5)]
    base = {"room1": 0.27, "room2": 0.22, "room5": 0.18}.get(room, 0.2)
    e = base * (1 - 0.7 * br * sign() * scale()) * abs(r.gauss(1, 0.3))
    return ["trial", "action", "room", "entropy"], [i, "serve", room, "%.5f" % e]


def merged_row(opts, i):
    r = rng_for("merged", opts, i, [])
    pm = 0.838 if scale() else 0.5
    pb = 0.268 if scale() else 0.5
    if sign() < 0:
        pm, pb = pb, pm
    return ["trial", "setting", "success_merged", "success_baseline", "success_oracle",
            "p_merged", "p_baseline", "p_oracle"], \
        [i, "noon", int(r.random() < pm), int(r.random() < pb), 1, "%.4f" % pm, "%.4f" % pb,
         "0.9"]


def dialog_script(opts):
    """Wide format of the real dialog_script: one row per turn (0 = prior), marginals in
    item_<v>, person_<v>, room_<v> columns. Before each utterance after the first the robot
    asks the next --question, else its (fake) policy's question: the paper's questions, then
    it serves (reverse mode: it asks about the person, and serves the wrong request)."""
    utter = opts.get("utterances", [])
    if not utter:
        sys.stderr.write("dialog_script: at least one --utterance is required\n")
        sys.exit(2)
    scripted = opts.get("questions", [])
    dims = [("item", ["coke", "coffee", "soda"]), ("person", ["john", "bob"]), ("room", ROOMS)]
    target = {"item": "coke", "person": "bob", "room": "room2"}
    policy = ["ask_item", "confirm_item_coke", "confirm_room_room2"]
    final = "serve_coke_room2_bob"
    if sign() < 0:
        policy, final = ["ask_person", "ask_person", "ask_room"], "serve_soda_room1_john"

    def next_action(k):  # the robot's action after user turn k (k >= 1)
        if k - 1 < len(scripted):
            return scripted[k - 1]
        return policy[k - 1] if k - 1 < len(policy) else final
    header = ["turn", "robot_action", "robot_text", "user"]
    for d, vals in dims:
        header += ["%s_%s" % (d, v) for v in vals]
    header += ["entropy", "next_action"]
    rows = []
    for t in range(len(utter) + 1):
        action = "none" if t <= 1 else next_action(t - 1)
        row = [t, action, '"Say, ""what""?"', utter[t - 1] if t else ""]
        for d, vals in dims:
            focus = min(0.95, 1.0 / len(vals) + 0.2 * t) if sign() > 0 else 1.0 / len(vals)
            row += ["%.4f" % (focus if v == target[d] else (1 - focus) / (len(vals) - 1))
                    for v in vals]
        rows.append(row + ["1.0", "none" if t == 0 else next_action(t)])
    with open(opts["out"], "w") as f:
        f.write(",".join(header) + "\n")
        for row in rows:
            f.write(",".join(str(c) for c in row) + "\n")


def main():
    program, argv = sys.argv[1], sys.argv[2:]
    if os.environ.get("FAKE_KRR_LOG"):
        with open(os.environ["FAKE_KRR_LOG"], "a") as f:
            f.write("%s %s\n" % (program, " ".join(argv)))
    opts = parse(argv)
    mode = os.environ.get("FAKE_KRR_MODE", "")
    if mode == "fail":
        sys.stderr.write("%s: simulated failure: config/x.yaml line 3: bad value\n" % program)
        return 3
    if program == "dialog_script":
        dialog_script(opts)
        return 0
    begin, n = int(opts.get("trial-begin", "0")), int(opts["trials"])
    make = {"nav_transfer": nav_rows, "delivery_trials": delivery_row,
            "dialog_entropy": entropy_row, "new_circumstances": merged_row}[program]
    header, rows = None, []
    for i in range(begin, begin + n):
        if mode == "skip_trial" and i == 1:
            continue
        h, r = make(opts, i)
        header = h
        rows.extend(r if program == "nav_transfer" else [r])
    if header is None:
        header = make(opts, 0)[0]
    if mode == "bad_header" and begin > 0:
        header = list(header[:-1]) + ["other"]
    if mode == "garbage":
        rows[0] = list(rows[0])
        rows[0][header.index("reward")] = "oops"
    out = opts["trials-out"] if program == "nav_transfer" else opts["out"]
    with open(out, "w") as f:
        f.write(",".join(header) + "\n")
        for row in rows:
            f.write(",".join(str(c) for c in row) + "\n")
    if program == "nav_transfer" and "out" in opts:
        with open(opts["out"], "w") as f:
            f.write("episode,mean_with\n")
    return 0


def make_bin_dir(directory, programs=PROGRAMS):
    """Write an executable wrapper per program name into `directory` (use as KRR_BIN_DIR)."""
    os.makedirs(directory, exist_ok=True)
    me = os.path.abspath(__file__)
    for p in programs:
        path = os.path.join(directory, p)
        with open(path, "w") as f:
            f.write('#!/bin/sh\nexec /usr/bin/python3 "%s" %s "$@"\n' % (me, p))
        os.chmod(path, os.stat(path).st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    return directory


if __name__ == "__main__":
    sys.exit(main())
