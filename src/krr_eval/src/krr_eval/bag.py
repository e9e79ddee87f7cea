"""The delivery table of a ROS run, recomputed from a rosbag (`sim.launch record:=true`).

    rosbag record (sim.launch record:=true bag:=/tmp/run.bag) ... then
    rosbag info /tmp/run.bag
    rosrun krr_eval bag_table /tmp/run.bag [--json] [--dialog-config config/dialog.yaml]

One row per delivery (dialog) that ended, the columns of the delivery experiments' table:
reward, identified, delivered, QA cost and the belief's entropy when the robot decided to
serve, with what they are made of (hidden and served requests, questions, navigation moves).
The table is computed from messages only, through the rosbag Python API, so the same code gives
the same table live (`DeliveryTable.add` from rospy callbacks) and from the bag:

  delivery_status (krr_msgs/DeliveryStatus)        per dialog: outcome, questions, QA cost,
                                                   entropy at the serve (bits), attempts
  robot_utterance (krr_msgs/RobotUtterance)        the serve: the request the robot decided on
  simulated_user/hidden_request (ServiceRequest)   what the person wanted (the truth)
  navigate/goal, navigate/result (Navigate action) trips and moves driven for the delivery

Messages are ordered by their header stamps (the publishers' clock), not by arrival, so a bag
and a live subscriber that received them in a different order give the same table. The reward
follows krr::dialog::deliveryReward (src/krr_core/include/krr_core/dialog/delivery_manager.h)
with config/dialog.yaml's values: +success_reward if fulfilled else failure_reward, minus the QA
cost, minus serve_cost.weight x (step_cost x moves + failure_penalty if a trip failed) when
serve_cost.mode is expected, minus wrong_delivery_penalty if the served request was not the
person's.
"""
import argparse
import json
import math
import os
import sys

import yaml

from . import paths

STATUS = "/delivery_status"
UTTERANCE = "/robot_utterance"
HIDDEN = "/simulated_user/hidden_request"
NAV_GOAL = "/navigate/goal"
NAV_RESULT = "/navigate/result"
# The topics the table needs; sim.launch's recorder records these and more (the whole dialog:
# user_utterance, dialog_belief, dialog/decisions; navigation: feedback, robot_pose, paths).
TABLE_TOPICS = (STATUS, UTTERANCE, HIDDEN, NAV_GOAL, NAV_RESULT)
FINAL = ("fulfilled", "unconfirmed", "failed")
COLUMNS = ("dialog", "request", "served", "outcome", "identified", "delivered", "questions",
           "qa_cost", "entropy_bits", "attempts", "trips", "moves", "nav_failed", "reward")


class RewardConfig(object):
    """The reward terms of config/dialog.yaml (sections dialog, serve_cost, navigation)."""

    def __init__(self, success=80.0, failure=-80.0, expected_nav=True, weight=1.0,
                 step_cost=1.0, failure_penalty=40.0, wrong_penalty=120.0):
        self.success, self.failure = success, failure
        self.expected_nav, self.weight = expected_nav, weight
        self.step_cost, self.failure_penalty = step_cost, failure_penalty
        self.wrong_penalty = wrong_penalty

    @classmethod
    def load(cls, path=None):
        path = path or paths.repo("config", "dialog.yaml")
        with open(path) as f:
            y = yaml.safe_load(f) or {}
        d, s, n = y.get("dialog", {}), y.get("serve_cost", {}), y.get("navigation", {})
        c = cls()
        c.success = float(d.get("success_reward", c.success))
        c.failure = float(d.get("failure_reward", c.failure))
        c.expected_nav = str(s.get("mode", "expected")) == "expected"
        c.weight = float(s.get("weight", c.weight))
        c.wrong_penalty = float(s.get("wrong_delivery_penalty", c.wrong_penalty))
        c.step_cost = float(n.get("step_cost", c.step_cost))
        c.failure_penalty = float(n.get("failure_penalty", c.failure_penalty))
        return c


def _stamp(msg, fallback):
    """The message's header stamp in seconds (fallback: the bag's / arrival time)."""
    h = getattr(msg, "header", None)
    if h is not None and (h.stamp.secs or h.stamp.nsecs):
        return h.stamp.to_sec()
    return fallback


def _req(r):
    return "%s,%s,%s" % (r.item, r.room, r.person)


class DeliveryTable(object):
    """Accumulates the messages of TABLE_TOPICS (live or from a bag) and makes the table."""

    def __init__(self, config=None):
        self.config = config or RewardConfig()
        self.events = []  # (stamp, arrival index, topic, msg)

    def add(self, topic, msg, t=None):
        """One message; t: its receive time in seconds (used if it has no header stamp)."""
        if not topic.startswith("/"):
            topic = "/" + topic
        if topic not in TABLE_TOPICS:
            return
        stamp = _stamp(msg, float(t) if t is not None else 0.0)
        self.events.append((stamp, len(self.events), topic, msg))

    def rows(self):
        """One dict per ended delivery (COLUMNS), in the order the deliveries ended."""
        ev = sorted(self.events, key=lambda e: (e[0], e[1]))
        hidden = [(s, _req(m)) for s, _, t, m in ev if t == HIDDEN]
        serves = {}
        for s, _, t, m in ev:
            if t == UTTERANCE and m.kind == "serve":
                serves.setdefault(m.dialog_id, _req(m.request))
        starts, finals = {}, []
        for s, _, t, m in ev:
            if t != STATUS:
                continue
            starts.setdefault(m.dialog_id, s)  # the first status: serving (the decision)
            if m.status in FINAL and all(f[1].dialog_id != m.dialog_id for f in finals):
                finals.append((s, m))
        out = []
        for end, m in finals:
            begin = starts[m.dialog_id]
            truth = None
            for s, r in hidden:  # the person's request: the last one drawn before the serve
                if s <= begin:
                    truth = r
            goals = [x for s, _, t, x in ev if t == NAV_GOAL and begin <= s <= end]
            results = [x.result for s, _, t, x in ev if t == NAV_RESULT and begin <= s <= end]
            moves = sum(int(r.steps) for r in results)
            nav_failed = any(not r.success for r in results) or len(goals) > len(results)
            served = serves.get(m.dialog_id)
            identified = None if truth is None or served is None else served == truth
            delivered = m.status == "fulfilled"
            c = self.config
            reward = None
            if identified is not None:
                reward = ((c.success if delivered else c.failure) - m.qa_cost -
                          (c.weight * (c.step_cost * moves +
                                       (c.failure_penalty if nav_failed else 0.0))
                           if c.expected_nav else 0.0) -
                          (0.0 if identified else c.wrong_penalty))
            out.append({"dialog": int(m.dialog_id), "request": truth, "served": served,
                        "outcome": m.status, "identified": identified, "delivered": delivered,
                        "questions": int(m.turns), "qa_cost": float(m.qa_cost),
                        "entropy_bits": float(m.entropy), "attempts": int(m.attempt),
                        "trips": len(goals), "moves": moves, "nav_failed": nav_failed,
                        "reward": reward})
        return out


def summary(rows):
    """Means over the deliveries (None where a column is unknown)."""
    def mean(key, f=float):
        v = [f(r[key]) for r in rows if r[key] is not None]
        return sum(v) / len(v) if v else None
    return {"deliveries": len(rows), "reward": mean("reward"), "identified": mean("identified"),
            "delivered": mean("delivered"), "qa_cost": mean("qa_cost"),
            "entropy_bits": mean("entropy_bits")}


def read_bag(path, config=None):
    """The DeliveryTable of a bag file (rosbag Python API)."""
    import rosbag  # python3-rosbag; imported here so the rest works without it
    table = DeliveryTable(config)
    with rosbag.Bag(path) as b:
        for topic, msg, t in b.read_messages(topics=list(TABLE_TOPICS)):
            table.add(topic, msg, t.to_sec())
    return table


def _cell(v, fmt="%.2f"):
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return fmt % v
    return str(v)


def markdown(rows):
    """The table as Markdown, with a mean row."""
    head = ["dialog", "request", "served", "outcome", "reward", "identified", "delivered",
            "questions", "QA cost", "entropy at serve (bits)", "trips", "moves"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        lines.append("| " + " | ".join(_cell(x) for x in (
            r["dialog"], r["request"], r["served"], r["outcome"], r["reward"], r["identified"],
            r["delivered"], r["questions"], r["qa_cost"], r["entropy_bits"], r["trips"],
            r["moves"])) + " |")
    s = summary(rows)
    lines.append("| mean (%d) | | | | %s | %s | %s | | %s | %s | | |" % (
        s["deliveries"], _cell(s["reward"]), _cell(s["identified"], "%.3f"),
        _cell(s["delivered"], "%.3f"), _cell(s["qa_cost"]), _cell(s["entropy_bits"], "%.3f")))
    return "\n".join(lines)


def same_rows(a, b, tol=1e-9):
    """Whether two tables are equal (floats within tol); returns (bool, first difference)."""
    if len(a) != len(b):
        return False, "%d rows vs %d" % (len(a), len(b))
    for i, (x, y) in enumerate(zip(a, b)):
        for k in COLUMNS:
            u, v = x[k], y[k]
            if isinstance(u, float) and isinstance(v, float):
                if not (math.isclose(u, v, abs_tol=tol) or (math.isnan(u) and math.isnan(v))):
                    return False, "row %d %s: %r vs %r" % (i + 1, k, u, v)
            elif u != v:
                return False, "row %d %s: %r vs %r" % (i + 1, k, u, v)
    return True, ""


def main(argv=None):
    ap = argparse.ArgumentParser(prog="bag_table", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("bag", help="a bag recorded by sim.launch record:=true")
    ap.add_argument("--json", action="store_true", help="rows and means as JSON")
    ap.add_argument("--dialog-config", help="the rewards (default: the repository's "
                    "config/dialog.yaml)")
    a = ap.parse_args(argv)
    if not os.path.isfile(a.bag):
        ap.error("%s: no such file" % a.bag)
    try:
        config = RewardConfig.load(a.dialog_config)
        table = read_bag(a.bag, config)
    except Exception as e:  # unreadable bag or config: say which, no traceback
        sys.stderr.write("bag_table: %s: %s\n" % (a.bag, e))
        return 1
    rows = table.rows()
    if a.json:
        print(json.dumps({"rows": rows, "mean": summary(rows)}, indent=1, sort_keys=True))
    else:
        print(markdown(rows))
    if not rows:
        sys.stderr.write("bag_table: %s has no finished delivery (topics %s)\n"
                         % (a.bag, ", ".join(TABLE_TOPICS)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
