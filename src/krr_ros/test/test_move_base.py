#!/usr/bin/python3
"""rostest of navigation_node's move_base face and REP 105 frames (see move_base.test)."""
import math
import os
import re
import subprocess
import time
import unittest

import actionlib
import rospy
import rostest
import tf2_ros
import yaml
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped, TransformStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseActionFeedback, MoveBaseGoal
from nav_msgs.msg import Odometry

from krr_test_utils import Latest


def pose(x, y, frame="map"):
    p = PoseStamped()
    p.header.frame_id = frame
    p.header.stamp = rospy.Time.now()
    p.pose.position.x, p.pose.position.y = x, y
    p.pose.orientation.w = 1.0
    return p


class TestMoveBase(unittest.TestCase):
    """Runs in name order: the robot's position carries over between steps."""

    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_move_base")
        with open(rospy.get_param("~domain")) as f:
            dom = yaml.safe_load(f)
        cls.places = dom["places"]
        cls.cols = dom["cols"]
        cls.cell = dom["cell_width"]
        cls.free = set(dom["free_cells"])
        cls.feedback = Latest("/move_base/feedback", MoveBaseActionFeedback)
        cls.odom = Latest("/odom", Odometry)
        cls.client = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        assert cls.client.wait_for_server(rospy.Duration(60)), "move_base action not available"
        cls.tf = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf)
        cls.simple = rospy.Publisher("/move_base_simple/goal", PoseStamped, queue_size=1)
        # a frame "shifted": map moved 1 m along x, and turned by 90 degrees (a goal given in
        # another frame must go through tf, rotation included)
        cls.static = tf2_ros.StaticTransformBroadcaster()
        t = TransformStamped()
        t.header.stamp = rospy.Time.now()
        t.header.frame_id, t.child_frame_id = "map", "shifted"
        t.transform.translation.x = 1.0
        t.transform.rotation.z = t.transform.rotation.w = math.sqrt(0.5)
        cls.static.sendTransform(t)

    def cell_of(self, x, y):
        return int(y // self.cell) * self.cols + int(x // self.cell)

    def robot(self):
        t = self.tf.lookup_transform("map", "base_link", rospy.Time(0), rospy.Duration(5))
        return t.transform.translation.x, t.transform.translation.y

    def go(self, target, timeout=60):
        mark = self.feedback.count()
        self.client.send_goal(MoveBaseGoal(target_pose=target))
        self.assertTrue(self.client.wait_for_result(rospy.Duration(timeout)), "no result")
        return self.client.get_state(), self.client.get_goal_status_text(), self.feedback.count() - mark

    def test_1_three_places_reached_with_feedback(self):
        for name in ("room1", "room5", "shop"):
            x, y = self.places[name]["point"]
            state, text, fb = self.go(pose(x, y))
            self.assertEqual(state, GoalStatus.SUCCEEDED, "%s: %s" % (name, text))
            self.assertIn("reached cell %d" % self.places[name]["cell"], text)
            self.assertGreater(fb, 0, "no feedback on the way to " + name)
            time.sleep(0.3)  # the pose timer republishes tf
            rx, ry = self.robot()
            self.assertEqual(self.cell_of(rx, ry), self.places[name]["cell"], name)

    def test_2_bad_poses_are_aborted_with_their_reason(self):
        cases = [
            (pose(20.0, 20.0), "off the map"),
            (pose(0.25, 0.25), "in an obstacle"),
            (pose(1.6, 7.6, frame="nowhere"), "frame 'nowhere'"),
            (pose(1.6, 7.6, frame=""), "no frame_id"),
            (pose(float("nan"), 1.0), "non-finite"),
        ]
        self.assertNotIn(0, self.free)
        for target, words in cases:
            state, text, _ = self.go(target, timeout=20)
            self.assertEqual(state, GoalStatus.ABORTED, text)
            self.assertIn(words, text)

    def test_3_a_goal_in_another_frame_goes_through_tf(self):
        x, y = self.places["room1"]["point"]
        # shifted: p_map = (1, 0) + R(90 deg) p_shifted, so p_shifted = (y, 1 - x)
        state, text, _ = self.go(pose(y, 1.0 - x, frame="shifted"))
        self.assertEqual(state, GoalStatus.SUCCEEDED, text)
        self.assertIn("reached cell %d" % self.places["room1"]["cell"], text)

    def test_4_simple_goal_moves_the_robot(self):
        x, y = self.places["room2"]["point"]
        deadline = time.time() + 10
        while self.simple.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.05)
        self.simple.publish(pose(x, y))
        deadline = time.time() + 60
        while time.time() < deadline:
            rx, ry = self.robot()
            if self.cell_of(rx, ry) == self.places["room2"]["cell"]:
                break
            time.sleep(0.1)
        self.assertEqual(self.cell_of(*self.robot()), self.places["room2"]["cell"])

    def test_5_newer_goal_and_cancel_preempt(self):
        far = self.places["room4"]["point"]
        self.client.send_goal(MoveBaseGoal(target_pose=pose(*far)))
        time.sleep(0.5)  # on its way (20 moves per second)
        x, y = self.places["room1"]["point"]
        other = actionlib.SimpleActionClient("move_base", MoveBaseAction)
        self.assertTrue(other.wait_for_server(rospy.Duration(10)))
        other.send_goal(MoveBaseGoal(target_pose=pose(x, y)))
        self.assertTrue(self.client.wait_for_result(rospy.Duration(30)))
        self.assertEqual(self.client.get_state(), GoalStatus.PREEMPTED)
        self.assertTrue(other.wait_for_result(rospy.Duration(60)))
        self.assertEqual(other.get_state(), GoalStatus.SUCCEEDED, other.get_goal_status_text())
        self.client.send_goal(MoveBaseGoal(target_pose=pose(*far)))
        time.sleep(0.5)
        self.client.cancel_goal()
        self.assertTrue(self.client.wait_for_result(rospy.Duration(30)))
        self.assertEqual(self.client.get_state(), GoalStatus.PREEMPTED)

    def test_6_frames_follow_rep_105(self):
        t = self.tf.lookup_transform("map", "odom", rospy.Time(0), rospy.Duration(5))
        self.assertAlmostEqual(t.transform.translation.x, 0.0)
        self.assertAlmostEqual(t.transform.rotation.w, 1.0)
        time.sleep(0.3)
        b = self.tf.lookup_transform("odom", "base_link", rospy.Time(0), rospy.Duration(5))
        rx, ry = self.robot()
        self.assertAlmostEqual(b.transform.translation.x, rx, places=6)
        self.assertAlmostEqual(b.transform.translation.y, ry, places=6)
        self.assertIsNotNone(self.odom.wait(timeout=5), "nothing on odom")
        o = self.odom.last()
        self.assertEqual((o.header.frame_id, o.child_frame_id), ("odom", "base_link"))
        self.assertLess(math.hypot(o.pose.pose.position.x - rx, o.pose.pose.position.y - ry), 1e-6)

    def test_7_the_community_tf_echo_sees_the_robot_through_odom(self):
        echo = "/usr/lib/tf/tf_echo"  # Debian's tf-tools (tf2_echo is not packaged)
        self.assertTrue(os.path.exists(echo), "tf-tools is not installed")
        try:
            out = subprocess.run([echo, "map", "base_link"], capture_output=True, text=True,
                                 timeout=4).stdout
        except subprocess.TimeoutExpired as e:  # tf_echo prints until stopped
            out = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        m = re.search(r"Translation: \[([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\]", out)
        self.assertIsNotNone(m, out)
        rx, ry = self.robot()
        self.assertAlmostEqual(float(m.group(1)), rx, places=2)
        self.assertAlmostEqual(float(m.group(2)), ry, places=2)


if __name__ == "__main__":
    rostest.rosrun("krr_ros", "move_base", TestMoveBase)
