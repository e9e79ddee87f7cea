#!/usr/bin/python3
"""Write the standard POMDP benchmarks as Cassandra .pomdp files, from their public definitions.

    gen_pomdp.py rocksample N K [-o FILE]     RockSample[N,K] (Smith & Simmons, UAI 2004)
    gen_pomdp.py tag [-o FILE]                Tag (Pineau, Gordon & Thrun, IJCAI 2003)
    ... --format pomdpx                       the same problem as SARSOP's PomdpX XML, factored
                                              (flat sizes in rocksample_pomdpx / tag_pomdpx)

Issue 15 compares pomdp_solve with SARSOP on these problems; generating them here keeps large
files out of git and documents every modelling choice next to the code.

RockSample[N,K]: an N x N grid, the robot starts at (0, N // 2) (left column, middle row) and
knows its position; K rocks at fixed cells are each good or bad (independently 1/2 at start).
Actions: north, south, east, west, sample, check1..checkK. Moves are deterministic; bumping into
the north, south or west wall leaves the robot in place; moving east from the last column exits
to an absorbing zero-reward state with +10. sample: +10 on a good rock (which becomes bad), -10
on a bad rock or an empty cell. checkI observes rock I correctly with probability
(1 + eta) / 2, eta = 2^(-d / d0), d the Euclidean distance, d0 = 20 (half-efficiency distance).
Observations: good, bad; actions other than checks observe 'bad' (no information). States:
N^2 2^K + 1 (257 for [4,4]), actions 5 + K, discount 0.95.

Tag: 29 cells (two full rows of 10, and a 3 x 3 block above columns 5-7). State: robot cell x
opponent cell, plus 29 'tagged' states (robot cell, opponent tagged): 870 states. Actions:
north, south, east, west, tag. Moves cost -1; tag is +10 when in the opponent's cell (then the
absorbing zero-reward tagged state), else -10. The opponent moves away from the robot's current
cell: 0.4 to the side of increasing x-distance (0.2 each way when the robot is in its column),
likewise 0.4 for y, 0.2 to stay; a move into a wall stays. Observations: the robot's cell
(29), or 'found' when it shares the opponent's cell: 30. Start: uniform over the 841 untagged
states. Discount 0.95.
"""

import argparse
import itertools
import math
import sys

# Standard rock layouts: robot start and rock cells (x, y), x = column, y = row.
ROCK_LAYOUTS = {
    (4, 4): [(3, 1), (2, 1), (1, 3), (1, 0)],
    (5, 5): [(2, 4), (0, 4), (3, 3), (2, 2), (4, 1)],
    (5, 7): [(1, 0), (2, 1), (1, 2), (2, 2), (4, 2), (0, 3), (3, 4)],
    (7, 8): [(2, 0), (0, 1), (3, 1), (6, 3), (2, 4), (3, 4), (5, 5), (1, 6)],
}


def fmt(p):
    """Probabilities and rewards with 12 significant digits (rows sum to 1 within 1e-11)."""
    return "%.12g" % p


def rock_layout(n, k):
    """The rock cells of RockSample[n,k]: the standard layout if known, else a fixed pseudo-random
    one (a linear congruential sequence, so that the file never depends on Python's RNG)."""
    if (n, k) in ROCK_LAYOUTS:
        return ROCK_LAYOUTS[(n, k)]
    if k > n * n - 1:
        raise SystemExit("gen_pomdp: %d rocks do not fit in a %dx%d grid" % (k, n, n))
    cells, seen, x = [], {(0, n // 2)}, 12345
    while len(cells) < k:
        x = (1103515245 * x + 12345) % (1 << 31)
        c = ((x >> 8) % n, (x >> 16) % n)
        if c not in seen:
            seen.add(c)
            cells.append(c)
    return cells


def rocksample(n, k, d0=20.0, discount=0.95):
    rocks = rock_layout(n, k)
    start = (0, n // 2)
    pos = [(x, y) for y in range(n) for x in range(n)]
    rock_at = {c: i for i, c in enumerate(rocks)}

    def name(p, bits):
        return "x%dy%d_%s" % (p[0], p[1], "".join("G" if b else "B" for b in bits) or "none")

    states = [(p, bits) for p in pos for bits in itertools.product((1, 0), repeat=k)]
    names = [name(p, b) for p, b in states] + ["exit"]
    actions = ["north", "south", "east", "west", "sample"] + ["check%d" % (i + 1) for i in range(k)]
    out = ["# RockSample[%d,%d] (Smith & Simmons 2004), written by tools/pomdp_bench/gen_pomdp.py" % (n, k),
           "# start (%d,%d); rocks %s; half-efficiency distance %g" % (start[0], start[1], rocks, d0),
           "discount: %g" % discount, "values: reward",
           "states: " + " ".join(names), "actions: " + " ".join(actions),
           "observations: good bad"]
    start_states = [name(start, b) for b in itertools.product((1, 0), repeat=k)]
    out.append("start include: " + " ".join(start_states))
    moves = {"north": (0, 1), "south": (0, -1), "east": (1, 0), "west": (-1, 0)}
    t, r = [], []
    for (p, bits), sn in zip(states, names):
        for a, (dx, dy) in moves.items():
            x, y = p[0] + dx, p[1] + dy
            if x >= n:  # exit east
                t.append("T: %s : %s : exit 1" % (a, sn))
                r.append("R: %s : %s : * : * 10" % (a, sn))
            elif 0 <= x and 0 <= y < n:
                t.append("T: %s : %s : %s 1" % (a, sn, name((x, y), bits)))
            else:
                t.append("T: %s : %s : %s 1" % (a, sn, sn))
        i = rock_at.get(p)
        if i is not None and bits[i]:
            after = list(bits)
            after[i] = 0
            t.append("T: sample : %s : %s 1" % (sn, name(p, after)))
            r.append("R: sample : %s : * : * 10" % sn)
        else:
            t.append("T: sample : %s : %s 1" % (sn, sn))
            r.append("R: sample : %s : * : * -10" % sn)
    for a in actions:
        if a.startswith("check"):
            t.append("T: %s identity" % a)
        t.append("T: %s : exit : exit 1" % a)
    obs = ["O: * : * : bad 1"]
    for i, c in enumerate(rocks):
        a = "check%d" % (i + 1)
        for (p, bits), sn in zip(states, names):
            eta = 2.0 ** (-math.hypot(p[0] - c[0], p[1] - c[1]) / d0)
            right = 0.5 * (1.0 + eta)
            good = right if bits[i] else 1.0 - right
            obs.append("O: %s : %s\n%s %s" % (a, sn, fmt(good), fmt(1.0 - good)))
    return "\n".join(out + [""] + t + [""] + obs + [""] + r) + "\n", len(names), len(actions), 2


TAG_CELLS = [(x, y) for y in range(2) for x in range(10)] + [(x, y) for y in range(2, 5) for x in range(5, 8)]


TAG_MOVES = {"north": (0, 1), "south": (0, -1), "east": (1, 0), "west": (-1, 0)}
TAG_INDEX = {c: i for i, c in enumerate(TAG_CELLS)}


def tag_step(c, d):
    """The cell reached from c by the move d; a move into a wall stays."""
    nc = (c[0] + d[0], c[1] + d[1])
    return nc if nc in TAG_INDEX else c


def tag_opponent(rc, oc):
    """Distribution of the opponent's next cell, moving away from the robot's cell rc."""
    dist = {oc: 0.2}
    for axis, (neg, pos) in ((0, ("west", "east")), (1, ("south", "north"))):
        if rc[axis] == oc[axis]:
            split = [(neg, 0.2), (pos, 0.2)]
        else:
            split = [(pos if oc[axis] > rc[axis] else neg, 0.4)]
        for m, p in split:
            nc = tag_step(oc, TAG_MOVES[m])
            dist[nc] = dist.get(nc, 0.0) + p
    return dist


def tag(discount=0.95):
    cells = TAG_CELLS
    index = {c: i for i, c in enumerate(cells)}
    names = ["r%do%d" % (i, j) for i in range(len(cells)) for j in range(len(cells))]
    names += ["r%dtagged" % i for i in range(len(cells))]
    actions = ["north", "south", "east", "west", "tag"]
    obs_names = ["at%d" % i for i in range(len(cells))] + ["found"]
    moves = TAG_MOVES

    step, opponent = tag_step, tag_opponent

    out = ["# Tag (Pineau, Gordon & Thrun 2003), written by tools/pomdp_bench/gen_pomdp.py",
           "discount: %g" % discount, "values: reward",
           "states: " + " ".join(names), "actions: " + " ".join(actions),
           "observations: " + " ".join(obs_names),
           "start include: " + " ".join(names[:len(cells) ** 2])]
    t, o, r = [], [], []
    for i, rc in enumerate(cells):
        for j, oc in enumerate(cells):
            sn = "r%do%d" % (i, j)
            od = opponent(rc, oc)
            for a in actions:
                if a == "tag" and i == j:
                    t.append("T: tag : %s : r%dtagged 1" % (sn, i))
                    r.append("R: tag : %s : * : * 10" % sn)
                    continue
                nr = index[step(rc, moves[a])] if a != "tag" else i
                for oc2, p in sorted(od.items()):
                    t.append("T: %s : %s : r%do%d %s" % (a, sn, nr, index[oc2], fmt(p)))
                r.append("R: %s : %s : * : * %d" % (a, sn, -10 if a == "tag" else -1))
            o.append("O: * : %s : %s 1" % (sn, "found" if i == j else "at%d" % i))
        t.append("T: * : r%dtagged : r%dtagged 1" % (i, i))
        o.append("O: * : r%dtagged : at%d 1" % (i, i))
    return "\n".join(out + [""] + t + [""] + o + [""] + r) + "\n", len(names), len(actions), len(obs_names)


# ---- PomdpX (SARSOP's XML format), factored where natural --------------------------------------

class PomdpX:
    """Builds a PomdpX document: variables, then CondProb / Func tables of TBL entries."""

    def __init__(self, comment, discount):
        self.head = ['<?xml version="1.0" encoding="UTF-8"?>', "<!-- %s -->" % comment,
                     '<pomdpx version="1.0" id="gen_pomdp">',
                     "  <Discount>%g</Discount>" % discount, "  <Variable>"]
        self.sections = {}

    def state(self, name, values, fully_observed=False):
        self.head.append('    <StateVar vnamePrev="%s_0" vnameCurr="%s_1" fullyObs="%s">'
                         '<ValueEnum>%s</ValueEnum></StateVar>'
                         % (name, name, "true" if fully_observed else "false", " ".join(values)))

    def variable(self, tag, name, values=None):
        if values is None:
            self.head.append('    <%s vname="%s"/>' % (tag, name))
        else:
            self.head.append('    <%s vname="%s"><ValueEnum>%s</ValueEnum></%s>'
                             % (tag, name, " ".join(values), tag))

    def table(self, section, var, parents, entries, func=False):
        """entries: (instance tokens, numbers or keyword); later entries override earlier ones."""
        kind, tab = ("Func", "ValueTable") if func else ("CondProb", "ProbTable")
        lines = ["    <%s><Var>%s</Var><Parent>%s</Parent>" % (kind, var, " ".join(parents) or "null"),
                 '    <Parameter type="TBL">']
        for inst, nums in entries:
            text = nums if isinstance(nums, str) else " ".join(fmt(x) for x in nums)
            lines.append("      <Entry><Instance>%s</Instance><%s>%s</%s></Entry>"
                         % (" ".join(inst), tab, text, tab))
        lines.append("    </Parameter></%s>" % kind)
        self.sections.setdefault(section, []).extend(lines)

    def text(self):
        out = self.head + ["  </Variable>"]
        for sec in ("InitialStateBelief", "StateTransitionFunction", "ObsFunction", "RewardFunction"):
            if sec in self.sections:
                out += ["  <%s>" % sec] + self.sections[sec] + ["  </%s>" % sec]
        return "\n".join(out + ["</pomdpx>"]) + "\n"


def rocksample_pomdpx(n, k, d0=20.0, discount=0.95):
    """RockSample[n,k] as in rocksample(), factored: the robot's cell (fully observable, with
    'exit') and one variable per rock. The flat model has (n^2 + 1) 2^k states (the .pomdp file
    has one exit state, n^2 2^k + 1): the exit states differ only in rocks nobody can sample."""
    rocks = rock_layout(n, k)
    start = (0, n // 2)
    pos = [(x, y) for y in range(n) for x in range(n)]
    cell = {p: "x%dy%d" % p for p in pos}
    rock_at = {c: i for i, c in enumerate(rocks)}
    actions = ["north", "south", "east", "west", "sample"] + ["check%d" % (i + 1) for i in range(k)]
    rv = ["rock%d" % (i + 1) for i in range(k)]
    x = PomdpX("RockSample[%d,%d] (Smith & Simmons 2004), factored, written by "
               "tools/pomdp_bench/gen_pomdp.py; start (%d,%d); rocks %s; half-efficiency distance %g"
               % (n, k, start[0], start[1], rocks, d0), discount)
    x.state("robot", [cell[p] for p in pos] + ["exit"], fully_observed=True)
    for r in rv:
        x.state(r, ["good", "bad"])
    x.variable("ObsVar", "obs", ["good", "bad"])
    x.variable("ActionVar", "action", actions)
    x.variable("RewardVar", "reward_move")
    x.variable("RewardVar", "reward_sample")
    for r in rv:
        x.variable("RewardVar", "reward_" + r)
    x.table("InitialStateBelief", "robot_0", [], [([cell[start]], [1])])
    for r in rv:
        x.table("InitialStateBelief", r + "_0", [], [(["-"], "uniform")])
    moves = {"north": (0, 1), "south": (0, -1), "east": (1, 0), "west": (-1, 0)}
    robot, move_reward = [], []
    for p in pos:
        for a, (dx, dy) in moves.items():
            nx, ny = p[0] + dx, p[1] + dy
            if nx >= n:
                robot.append(([a, cell[p], "exit"], [1]))
                move_reward.append(([a, cell[p]], [10]))
            else:
                robot.append(([a, cell[p], cell[(nx, ny)] if 0 <= nx and 0 <= ny < n else cell[p]], [1]))
    for a in actions[4:]:
        robot.append(([a, "-", "-"], "identity"))
    robot.append((["*", "exit", "exit"], [1]))
    x.table("StateTransitionFunction", "robot_1", ["action", "robot_0"], robot)
    for i, r in enumerate(rv):
        x.table("StateTransitionFunction", r + "_1", ["action", "robot_0", r + "_0"],
                [(["*", "*", "-", "-"], "identity"),
                 (["sample", cell[rocks[i]], "-", "-"], [0, 1, 0, 1])])
    # The sensor: checkI reads rock I from the robot's cell; every other action observes 'bad'.
    obs = [(["*", "*"] + ["*"] * k + ["-"], [0, 1])]
    for i in range(k):
        for p in pos:
            eta = 2.0 ** (-math.hypot(p[0] - rocks[i][0], p[1] - rocks[i][1]) / d0)
            right = 0.5 * (1.0 + eta)
            for value, good in (("good", right), ("bad", 1.0 - right)):
                inst = ["check%d" % (i + 1), cell[p]] + ["*"] * k + ["-"]
                inst[2 + i] = value
                obs.append((inst, [good, 1.0 - good]))
    x.table("ObsFunction", "obs", ["action", "robot_1"] + [r + "_1" for r in rv], obs)
    x.table("RewardFunction", "reward_move", ["action", "robot_0"], move_reward, func=True)
    x.table("RewardFunction", "reward_sample", ["action", "robot_0"],
            [(["sample", cell[p]], [-10]) for p in pos if p not in rock_at], func=True)
    for i, r in enumerate(rv):
        x.table("RewardFunction", "reward_" + r, ["action", "robot_0", r + "_0"],
                [(["sample", cell[rocks[i]], "-"], [10, -10])], func=True)
    return x.text(), (n * n + 1) * 2 ** k, len(actions), 2 * (n * n + 1)


def tag_pomdpx(discount=0.95):
    """Tag as in tag(), factored: the robot's cell (fully observable) and the opponent's cell or
    'tagged'; the observation says whether the robot shares the opponent's cell. The same 870
    states; 58 flat observations (robot cell x found) carry what the .pomdp's 30 carry."""
    cells = ["c%d" % i for i in range(len(TAG_CELLS))]
    actions = ["north", "south", "east", "west", "tag"]
    x = PomdpX("Tag (Pineau, Gordon & Thrun 2003), factored, written by tools/pomdp_bench/gen_pomdp.py",
               discount)
    x.state("robot", cells, fully_observed=True)
    x.state("opponent", cells + ["tagged"])
    x.variable("ObsVar", "seen", ["found", "notfound"])
    x.variable("ActionVar", "action", actions)
    x.variable("RewardVar", "reward")
    x.table("InitialStateBelief", "robot_0", [], [(["-"], "uniform")])
    x.table("InitialStateBelief", "opponent_0", [],
            [(["-"], [1.0 / len(cells)] * len(cells) + [0])])
    robot = []
    for a in actions[:4]:
        for i, c in enumerate(TAG_CELLS):
            robot.append(([a, cells[i], "*", cells[TAG_INDEX[tag_step(c, TAG_MOVES[a])]]], [1]))
    robot += [(["tag", "-", "*", "-"], "identity"), (["*", "-", "tagged", "-"], "identity")]
    x.table("StateTransitionFunction", "robot_1", ["action", "robot_0", "opponent_0"], robot)
    opp = []
    for i, rc in enumerate(TAG_CELLS):
        for j, oc in enumerate(TAG_CELLS):
            for oc2, p in sorted(tag_opponent(rc, oc).items()):
                opp.append((["*", cells[i], cells[j], cells[TAG_INDEX[oc2]]], [p]))
        opp.append((["tag", cells[i], cells[i], "-"], [0] * len(cells) + [1]))
    opp.append((["*", "*", "tagged", "tagged"], [1]))
    x.table("StateTransitionFunction", "opponent_1", ["action", "robot_0", "opponent_0"], opp)
    seen = [(["*", "*", "-"], [0, 1])] + [([c, c, "-"], [1, 0]) for c in cells]
    x.table("ObsFunction", "seen", ["robot_1", "opponent_1"], seen)
    rew = [([a, "*", "*"], [-10 if a == "tag" else -1]) for a in actions]
    rew += [(["*", "*", "tagged"], [0])] + [(["tag", c, c], [10]) for c in cells]
    x.table("RewardFunction", "reward", ["action", "robot_0", "opponent_0"], rew, func=True)
    return x.text(), len(cells) * (len(cells) + 1), len(actions), 2 * len(cells)


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="problem", required=True)
    rs = sub.add_parser("rocksample", help="RockSample[N,K]")
    rs.add_argument("n", type=int)
    rs.add_argument("k", type=int)
    rs.add_argument("--d0", type=float, default=20.0, help="half-efficiency distance (20)")
    rs.add_argument("-o", "--output")
    tg = sub.add_parser("tag", help="Tag (870 states)")
    tg.add_argument("-o", "--output")
    for p in (rs, tg):
        p.add_argument("--format", choices=("pomdp", "pomdpx"), default="pomdp",
                       help="Cassandra .pomdp (flat, the default) or SARSOP's PomdpX, factored "
                            "(robot cell fully observable, one variable per rock / the opponent)")
    args = ap.parse_args(argv)
    if args.problem == "rocksample":
        if not (1 <= args.n <= 20 and 0 <= args.k <= 12):
            ap.error("need 1 <= N <= 20 and 0 <= K <= 12")
        gen = rocksample_pomdpx if args.format == "pomdpx" else rocksample
        text, s, a, o = gen(args.n, args.k, args.d0)
    else:
        text, s, a, o = tag_pomdpx() if args.format == "pomdpx" else tag()
    if args.output:
        with open(args.output, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    sys.stderr.write("gen_pomdp: %s: %d states, %d actions, %d observations\n" % (args.problem, s, a, o))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
