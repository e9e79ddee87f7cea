#!/usr/bin/python3
"""rostest: dialog_node serves certified dialog policies without making a person wait.

Started as shipped on a model whose configured (certified) policy is not in the cache, the node
serves at once with a provisional policy (~startup_max_trials), publishes it on ~policy as
provisional, and answers a request within 0.5 s while the certified policy is solved in the
background. The certified policy is installed between dialogs and published with its gap at
most the configured precision; the next dialog runs on it. A second start with the same cache
loads the certified policy directly: no provisional policy, no background solve."""
import os
import shutil
import signal
import sys
import threading
import time
import unittest

import rospy
import rostest
from krr_msgs.msg import DeliveryStatus, DialogPolicy, RobotUtterance, UserUtterance
from rosgraph_msgs.msg import Log

from krr_test_utils import (DELIVERY_FINAL as FINAL, DIALOG_REPLIES as REPLIES,
                            DIALOG_REQUEST as REQUEST, DIALOG_SENTENCE as SENTENCE,
                            RecordingMixin, dialog_node_params)

NODE = "dialog"
MAX_LATENCY = 0.5    # s from a request to the robot's first reply
START_WAIT = 60.0    # s for the node to serve (a provisional solve takes seconds)
SOLVE_WAIT = 300.0   # s for the certified background solve (about 25 s alone on this model)


class DialogCertifyTest(RecordingMixin, unittest.TestCase):
    """Runs in name order: the steps build on each other (one node, then a second start)."""
    node_name = NODE

    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_dialog_certify")
        root = os.path.realpath(rospy.get_param("~root"))  # catkin_ws/src links to src/
        cls.tmp = rospy.get_param("~tmp_dir")
        cls.cache = os.path.join(cls.tmp, "policies")
        shutil.rmtree(cls.cache, ignore_errors=True)
        os.makedirs(cls.tmp, exist_ok=True)
        params = dialog_node_params(root, policy_cache=cls.cache, knowledge_updates="")
        rospy.set_param("/" + NODE, params)
        cls.lock = threading.Lock()
        cls.utterances, cls.statuses, cls.policies, cls.logs = [], [], [], []
        cls.subs = [
            rospy.Subscriber("robot_utterance", RobotUtterance, cls._append(cls.utterances)),
            rospy.Subscriber("delivery_status", DeliveryStatus, cls._append(cls.statuses)),
            rospy.Subscriber("/%s/policy" % NODE, DialogPolicy, cls._append(cls.policies)),
            rospy.Subscriber("/rosout", Log, cls._log, queue_size=1000),
        ]
        cls.pub = rospy.Publisher("user_utterance", UserUtterance, queue_size=10)
        cls.start_node("first")

    @classmethod
    def start_node(cls, tag):
        with cls.lock:
            del cls.policies[:]
            del cls.logs[:]
        cls.started = time.time()
        cls.ready = cls.start_node_process(
            "dialog_node", os.path.join(cls.tmp, "dialog_node_%s.log" % tag),
            lambda: cls.pub.get_num_connections() > 0 and all(
                s.get_num_connections() > 0 for s in cls.subs[:3]),
            START_WAIT)

    # --- helpers ----------------------------------------------------------------------------
    def request_and_finish(self, dialog_id):
        """Say SENTENCE (first reply within MAX_LATENCY), answer truthfully, serve; the delivery
        fails without a navigation server. Returns the first reply's latency."""
        with self.lock:
            nu, ns = len(self.utterances), len(self.statuses)
        sent = time.time()
        self.pub.publish(UserUtterance(text=SENTENCE))
        t, reply = self.wait_for(self.utterances, lambda m: m.kind in REPLIES, nu, 30,
                                 "the robot's first reply")
        self.assertEqual(reply.dialog_id, dialog_id)
        latency = t - sent
        print("dialog %d: first reply '%s' %.3f s after the request" % (dialog_id, reply.text,
                                                                        latency))
        self.assertLess(latency, MAX_LATENCY, "the robot answered %.2f s after the request" %
                        latency)
        m = reply
        for _ in range(26):
            if m.kind == RobotUtterance.SERVE:
                break
            with self.lock:
                nu = len(self.utterances)
            factor = m.kind.split("_")[1]
            self.pub.publish(UserUtterance(text=REQUEST[factor] if m.kind.startswith("ask") else
                                           ("yes" if m.value == REQUEST[factor] else "no")))
            _, m = self.wait_for(self.utterances, lambda u: u.kind in REPLIES, nu, 10, "a reply")
        self.assertEqual(m.kind, RobotUtterance.SERVE, "the robot never served")
        self.assertEqual((m.request.item, m.request.room, m.request.person),
                         ("coke", "room2", "bob"))
        self.wait_for(self.statuses, lambda s: s.dialog_id == dialog_id and s.status in FINAL,
                      ns, 15, "the delivery's end")
        return latency

    # --- steps ------------------------------------------------------------------------------
    def test_1_serves_at_once_with_a_provisional_policy(self):
        self.assertLess(self.ready - self.started, START_WAIT, "dialog_node never served:\n" +
                        self.node_output())
        _, first = self.wait_for(self.policies, lambda m: True, 0, 10, "~policy")
        self.assertEqual(first.status, DialogPolicy.PROVISIONAL)
        self.assertFalse(first.from_cache)
        self.assertEqual(first.trials, 1500)   # config/dialog_node.yaml's startup_max_trials
        self.assertGreater(first.gap, 0.0)
        self.assertLessEqual(first.lower, first.upper)
        self.assertEqual(first.precision, 1.0)  # config/dialog.yaml's
        self.assertTrue(self.logged("serving with a provisional policy"))
        self.assertTrue(self.logged("solving the configured policy in the background"))
        # The robot talks while the certified policy is being solved.
        self.request_and_finish(1)
        self.assertFalse(self.logged("new dialog policy installed"),
                         "the background solve ended before the dialog: nothing was tested")

    def test_2_installs_the_certified_policy_between_dialogs(self):
        _, cert = self.wait_for(self.policies, lambda m: m.status != DialogPolicy.PROVISIONAL, 0,
                                SOLVE_WAIT, "the certified policy on ~policy")
        print("certified: bounds [%.3f, %.3f], gap %.3f, %d trials, %d vectors, %.1f s after "
              "start" % (cert.lower, cert.upper, cert.gap, cert.trials, cert.vectors,
                         time.time() - self.started))
        self.assertEqual(cert.status, DialogPolicy.CERTIFIED)
        self.assertLessEqual(cert.gap, cert.precision)
        self.assertLessEqual(cert.lower, cert.upper)
        self.assertGreater(cert.trials, 1500)
        self.assertFalse(cert.from_cache)
        self.assertTrue(os.path.isfile(cert.cache_file), cert.cache_file)
        self.assertTrue(self.logged("new dialog policy installed (solved, certified)"))
        self.request_and_finish(2)

    def test_3_a_second_start_loads_the_certified_policy(self):
        self.proc.send_signal(signal.SIGINT)
        self.assertEqual(self.proc.wait(15), 0, self.node_output())
        type(self).start_node("second")
        self.setUp()
        _, first = self.wait_for(self.policies, lambda m: True, 0, 10, "~policy")
        self.assertEqual(first.status, DialogPolicy.CERTIFIED)
        self.assertTrue(first.from_cache)
        self.assertLessEqual(first.gap, first.precision)
        self.assertFalse(self.logged("provisional"))
        self.assertFalse(self.logged("in the background"))
        self.request_and_finish(1)


if __name__ == "__main__":
    rostest.rosrun("krr_ros", "dialog_certify", DialogCertifyTest, sys.argv)
