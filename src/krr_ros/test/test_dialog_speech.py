#!/usr/bin/python3
"""rostest of dialog_node's speech topics: recognised text (std_msgs/String on
recognizer/output) drives the dialog like user_utterance, and everything the robot says is
republished on tts/say, in order; garbage from the recogniser is answered, not fatal."""
import threading
import time
import unittest

import rospy
import rostest
from std_msgs.msg import String
from krr_msgs.msg import RobotUtterance

from krr_test_utils import appender, wait_connected

QUESTIONS = (RobotUtterance.ASK_ITEM, RobotUtterance.ASK_ROOM, RobotUtterance.ASK_PERSON,
             RobotUtterance.CONFIRM_ITEM, RobotUtterance.CONFIRM_ROOM,
             RobotUtterance.CONFIRM_PERSON)
REQUEST = {"item": "coke", "room": "room2", "person": "bob"}


class DialogSpeechTest(unittest.TestCase):
    """Runs in name order against one dialog_node."""

    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_dialog_speech")
        cls.lock = threading.Lock()
        cls.utterances, cls.spoken = [], []
        cls.subs = [
            rospy.Subscriber("robot_utterance", RobotUtterance, cls._append(cls.utterances)),
            rospy.Subscriber("tts/say", String, cls._append(cls.spoken)),
        ]
        cls.pub = rospy.Publisher("recognizer/output", String, queue_size=10)
        wait_connected([cls.pub], cls.subs)  # the node solves its POMDP before subscribing

    @classmethod
    def _append(cls, target):
        return appender(cls.lock, target)

    def hear(self, text):
        self.pub.publish(String(data=text))

    def wait_for(self, pred, start, timeout=10.0):
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown():
            with self.lock:
                for m in self.utterances[start:]:
                    if pred(m):
                        return m
            time.sleep(0.05)
        with self.lock:
            self.fail("timed out; got %r" % [m.text for m in self.utterances[start:]])

    def count(self):
        with self.lock:
            return len(self.utterances)

    def test_1_recognised_text_starts_a_dialog(self):
        n = self.count()
        self.hear("I'd like a coke for Bob to office2, please")
        q = self.wait_for(lambda m: m.kind in QUESTIONS + (RobotUtterance.SERVE,), n)
        self.assertEqual(q.dialog_id, 1)

    def test_2_garbage_from_the_recogniser_is_answered(self):
        n = self.count()
        self.hear("xyzzy plugh")
        self.wait_for(lambda m: m.kind == RobotUtterance.NOTICE and "xyzzy" in m.text, n)
        n = self.count()
        self.hear("")
        self.wait_for(lambda m: m.kind == RobotUtterance.NOTICE and "empty" in m.text, n)

    def test_3_answers_by_speech_until_the_robot_serves(self):
        for _ in range(26):
            with self.lock:
                m = [u for u in self.utterances if u.kind in QUESTIONS + (RobotUtterance.SERVE,)][-1]
            if m.kind == RobotUtterance.SERVE:
                break
            factor = m.kind.split("_")[1]
            n = self.count()
            self.hear(REQUEST[factor] if m.kind.startswith("ask") else
                      ("yes" if m.value == REQUEST[factor] else "no"))
            self.wait_for(lambda u: u.kind in QUESTIONS + (RobotUtterance.SERVE,), n)
        else:
            self.fail("the robot never served")
        self.assertEqual((m.request.item, m.request.room, m.request.person),
                         ("coke", "room2", "bob"))

    def test_4_everything_said_is_spoken_in_order(self):
        time.sleep(1.0)  # the last messages arrive on both topics
        with self.lock:
            said = [u.text for u in self.utterances]
            spoken = [s.data for s in self.spoken]
        self.assertGreaterEqual(len(said), 4)
        self.assertEqual(spoken[:len(said)], said)


if __name__ == "__main__":
    rostest.rosrun("krr_ros", "dialog_speech", DialogSpeechTest)
