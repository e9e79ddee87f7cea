#!/usr/bin/python3
"""rostest of navigation_node's external executor (see executor.test). Runs in name order."""
import signal
import os
import threading
import time
import unittest

try:
    from xmlrpc.client import ServerProxy
except ImportError:  # pragma: no cover
    from xmlrpclib import ServerProxy

import actionlib
import rosgraph
import rospy
import rostest
import yaml
from actionlib_msgs.msg import GoalStatus
from std_msgs.msg import Bool
from tf2_msgs.msg import TFMessage
from krr_msgs.msg import (DeliveryStatus, NavigateAction, NavigateGoal, NavigationSample,
                          RobotUtterance, UserUtterance)
from krr_msgs.srv import QueryProbability

from krr_test_utils import Latest

FINAL = (DeliveryStatus.FULFILLED, DeliveryStatus.UNCONFIRMED, DeliveryStatus.FAILED)
# Episodes (trips) of the learning test: back and forth inside ba1 (row 7, cells 219 <-> 224: five
# moves into the area, no way around it) and inside ba4 (column 22, cells 472 <-> 622), TRIPS
# per area. A trip ends early when the fake robot aborts a move; the next starts where it stopped.
ROUTES = {"ba1": (219, 224), "ba4": (472, 622)}
TRIPS = {"ba1": 120, "ba4": 240}
TOLERANCE = 0.05


class TestExecutor(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_executor")
        with open(rospy.get_param("~domain")) as f:
            dom = yaml.safe_load(f)
        cls.area_of = {c: a for a, v in dom["blocking_areas"].items() for c in v["cells"]}
        cls.rates = rospy.get_param("~failure_rates")
        cls.lock = threading.Lock()
        cls.base_link_publishers = set()
        rospy.Subscriber("/tf", TFMessage, cls.on_tf, queue_size=1000)
        rospy.Subscriber("/tf_static", TFMessage, cls.on_tf, queue_size=10)
        cls.samples = Latest("/navigation_samples", NavigationSample)
        cls.statuses = Latest("/delivery_status", DeliveryStatus)
        cls.done = Latest("/simulated_user/done", Bool)
        cls.client = actionlib.SimpleActionClient("navigate", NavigateAction)
        assert cls.client.wait_for_server(rospy.Duration(60)), "navigate action not available"
        rospy.wait_for_service("/reasoner/query_probability", timeout=60)
        cls.query = rospy.ServiceProxy("/reasoner/query_probability", QueryProbability)

    @classmethod
    def on_tf(cls, msg):
        for t in msg.transforms:
            if t.child_frame_id.lstrip("/") in ("base_link", "odom"):
                with cls.lock:
                    cls.base_link_publishers.add(msg._connection_header["callerid"])

    def trip(self, cell, timeout=60, on_feedback=None):
        self.client.send_goal(NavigateGoal(cell=cell), feedback_cb=on_feedback)
        self.assertTrue(self.client.wait_for_result(rospy.Duration(timeout)),
                        "no result for cell %d within %d s" % (cell, timeout))
        return self.client.get_state(), self.client.get_result()

    def walker_rate(self, area):
        res = self.query(query="?{walkers(%s)=true} | obs(curr_time=morning)." % area,
                         knowledge_base="navigation")
        self.assertTrue(res.success, res.message)
        return res.probability

    def test_1_delivery_ends_through_dialog_node(self):
        done = self.done.wait(lambda m: m.data, timeout=70)
        trace = ["%d:%s:%s" % (s.dialog_id, s.status, s.message) for s in self.statuses.messages]
        self.assertIsNotNone(done, "the simulated user's delivery did not end: %s" % trace)
        finals = [s for s in self.statuses.messages if s.status in FINAL]
        self.assertEqual(len(finals), 1, trace)
        # No walkers yet: every trip arrives, so the person gets (after a redelivery if the
        # first was wrong) what they asked for.
        self.assertEqual(finals[0].status, DeliveryStatus.FULFILLED, trace)
        self.assertIn(DeliveryStatus.ARRIVED, [s.status for s in self.statuses.messages], trace)
        self.assertGreater(self.samples.count(), 0, "the trips made no observed move")
        with self.lock:
            publishers = set(self.base_link_publishers)
        self.assertEqual(publishers, {"/fake_move_base"},
                         "the robot's frames (odom, base_link) must come from the robot only: %s"
                         % publishers)
        pubs, _, _ = rosgraph.Master("/test_executor").getSystemState()
        for topic, nodes in pubs:
            if topic in ("/tf", "/tf_static", "/odom"):
                self.assertNotIn("/navigation", nodes, "navigation_node advertises " + topic)

    def test_2_learned_walker_rates_converge_to_the_failure_rates(self):
        rospy.set_param("/fake_move_base/failure_rates", self.rates)  # walkers appear
        start = time.time()
        for area, (a, b) in sorted(ROUTES.items()):
            for _ in range(10):  # get to the route's start (a trip there may be aborted)
                if self.trip(a)[1].outcome == "reached":
                    break
            for k in range(TRIPS[area]):
                state, result = self.trip(b if k % 2 == 0 else a)
                self.assertIn(result.outcome, ("reached", "aborted"),
                              "%s trip %d: %s" % (area, k, result.failure_reason))
                if result.outcome == "aborted":
                    self.assertEqual(state, GoalStatus.ABORTED)
                    self.assertIn("move_base server /move_base_external aborted move",
                                  result.failure_reason)
                    self.assertIn("blocked by walkers in " + area, result.failure_reason)
        moves = {}
        for s in self.samples.messages:
            area = self.area_of.get(s.target_cell)
            if area:
                n, aborted = moves.get(area, (0, 0))
                moves[area] = (n + 1, aborted + (s.outcome == "aborted"))
        time.sleep(3.0)  # learner_node sends what it learned every sample_period (1 s)
        report = []
        for area, (n, aborted) in sorted(moves.items()):
            rate = float(self.rates.get(area, 0.0))
            learned = self.walker_rate(area)
            report.append("%s: %d moves, %d aborted (%.3f), learned %.3f, fake %.2f"
                          % (area, n, aborted, aborted / float(n), learned, rate))
        rospy.loginfo("after %d trips in %.0f s: %s", sum(TRIPS.values()), time.time() - start,
                      "; ".join(report))
        print("learning: " + "; ".join(report))
        for area in ROUTES:
            self.assertGreaterEqual(moves.get(area, (0, 0))[0], 250, report)
        for area, (n, aborted) in moves.items():
            learned = self.walker_rate(area)
            # What the knowledge base holds is what the robot saw (an abort is a trapped move) ...
            self.assertAlmostEqual(learned, aborted / float(n), delta=1e-3, msg=report)
            # ... and, with enough moves, the fake robot's failure rate.
            if n >= 250:
                self.assertLess(abs(learned - float(self.rates.get(area, 0.0))), TOLERANCE, report)

    def far_trip_interrupted(self, interrupt, timeout):
        """Send a trip across the map and call interrupt() after its second move (a trip the fake
        robot aborts before that is sent again)."""
        for _ in range(10):
            here = self.samples.last().next_cell if self.samples.last() else -1
            if here < 0:
                here = self.samples.last().cell
            # the farther of room1's and room5's cells (30 columns a row)
            goal = max((213, 417), key=lambda c: abs(c % 30 - here % 30) + abs(c // 30 - here // 30))
            moved = threading.Event()

            def on_feedback(fb):
                if fb.step >= 2:
                    moved.set()
            self.client.send_goal(NavigateGoal(cell=goal), feedback_cb=on_feedback)
            deadline = time.time() + 30
            while not moved.is_set() and time.time() < deadline and \
                    self.client.get_state() in (GoalStatus.PENDING, GoalStatus.ACTIVE):
                time.sleep(0.005)
            if moved.is_set():
                break
            self.assertTrue(self.client.wait_for_result(rospy.Duration(30)), "the trip hangs")
        self.assertTrue(moved.is_set(), "no trip made two moves")
        interrupt()
        t0 = time.time()
        self.assertTrue(self.client.wait_for_result(rospy.Duration(timeout)),
                        "the trip did not end within %d s" % timeout)
        return self.client.get_state(), self.client.get_result(), time.time() - t0

    def test_3_preemption_ends_the_trip(self):
        state, result, took = self.far_trip_interrupted(self.client.cancel_goal, 10)
        self.assertEqual(state, GoalStatus.PREEMPTED, result.failure_reason)
        self.assertEqual(result.outcome, "preempted")
        self.assertIn("preempted", result.failure_reason)
        self.assertLess(took, 5.0)

    def test_4_a_killed_server_ends_the_trip_with_its_name(self):
        master = rosgraph.Master("/test_executor")
        _, _, pid = ServerProxy(master.lookupNode("/fake_move_base")).getPid("/test_executor")
        state, result, took = self.far_trip_interrupted(lambda: os.kill(pid, signal.SIGKILL), 20)
        self.assertEqual(state, GoalStatus.ABORTED, result.failure_reason)
        self.assertEqual(result.outcome, "error", result.failure_reason)
        self.assertIn("move_base server /move_base_external", result.failure_reason)
        self.assertTrue("vanished" in result.failure_reason or
                        "not available" in result.failure_reason, result.failure_reason)
        # The node is not stuck: the next goal ends too, with the same clear reason.
        state, result = self.trip(213, timeout=20)
        self.assertEqual(result.outcome, "error", result.failure_reason)
        self.assertIn("/move_base_external", result.failure_reason)


    def test_5_a_delivery_without_the_robot_fails_clearly(self):
        """With the server gone, a delivery asked through dialog_node ends failed, naming it."""
        truth = {"item": "coke", "room": "room2", "person": "bob"}
        say = rospy.Publisher("/user_utterance", UserUtterance, queue_size=10)
        first = len(self.statuses.messages)

        def on_robot(msg):
            kind = msg.kind
            if kind.startswith("ask_"):
                say.publish(UserUtterance(dialog_id=msg.dialog_id, text=truth[kind[4:]]))
            elif kind.startswith("confirm_"):
                right = msg.value == truth[kind[len("confirm_"):]]
                say.publish(UserUtterance(dialog_id=msg.dialog_id, text="yes" if right else "no"))
        sub = rospy.Subscriber("/robot_utterance", RobotUtterance, on_robot)
        deadline = time.time() + 10
        while say.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)
        say.publish(UserUtterance(text="a coke for bob to room2"))
        final = self.statuses.wait(lambda m: m.status in FINAL and
                                   self.statuses.messages.index(m) >= first, timeout=40)
        sub.unregister()
        trace = ["%d:%s:%s" % (m.dialog_id, m.status, m.message)
                 for m in self.statuses.messages[first:]]
        self.assertIsNotNone(final, "the dialog hangs: %s" % trace)
        self.assertEqual(final.status, DeliveryStatus.FAILED, trace)
        self.assertIn("/move_base_external", final.message, trace)


if __name__ == "__main__":
    rostest.rosrun("krr_ros", "test_executor", TestExecutor)
