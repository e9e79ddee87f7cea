#!/usr/bin/python3
"""rostest of navigation_node: map, markers, a goal to room1 with feedback, path, pose and tf,
and out-of-range / unknown goals refused with a clear reason by a node that keeps running."""
import math
import time
import unittest

import actionlib
import rospy
import rostest
import tf2_ros
from actionlib_msgs.msg import GoalStatus
from geometry_msgs.msg import PoseStamped
from krr_msgs.msg import NavigateAction, NavigateActionFeedback, NavigateGoal
from nav_msgs.msg import OccupancyGrid, Path
from visualization_msgs.msg import MarkerArray

from krr_test_utils import Latest

ROOM1_CELL = 213   # maps/office_30x30.yaml: places.room1.cell
SHOP_CELL = 453
CELL = 0.5         # m


def cell_centre(cell):
    return ((cell % 30) * CELL + CELL / 2, (cell // 30) * CELL + CELL / 2)


class TestNavigationNode(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_navigation_node')
        cls.plans = Latest('/planned_path', Path)
        cls.executed = Latest('/executed_path', Path)
        cls.poses = Latest('/robot_pose', PoseStamped)
        # Feedback from the topic itself: SimpleActionClient drops feedback that arrives after
        # the result, and at sim_rate 0 a whole goal takes a few milliseconds.
        cls.feedback = Latest('/navigate/feedback', NavigateActionFeedback)
        cls.client = actionlib.SimpleActionClient('navigate', NavigateAction)
        assert cls.client.wait_for_server(rospy.Duration(30)), 'navigate action not available'
        cls.tf = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf)

    def send(self, goal, timeout=40):
        """Send a goal; returns its final state, result and feedback messages."""
        mark = self.feedback.count()
        self.client.send_goal(goal)
        self.assertTrue(self.client.wait_for_result(rospy.Duration(timeout)), 'no result')
        result = self.client.get_result()
        end = time.time() + 3.0  # feedback travels on its own topic: let it catch up
        while time.time() < end and self.feedback.count() - mark < result.steps:
            time.sleep(0.02)
        with self.feedback.lock:
            feedback = [m.feedback for m in self.feedback.messages[mark:]]
        return self.client.get_state(), result, feedback

    def test_1_map_is_published_latched(self):
        m = rospy.wait_for_message('/map', OccupancyGrid, timeout=10)
        self.assertEqual(m.header.frame_id, 'map')
        self.assertEqual((m.info.width, m.info.height), (300, 300))  # 15 m at 0.05 m
        self.assertAlmostEqual(m.info.resolution, 0.05, places=6)
        values = set(m.data)
        self.assertIn(0, values)
        self.assertIn(100, values)

    def test_2_blocking_areas_and_places_as_markers(self):
        m = rospy.wait_for_message('/blocking_areas', MarkerArray, timeout=10)
        areas = [x for x in m.markers if x.ns == 'blocking_areas']
        labels = sorted(x.text for x in m.markers if x.ns == 'blocking_area_labels')
        places = sorted(x.text for x in m.markers if x.ns == 'place_labels')
        self.assertEqual(len(areas), 4)
        self.assertEqual(labels[0], 'ba1 (br 0.30)')
        self.assertEqual(places, ['room1', 'room2', 'room3', 'room4', 'room5', 'shop'])

    def test_3_robot_starts_at_the_shop(self):
        p = self.poses.wait(timeout=10)
        self.assertIsNotNone(p)
        x, y = cell_centre(SHOP_CELL)
        self.assertLess(math.hypot(p.pose.position.x - x, p.pose.position.y - y), 0.3)

    def test_4_goal_room1_completes_with_feedback_and_path(self):
        n_exec = self.executed.count()
        state, result, feedback = self.send(NavigateGoal(place='room1'))
        self.assertEqual(state, GoalStatus.SUCCEEDED, result.failure_reason)
        self.assertTrue(result.success)
        self.assertEqual(result.outcome, 'reached')
        self.assertEqual(result.final_cell, ROOM1_CELL)
        self.assertGreaterEqual(result.steps, 20)  # shortest route: 20 moves
        # One feedback per move (the action's feedback queue holds 50: none is dropped here).
        self.assertEqual([f.step for f in feedback], list(range(1, result.steps + 1)))
        self.assertEqual(feedback[-1].current_cell, ROOM1_CELL)
        self.assertEqual(feedback[0].goal_cell, ROOM1_CELL)
        self.assertIn(feedback[0].last_move, ('up', 'down', 'left', 'right'))
        # The planned route goes from the shop to room1 through cell centres.
        plan = self.plans.wait(lambda p: len(p.poses) > 10)
        self.assertIsNotNone(plan)
        start, end = plan.poses[0].pose.position, plan.poses[-1].pose.position
        self.assertLess(math.hypot(start.x - cell_centre(SHOP_CELL)[0],
                                   start.y - cell_centre(SHOP_CELL)[1]), 1e-6)
        self.assertLess(math.hypot(end.x - cell_centre(ROOM1_CELL)[0],
                                   end.y - cell_centre(ROOM1_CELL)[1]), 1e-6)
        # The executed OMPL path ends where the robot is; pose and tf agree.
        rospy.sleep(0.3)
        self.assertGreater(self.executed.count(), n_exec)
        path = self.executed.last()
        x, y = cell_centre(ROOM1_CELL)
        end = path.poses[-1].pose.position
        self.assertLess(math.hypot(end.x - x, end.y - y), 0.35)
        pose = self.poses.last().pose.position
        self.assertLess(math.hypot(pose.x - end.x, pose.y - end.y), 1e-6)
        t = self.tf.lookup_transform('map', 'base_link', rospy.Time(0), rospy.Duration(5))
        self.assertLess(math.hypot(t.transform.translation.x - end.x,
                                   t.transform.translation.y - end.y), 1e-6)

    def test_5_bad_goals_are_aborted_with_a_reason(self):
        cases = [
            (NavigateGoal(place='kitchen'), "unknown place 'kitchen'"),
            (NavigateGoal(cell=5000), 'goal cell 5000 is out of range [0, 899]'),
            (NavigateGoal(cell=-3), 'goal cell -3 is out of range'),
            (NavigateGoal(cell=0), 'goal cell 0 is not a free cell'),
            (NavigateGoal(place='room2', time='midnight'), "'midnight'"),
        ]
        for goal, needle in cases:
            state, result, feedback = self.send(goal, timeout=10)
            self.assertEqual(state, GoalStatus.ABORTED, needle)
            self.assertFalse(result.success)
            self.assertEqual(result.outcome, 'rejected')
            self.assertIn(needle, result.failure_reason)
            self.assertEqual(feedback, [])
            self.assertIn(needle, self.client.get_goal_status_text())

    def test_6_node_still_serves_goals_after_bad_ones(self):
        here = self.poses.last()
        self.assertIsNotNone(here)
        state, result, _ = self.send(NavigateGoal(place='shop'))
        self.assertEqual(state, GoalStatus.SUCCEEDED, result.failure_reason)
        self.assertEqual(result.final_cell, SHOP_CELL)
        # A goal at the current cell succeeds at once.
        state, result, feedback = self.send(NavigateGoal(cell=SHOP_CELL))
        self.assertEqual(state, GoalStatus.SUCCEEDED)
        self.assertEqual((result.steps, feedback), (0, []))


if __name__ == '__main__':
    rostest.rosrun('krr_ros', 'navigation_node', TestNavigationNode)
