#!/usr/bin/python3
"""rostest of dialog_node alone: belief and questions from text, robustness to bad input,
parameter validation, and a delivery that fails cleanly when navigation is not running."""
import os
import subprocess
import sys
import threading
import time
import unittest

import roslib.packages
import actionlib
import rospy
import rostest
from krr_msgs.msg import (DeliveryStatus, DialogBelief, NavigateAction, NavigateResult,
                          RobotUtterance, UserUtterance)

from krr_test_utils import appender, wait_connected

QUESTIONS = (RobotUtterance.ASK_ITEM, RobotUtterance.ASK_ROOM, RobotUtterance.ASK_PERSON,
             RobotUtterance.CONFIRM_ITEM, RobotUtterance.CONFIRM_ROOM,
             RobotUtterance.CONFIRM_PERSON)
REQUEST = {"item": "coke", "room": "room2", "person": "bob"}
FINAL = (DeliveryStatus.FULFILLED, DeliveryStatus.UNCONFIRMED, DeliveryStatus.FAILED)


class DialogNodeTest(unittest.TestCase):
    """Runs in name order against one dialog_node: the steps build on each other."""

    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_dialog_node")
        cls.lock = threading.Lock()
        cls.utterances, cls.beliefs, cls.statuses = [], [], []
        cls.subs = [
            rospy.Subscriber("robot_utterance", RobotUtterance, cls._append(cls.utterances)),
            rospy.Subscriber("dialog_belief", DialogBelief, cls._append(cls.beliefs)),
            rospy.Subscriber("delivery_status", DeliveryStatus, cls._append(cls.statuses)),
        ]
        cls.pub = rospy.Publisher("user_utterance", UserUtterance, queue_size=10)
        wait_connected([cls.pub], cls.subs)  # the node solves its POMDP before subscribing

    @classmethod
    def _append(cls, target):
        return appender(cls.lock, target)

    def say(self, text, dialog_id=0):
        self.pub.publish(UserUtterance(text=text, dialog_id=dialog_id))

    def wait_for(self, items, pred, start, timeout=10.0):
        """The first message of items[start:] satisfying pred, or fail."""
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown():
            with self.lock:
                for m in items[start:]:
                    if pred(m):
                        return m
            time.sleep(0.05)
        self.fail("timed out; got %r" % [getattr(m, "text", getattr(m, "status", m))
                                         for m in items[start:]])

    def counts(self):
        with self.lock:
            return len(self.utterances), len(self.beliefs), len(self.statuses)

    def converse(self, request, max_questions=25):
        """Answer the robot's questions truthfully for request until it serves; the serve."""
        for _ in range(max_questions + 1):
            nu, _, _ = self.counts()
            with self.lock:
                last = [m for m in self.utterances if m.kind in QUESTIONS + (RobotUtterance.SERVE,)]
            m = last[-1]
            if m.kind == RobotUtterance.SERVE:
                return m
            factor = m.kind.split("_")[1]
            self.say(request[factor] if m.kind.startswith("ask") else
                     ("yes" if m.value == request[factor] else "no"))
            self.wait_for(self.utterances, lambda u: u.kind in QUESTIONS + (RobotUtterance.SERVE,),
                          nu)
        self.fail("the robot never served within %d questions" % max_questions)

    def start(self, sentence, dialog_id):
        """A new dialog: wait until the previous delivery ended, say the sentence."""
        self.wait_for(self.statuses, lambda m: m.dialog_id == dialog_id - 1 and
                      m.status in FINAL, 0, timeout=15)
        nu, _, _ = self.counts()
        self.say(sentence)
        q = self.wait_for(self.utterances, lambda m: m.kind in QUESTIONS + (RobotUtterance.SERVE,),
                          nu)
        self.assertEqual(q.dialog_id, dialog_id)

    def test_1_full_sentence_moves_the_belief_and_gets_a_question(self):
        nu, nb, _ = self.counts()
        self.say("I'd like a coke for Bob to office2, please")
        q = self.wait_for(self.utterances, lambda m: m.kind in QUESTIONS, nu)
        self.assertEqual(q.dialog_id, 1)
        self.assertTrue(q.text.endswith("?"), q.text)
        b = self.wait_for(self.beliefs, lambda m: m.dialog_id == 1, nb)
        p = lambda names, probs, v: probs[list(names).index(v)]
        # Prior: items and persons uniform, room2 0.425 (bob's office); the sentence moves all.
        self.assertGreater(p(b.items, b.item_probabilities, "coke"), 0.75)
        self.assertGreater(p(b.persons, b.person_probabilities, "bob"), 0.9)
        self.assertGreater(p(b.rooms, b.room_probabilities, "room2"), 0.9)
        self.assertAlmostEqual(sum(b.room_probabilities), 1.0, places=9)
        self.assertEqual((b.most_likely.item, b.most_likely.room, b.most_likely.person),
                         ("coke", "room2", "bob"))
        self.assertLess(b.entropy, 3.7)  # prior entropy: 3.707 bits

    def test_2_garbage_is_reported_and_the_node_stays_alive(self):
        nu, _, _ = self.counts()
        self.say("xyzzy !!! plugh \xff")
        n = self.wait_for(self.utterances, lambda m: m.kind == RobotUtterance.NOTICE and
                          "xyzzy" in m.text and "plugh" in m.text, nu)
        self.assertIn("did not understand", n.text)
        # The same question is asked again: nothing was understood, the turn does not count.
        again = self.wait_for(self.utterances, lambda m: m.kind in QUESTIONS, nu)
        self.assertEqual(again.turn, 1)
        nu, _, _ = self.counts()
        self.say("")
        self.wait_for(self.utterances, lambda m: m.kind == RobotUtterance.NOTICE and
                      "empty" in m.text, nu)
        nu, _, _ = self.counts()
        self.say("coke", dialog_id=999)
        self.wait_for(self.utterances, lambda m: m.kind == RobotUtterance.NOTICE and
                      "999" in m.text, nu)

    def test_3_dialog_serves_and_fails_cleanly_without_navigation(self):
        _, _, ns = self.counts()
        served = self.converse(REQUEST)
        self.assertEqual((served.request.item, served.request.room, served.request.person),
                         ("coke", "room2", "bob"))
        st = self.wait_for(self.statuses, lambda m: m.status == DeliveryStatus.FAILED, ns,
                           timeout=15)
        self.assertIn("not available", st.message)
        self.assertEqual(st.request.room, "room2")
        self.assertGreater(st.qa_cost, 0)
        # Idle again: a new sentence starts dialog 2.
        nu, _, _ = self.counts()
        self.say("a soda for john")
        q = self.wait_for(self.utterances, lambda m: m.kind in QUESTIONS + (RobotUtterance.SERVE,),
                          nu)
        self.assertEqual(q.dialog_id, 2)
        # Dialog 2 ends too (serve, then no navigation), so the next test starts from idle.
        _, _, ns = self.counts()
        self.converse({"item": "soda", "room": "room5", "person": "john"})
        self.wait_for(self.statuses, lambda m: m.dialog_id == 2 and m.status in FINAL, ns,
                      timeout=15)

    def test_4_bad_parameters_are_refused_with_their_name(self):
        root = rospy.get_param("~root")
        node = roslib.packages.find_node("krr_ros", "dialog_node")
        self.assertTrue(node, "dialog_node executable not found")
        for bad, value, expect in (("navigation_timeout", -1.0, "navigation_timeout"),
                                   ("colour", "red", "colour"),
                                   ("model_source", "magic", "model_source"),
                                   ("reach_probabilities", [0.9, 1.5, 0.9, 0.9, 0.9],
                                    "reach_probabilities[1]")):
            if rospy.has_param("/bad_dialog"):
                rospy.delete_param("/bad_dialog")
            rospy.set_param("/bad_dialog", {"base_dir": root, "model_source": "reach",
                                            "reach_probabilities": [0.9] * 5, bad: value})
            out = subprocess.run([node[0], "__name:=bad_dialog"], stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, timeout=30, universal_newlines=True)
            self.assertEqual(out.returncode, 1, out.stdout)
            self.assertIn("cannot start", out.stdout)
            self.assertIn(expect, out.stdout)
    def test_5_delivery_check_redelivery_timeout_and_navigation_failure(self):
        goals, outcome = [], {"fail": False}

        def execute(goal):
            goals.append(goal.place)
            if outcome["fail"]:
                server.set_aborted(NavigateResult(success=False, outcome="trapped",
                                                  failure_reason="trapped by walkers in ba1"))
            else:
                server.set_succeeded(NavigateResult(success=True, outcome="reached"))
        server = actionlib.SimpleActionServer("navigate", NavigateAction, execute, False)
        server.start()
        # Dialog 3: wrong delivery (the robot heard room2), corrected, redelivered, confirmed.
        self.start("a coke for bob to office2", 3)
        _, _, ns = self.counts()
        self.assertEqual(self.converse(REQUEST).request.room, "room2")
        self.wait_for(self.statuses, lambda m: m.status == DeliveryStatus.ARRIVED, ns)
        self.say("no, a soda for john to room5")
        self.wait_for(self.statuses, lambda m: m.status == DeliveryStatus.RETURNING, ns)
        arrived2 = self.wait_for(self.statuses, lambda m: m.status == DeliveryStatus.ARRIVED and
                                 m.attempt == 2, ns)
        self.assertEqual((arrived2.request.item, arrived2.request.room, arrived2.request.person),
                         ("soda", "room5", "john"))
        self.say("yes")
        done = self.wait_for(self.statuses, lambda m: m.status in FINAL, ns)
        self.assertEqual(done.status, DeliveryStatus.FULFILLED)
        self.assertEqual(done.attempt, 2)
        self.assertEqual(goals, ["shop", "room2", "shop", "room5"])
        # Dialog 4: nobody answers the check -> unconfirmed after ~check_timeout.
        self.start("a coke for bob to office2", 4)
        _, _, ns = self.counts()
        self.converse(REQUEST)
        self.wait_for(self.statuses, lambda m: m.status == DeliveryStatus.ARRIVED, ns)
        done = self.wait_for(self.statuses, lambda m: m.status in FINAL, ns, timeout=10)
        self.assertEqual(done.status, DeliveryStatus.UNCONFIRMED)
        # Dialog 5: navigation fails -> failed, with navigation's reason.
        outcome["fail"] = True
        self.start("a coke for bob to office2", 5)
        _, _, ns = self.counts()
        self.converse(REQUEST)
        done = self.wait_for(self.statuses, lambda m: m.status in FINAL, ns)
        self.assertEqual(done.status, DeliveryStatus.FAILED)
        self.assertIn("trapped by walkers", done.message)


if __name__ == "__main__":
    rostest.rosrun("krr_ros", "dialog_node", DialogNodeTest, sys.argv)
