#!/usr/bin/python3
"""rostest: the robot serves the request that was said (the sentences of the delivery-decisions
issue and variants), every serve is the most likely request, and dialog_node decides exactly as
the core's DeliveryManager driven by dialog_script on the same script (questions, serve, legs,
checks, outcome). Two dialog nodes (namespaces human and easy) with different P^N."""
import json
import subprocess
import sys
import threading
import time
import unittest

import actionlib
import roslib.packages
import rospy
import rostest
from krr_msgs.msg import (DeliveryStatus, DialogBelief, NavigateAction, NavigateResult,
                          RobotUtterance, UserUtterance)
from std_msgs.msg import String

QUESTIONS = (RobotUtterance.ASK_ITEM, RobotUtterance.ASK_ROOM, RobotUtterance.ASK_PERSON,
             RobotUtterance.CONFIRM_ITEM, RobotUtterance.CONFIRM_ROOM,
             RobotUtterance.CONFIRM_PERSON)
FINAL = (DeliveryStatus.FULFILLED, DeliveryStatus.UNCONFIRMED, DeliveryStatus.FAILED)
REACH = {"human": "0.999,0.384,0.619,0.999,0.241", "easy": "1.0,0.2,1.0,0.3,0.1"}


class Robot(object):
    """One dialog node: its topics, and a navigation server that records the goals."""

    def __init__(self, ns):
        self.ns = ns
        self.lock = threading.Lock()
        self.utterances, self.statuses, self.decisions, self.beliefs, self.goals = [], [], [], [], []
        self.subs = [
            rospy.Subscriber(ns + "/robot_utterance", RobotUtterance, self._add(self.utterances)),
            rospy.Subscriber(ns + "/delivery_status", DeliveryStatus, self._add(self.statuses)),
            rospy.Subscriber(ns + "/dialog/decisions", String, self._add(self.decisions)),
            rospy.Subscriber(ns + "/dialog_belief", DialogBelief, self._add(self.beliefs)),
        ]
        self.pub = rospy.Publisher(ns + "/user_utterance", UserUtterance, queue_size=10)
        self.server = actionlib.SimpleActionServer(ns + "/navigate", NavigateAction,
                                                   self._execute, False)
        self.server.start()

    def _add(self, target):
        def cb(msg):
            with self.lock:
                target.append(msg)
        return cb

    def _execute(self, goal):
        with self.lock:
            self.goals.append(goal.place)
        self.server.set_succeeded(NavigateResult(success=True, outcome="reached", steps=5))

    def ready(self):
        return self.pub.get_num_connections() > 0 and all(s.get_num_connections() > 0
                                                          for s in self.subs)

    def mark(self):
        with self.lock:
            return (len(self.utterances), len(self.statuses), len(self.decisions),
                    len(self.beliefs), len(self.goals))


class DialogDecisionsTest(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_dialog_decisions")
        cls.robots = {ns: Robot("/" + ns) for ns in REACH}
        deadline = time.time() + 120  # each node builds and solves its model first
        while time.time() < deadline and not all(r.ready() for r in cls.robots.values()):
            time.sleep(0.2)
        time.sleep(0.5)
        found = roslib.packages.find_node("krr_core", "dialog_script")
        assert found, "dialog_script not built"
        cls.cli = found[0]
        cls.root = rospy.get_param("~root")

    def wait_for(self, robot, items, pred, start, timeout=20.0):
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown():
            with robot.lock:
                for m in items[start:]:
                    if pred(m):
                        return m
            time.sleep(0.02)
        with robot.lock:
            got = [getattr(m, "text", getattr(m, "status", getattr(m, "data", m)))
                   for m in items[start:]]
        self.fail("%s: timed out; got %r" % (robot.ns, got))

    def deliver(self, robot, want, opening, checks=("yes",)):
        """Talk to the robot through topics as a person who wants `want` (item, room, person):
        the opening utterances, then truthful answers; at the room the `checks` in order.
        Returns (the utterances said during the dialog, the serve utterance, the decisions,
        the final status)."""
        nu, ns, nd, _, ng = robot.mark()
        pending = list(opening)
        said = [pending.pop(0)]
        robot.pub.publish(UserUtterance(text=said[0]))
        asked = nu
        while True:
            m = self.wait_for(robot, robot.utterances,
                              lambda u: u.kind in QUESTIONS + (RobotUtterance.SERVE,), asked)
            with robot.lock:
                asked = robot.utterances.index(m) + 1
            if m.kind == RobotUtterance.SERVE:
                serve = m
                break
            if pending:
                text = pending.pop(0)
            else:
                factor = m.kind.split("_")[1]
                text = (want[factor] if m.kind.startswith("ask") else
                        ("yes" if m.value == want[factor] else "no"))
            said.append(text)
            robot.pub.publish(UserUtterance(text=text))
        for text in checks:
            self.wait_for(robot, robot.statuses, lambda s: s.status == DeliveryStatus.ARRIVED and
                          s.dialog_id == serve.dialog_id, ns)
            with robot.lock:
                ns = len(robot.statuses)
            robot.pub.publish(UserUtterance(text=text))
        final = self.wait_for(robot, robot.statuses, lambda s: s.status in FINAL and
                              s.dialog_id == serve.dialog_id, ns)
        time.sleep(0.2)
        with robot.lock:
            decisions = [d.data for d in robot.decisions[nd:]]
            goals = robot.goals[ng:]
        return said, serve, decisions, final, goals

    def core(self, ns, said, checks):
        """The same script through the core's DeliveryManager (dialog_script deliver)."""
        # The nodes' budget (dialog_decisions.test): the same policy.
        cmd = [self.cli, "--deliver", "--json", "--reach", REACH[ns], "--root", self.root,
               "--solver-trials", "1500"]
        for u in said:
            cmd += ["--utterance", u]
        for c in checks:
            cmd += ["--check", c]
        out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=120,
                             universal_newlines=True)
        self.assertEqual(out.returncode, 0, out.stderr)
        self.assertIn("policy: loaded", out.stderr,
                      "the CLI should load the policy dialog_node solved (same builder, same "
                      "solver options, same cache key): " + out.stderr)
        return json.loads(out.stdout)

    def check_case(self, ns, want, opening, checks=("yes",)):
        robot = self.robots[ns]
        said, serve, decisions, final, goals = self.deliver(robot, want, opening, checks)
        core = self.core(ns, said, checks)
        label = "%s: %r" % (ns, opening)
        self.assertEqual(decisions, core["decisions"], label)
        self.assertTrue(core["completed"], label)
        self.assertEqual(core["served_probability"], core["max_probability"],
                         label + ": the serve is not the most likely request")
        self.assertEqual(final.status, core["outcome"], label)
        # What the node did agrees with its decisions: the goals it sent are the legs.
        self.assertEqual(["navigate " + g for g in goals],
                         [d for d in decisions if d.startswith("navigate ")], label)
        return serve, final

    def test_1_the_issues_sentences_are_served_as_said(self):
        for ns in REACH:
            serve, final = self.check_case(
                ns, {"item": "coke", "room": "room2", "person": "bob"},
                ["I would like a coke for Bob to office2, please"])
            self.assertEqual(serve.value, "coke,room2,bob", ns)
            self.assertEqual(final.status, DeliveryStatus.FULFILLED)
            serve, final = self.check_case(
                ns, {"item": "soda", "room": "room3", "person": "john"},
                ["Could you bring a soda for John to room 3?", "room 3"])
            self.assertEqual(serve.value, "soda,room3,john", ns)

    def test_2_variants_with_other_items_persons_and_rooms(self):
        cases = [({"item": "coffee", "room": "room4", "person": "bob"},
                  "an espresso for Robert to office four"),
                 ({"item": "coke", "room": "room1", "person": "john"},
                  "Hi, could I get a cola for john in room 1?"),
                 ({"item": "soda", "room": "room5", "person": "bob"},
                  "please take a soda to room5 for bob"),
                 ({"item": "coffee", "room": "room2", "person": "john"},
                  "coffee, john, office2")]
        for ns in REACH:
            for want, sentence in cases:
                serve, _ = self.check_case(ns, want, [sentence])
                self.assertEqual(serve.value, "%(item)s,%(room)s,%(person)s" % want,
                                 "%s: %r" % (ns, sentence))

    def test_3_corrected_at_the_room_is_redelivered_the_same_way(self):
        # The robot hears coke for bob to room2 (the person's answers agree), the person then
        # says it was a soda for john to room5: back to the shop, deliver again.
        for ns in REACH:
            serve, final = self.check_case(
                ns, {"item": "coke", "room": "room2", "person": "bob"},
                ["a coke for bob to office2"], checks=("no, a soda for john to room5", "yes"))
            self.assertEqual(final.status, DeliveryStatus.FULFILLED)
            self.assertEqual(final.attempt, 2)
            self.assertEqual((final.request.item, final.request.room, final.request.person),
                             ("soda", "room5", "john"))


if __name__ == "__main__":
    rostest.rosrun("krr_ros", "dialog_decisions", DialogDecisionsTest, sys.argv)
