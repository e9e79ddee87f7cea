#!/usr/bin/python3
"""rostest of learner_node (Procedure 1): what it learns in free time reaches the reasoner and
its file; it pauses while a navigation goal runs and after a service request, then resumes."""
import os
import time
import unittest

import actionlib
import rospy
import rostest
from actionlib_msgs.msg import GoalStatus
from krr_msgs.msg import KnowledgeUpdate, NavigateAction, NavigateGoal, ServiceRequest
from krr_msgs.srv import QueryProbability
from std_msgs.msg import String

from krr_test_utils import Latest, SpawnedNode


class TestLearnerNode(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_learner_node')
        cls.status = Latest('/learner/status', String)
        cls.updates = Latest('/reasoner/knowledge_updates', KnowledgeUpdate)
        rospy.wait_for_service('/reasoner/query_probability', timeout=30)
        cls.query = rospy.ServiceProxy('/reasoner/query_probability', QueryProbability)
        cls.client = actionlib.SimpleActionClient('navigate', NavigateAction)
        assert cls.client.wait_for_server(rospy.Duration(30))
        cls.requests = rospy.Publisher('/service_request', ServiceRequest, queue_size=1)
        cls.learned_file = os.path.join(rospy.get_param('~learned_dir'),
                                        'learned_navigation.plog')

    def wait_status(self, prefix, timeout=20.0, after=0):
        """Wait for a status message starting with prefix, among those from index `after` on."""
        end = time.time() + timeout
        while time.time() < end:
            with self.status.lock:
                for m in self.status.messages[after:]:
                    if m.data.startswith(prefix):
                        return m.data
            time.sleep(0.05)
        self.fail('no status "%s..." within %.0f s; got %s' % (
            prefix, timeout, [m.data for m in self.status.messages[after:]]))

    def wait_learning(self, timeout=20.0):
        """Wait until the learner's current status is 'learning' or 'learned ...'."""
        end = time.time() + timeout
        while time.time() < end:
            last = self.status.last()
            if last is not None and last.data.startswith('learn'):
                return
            time.sleep(0.05)
        self.fail('the learner is not learning: %s' % self.status.last())

    def test_1_free_time_learning_reaches_the_reasoner(self):
        self.wait_learning()
        update = self.updates.wait(lambda u: u.source.endswith('learner') and
                                   u.area_statements, timeout=40)
        self.assertIsNotNone(update, 'the learner sent nothing to the reasoner')
        self.assertEqual(update.area_time, 'morning')
        self.assertIn('learned_area(', update.area_statements)
        self.assertTrue(os.path.exists(self.learned_file))
        self.assertIn('learned_area(', open(self.learned_file).read())

    def test_2_a_navigation_goal_pauses_learning(self):
        self.wait_learning()
        mark = self.status.count()
        self.client.send_goal(NavigateGoal(place='room1'))
        self.wait_status('paused: navigation goal active', timeout=5, after=mark)
        n_updates = self.updates.count()
        # While paused, the reasoner's knowledge does not change: it answers with what the
        # learner sent last (an area's walker rate).
        u = self.updates.last()
        line = next(l for l in u.area_statements.splitlines() if l.startswith('pr(walkers('))
        area = line[len('pr(walkers('):line.index(')')]
        num, den = line.rsplit('= ', 1)[1].rstrip('.').split('/')
        res = self.query(query='?{walkers(%s)=true} | obs(curr_time=%s)' % (area, u.area_time),
                         knowledge_base='navigation')
        self.assertTrue(res.success, res.message)
        self.assertAlmostEqual(res.probability, float(num) / float(den), places=9)
        self.assertTrue(self.client.wait_for_result(rospy.Duration(40)))
        self.assertEqual(self.client.get_state(), GoalStatus.SUCCEEDED)
        self.assertEqual(self.updates.count(), n_updates, 'the learner sent knowledge while '
                         'a navigation goal was active')
        mark = self.status.count()
        self.wait_status('learn', timeout=10, after=mark)  # resumes after idle_delay

    def test_3_a_service_request_pauses_learning(self):
        self.wait_learning()
        mark = self.status.count()
        self.requests.publish(ServiceRequest(item='coke', room='room2', person='bob'))
        self.wait_status('paused: service request received', timeout=5, after=mark)
        mark = self.status.count()
        self.wait_status('learn', timeout=10, after=mark)  # task_hold is 2 s in this test

    def test_4_rests_when_practice_teaches_nothing_new(self):
        params = rospy.get_param('/learner')
        params.update({'extraction': 'pairs', 'rest_threshold': 1000000, 'rest_after': 2,
                       'rest_period': 600,
                       'knowledge_service': '/nowhere/add_knowledge', 'service_timeout': 0.1})
        status = Latest('/learner_rest/status', String)
        node = SpawnedNode('learner_node', 'learner_rest', params).start()
        try:
            rest = status.wait(lambda m: m.data.startswith('resting'), timeout=30)
            self.assertIsNotNone(rest, [m.data for m in status.messages])
            # rest_after (2) tasks, then rest (the first status may predate the subscription).
            learned = [m.data for m in status.messages if m.data.startswith('learned')]
            self.assertIn(len(learned), (1, 2), learned)
            rospy.sleep(1.0)
            self.assertIs(status.last(), rest)  # no more practice while resting
        finally:
            node.kill()
            node.clear_params()


if __name__ == '__main__':
    rostest.rosrun('krr_ros', 'learner_node', TestLearnerNode)
