#!/usr/bin/python3
"""rostest node of bag_replay.test: the delivery table of a recorded sim run, live and from the
bag, must be equal (and describe the deliveries the simulated user made)."""
import json
import os
import subprocess
import sys
import threading
import time
import unittest

import rosnode
import rospy
import rostest
from std_msgs.msg import Bool
from krr_msgs.msg import (DeliveryStatus, NavigateActionGoal, NavigateActionResult,
                          RobotUtterance, ServiceRequest)

from krr_eval import bag

TYPES = {bag.STATUS: DeliveryStatus, bag.UTTERANCE: RobotUtterance, bag.HIDDEN: ServiceRequest,
         bag.NAV_GOAL: NavigateActionGoal, bag.NAV_RESULT: NavigateActionResult}
SCRIPT = os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", "scripts", "bag_table")


class BagReplay(unittest.TestCase):
    def setUp(self):
        rospy.init_node("test_bag_replay")
        self.path = rospy.get_param("~bag")
        self.deliveries = rospy.get_param("~deliveries", 2)
        if os.path.exists(self.path):  # a previous run's (the recorder writes BAG.active)
            os.remove(self.path)
        self.lock = threading.Lock()
        self.live = bag.DeliveryTable(bag.RewardConfig.load())
        self.done = False
        for topic, kind in TYPES.items():
            rospy.Subscriber(topic, kind, self.keep(topic), queue_size=200)
        rospy.Subscriber("/simulated_user/done", Bool, self.on_done)

    def keep(self, topic):
        def cb(msg):
            with self.lock:
                self.live.add(topic, msg, rospy.get_time())
        return cb

    def on_done(self, msg):
        self.done = msg.data

    def wait(self, what, cond, timeout):
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown():
            if cond():
                return
            time.sleep(0.1)
        self.fail("timed out waiting for " + what)

    def test_table_from_bag_equals_live_table(self):
        self.wait("the simulated user's %d deliveries" % self.deliveries, lambda: self.done, 75)
        time.sleep(1.0)  # the last messages reach the recorder and us
        with self.lock:
            live = self.live.rows()
        # Stop the recorder: it closes the bag (BAG.active -> BAG) when its node shuts down.
        rosnode.kill_nodes(["/record"])
        self.wait("the closed bag " + self.path, lambda: os.path.exists(self.path), 20)
        replay = bag.read_bag(self.path, bag.RewardConfig.load()).rows()
        rospy.loginfo("live:\n%s\nfrom the bag:\n%s", bag.markdown(live), bag.markdown(replay))
        self.assertEqual(len(live), self.deliveries, bag.markdown(live))
        for r in live:
            for k in ("request", "served", "identified", "reward"):
                self.assertIsNotNone(r[k], "%s unknown: %s" % (k, r))
            # shop, room (and back on a redelivery); a failed trip ends the delivery early
            self.assertGreaterEqual(r["trips"], 1 if r["nav_failed"] else 2, r)
            if r["nav_failed"]:
                self.assertFalse(r["delivered"], r)
            self.assertEqual(r["delivered"], r["outcome"] == "fulfilled", r)
        same, why = bag.same_rows(live, replay)
        self.assertTrue(same, "bag table differs from the live one: %s\nlive:\n%s\nbag:\n%s"
                        % (why, bag.markdown(live), bag.markdown(replay)))
        # The command-line program prints the same rows.
        res = subprocess.run(["/usr/bin/python3", SCRIPT, self.path, "--json"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             universal_newlines=True, timeout=60)
        self.assertEqual(res.returncode, 0, res.stderr)
        same, why = bag.same_rows(live, json.loads(res.stdout)["rows"])
        self.assertTrue(same, "bag_table --json differs: " + why)


if __name__ == "__main__":
    rostest.rosrun("krr_eval", "bag_replay", BagReplay, sys.argv)
