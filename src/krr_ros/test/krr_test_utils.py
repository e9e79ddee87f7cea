"""Helpers shared by the krr_ros rostest nodes (imported from the test directory)."""
import os
import signal
import subprocess
import threading
import time

import roslib.packages
import rospy
import yaml
from krr_msgs.msg import DeliveryStatus, RobotUtterance


def node_binary(name):
    """Path of a krr_ros executable (devel or install space)."""
    found = roslib.packages.find_node('krr_ros', name)
    if not found:
        raise RuntimeError('krr_ros/%s not found: build it first' % name)
    return found[0]


class SpawnedNode:
    """A krr_ros node started by the test itself, with its parameters set on the master, so a
    test can kill it (SIGKILL: no clean shutdown) and start it again."""

    def __init__(self, binary, name, params):
        self.binary = node_binary(binary)
        self.name = name
        self.params = params
        self.proc = None
        self.output = ''

    def start(self):
        rospy.set_param('/' + self.name, self.params)
        self.proc = subprocess.Popen([self.binary, '__name:=' + self.name],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     env=dict(os.environ, ROSCONSOLE_STDOUT_LINE_BUFFERED='1'))
        return self

    def wait_exit(self, timeout):
        """Wait for the process to exit; returns its exit code (None on timeout)."""
        try:
            out, _ = self.proc.communicate(timeout=timeout)
            self.output = out.decode(errors='replace')
            return self.proc.returncode
        except subprocess.TimeoutExpired:
            return None

    def kill(self):
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
            self.proc.wait(10)

    def clear_params(self):
        if rospy.has_param('/' + self.name):
            rospy.delete_param('/' + self.name)


class Latest:
    """Subscribes to a topic and keeps every message (thread-safe)."""

    def __init__(self, topic, msg_type):
        self.lock = threading.Lock()
        self.messages = []
        self.sub = rospy.Subscriber(topic, msg_type, self._cb, queue_size=100)

    def _cb(self, msg):
        with self.lock:
            self.messages.append(msg)

    def last(self):
        with self.lock:
            return self.messages[-1] if self.messages else None

    def count(self):
        with self.lock:
            return len(self.messages)

    def wait(self, predicate=lambda m: True, timeout=10.0):
        """The first message (old or new) satisfying predicate, or None after timeout."""
        end = time.time() + timeout
        while time.time() < end and not rospy.is_shutdown():
            with self.lock:
                for m in self.messages:
                    if predicate(m):
                        return m
            time.sleep(0.05)
        return None


def wait_connected(publishers, subscribers, timeout=60.0):
    """Wait until every publisher has a subscriber and every subscriber a publisher (a node
    that solves its model before advertising takes a while), then let the connections settle."""
    deadline = time.time() + timeout
    while time.time() < deadline and not rospy.is_shutdown():
        if all(p.get_num_connections() > 0 for p in publishers) and \
                all(s.get_num_connections() > 0 for s in subscribers):
            break
        time.sleep(0.1)
    time.sleep(0.5)


def appender(lock, target):
    """A subscriber callback that appends each message to target under lock."""
    def cb(msg):
        with lock:
            target.append(msg)
    return cb


# The office dialog the dialog_node rostests hold: the robot's replies and a delivery's end.
DIALOG_QUESTIONS = (RobotUtterance.ASK_ITEM, RobotUtterance.ASK_ROOM, RobotUtterance.ASK_PERSON,
                    RobotUtterance.CONFIRM_ITEM, RobotUtterance.CONFIRM_ROOM,
                    RobotUtterance.CONFIRM_PERSON)
DIALOG_REPLIES = DIALOG_QUESTIONS + (RobotUtterance.SERVE,)
DELIVERY_FINAL = (DeliveryStatus.FULFILLED, DeliveryStatus.UNCONFIRMED, DeliveryStatus.FAILED)
DIALOG_REQUEST = {"item": "coke", "room": "room2", "person": "bob"}
DIALOG_SENTENCE = "a coke for bob to room2"


def dialog_node_params(root, **overrides):
    """dialog_node's parameters as shipped (config/navigation_kb.yaml, config/dialog_node.yaml)
    on the office's reach model, without a navigation server to wait for, then `overrides`."""
    params = {}
    for f in ("navigation_kb.yaml", "dialog_node.yaml"):
        with open(os.path.join(root, "config", f)) as fh:
            params.update(yaml.safe_load(fh))
    params.update({
        "base_dir": root, "model_source": "reach",
        "reach_probabilities": [0.95, 0.65, 0.75, 0.95, 0.5],
        "server_wait": 1.0, "check_timeout": 3.0})
    params.update(overrides)
    return params


class RecordingMixin:
    """For a unittest.TestCase class that starts a node itself (start_node_process: a
    subprocess, SIGKILLed at the end, checked alive before every test) and records what it
    publishes. The class sets node_name (its /rosout lines go to cls.logs), lock and logs;
    topic callbacks come from _append(list)."""

    @classmethod
    def _append(cls, target):
        def cb(msg):
            with cls.lock:
                target.append((time.time(), msg))
        return cb

    @classmethod
    def _log(cls, msg):
        if msg.name == "/" + cls.node_name:
            with cls.lock:
                cls.logs.append((time.time(), msg))

    @classmethod
    def start_node_process(cls, binary, log_file, connected, timeout):
        """Start `binary` as cls.node_name with its output in log_file (cls.proc, cls.out), and
        wait until connected() or the node exits or `timeout` s pass; then 0.5 s more."""
        if getattr(cls, "out", None):
            cls.out.close()
        cls.log_file = log_file
        cls.out = open(log_file, "w")
        cls.proc = subprocess.Popen([node_binary(binary), "__name:=" + cls.node_name],
                                    stdout=cls.out, stderr=subprocess.STDOUT,
                                    env=dict(os.environ, ROSCONSOLE_STDOUT_LINE_BUFFERED="1"))
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown() and cls.proc.poll() is None:
            if connected():
                break
            time.sleep(0.1)
        ready = time.time()
        time.sleep(0.5)
        return ready

    @classmethod
    def tearDownClass(cls):
        if getattr(cls, "proc", None) and cls.proc.poll() is None:
            cls.proc.send_signal(signal.SIGKILL)
            cls.proc.wait(10)
        if getattr(cls, "out", None):
            cls.out.close()
        rospy.delete_param("/" + cls.node_name)

    def setUp(self):
        self.assertIsNone(self.proc.poll(), "%s exited:\n%s" % (self.node_name,
                                                                  self.node_output()))

    def node_output(self):
        with open(self.log_file) as f:
            return "".join(f.readlines()[-60:])

    def wait_for(self, items, pred, start=0, timeout=10.0, what="message"):
        """The first (receipt time, message) of items[start:] with pred(message), or fail."""
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown():
            with self.lock:
                for t, m in items[start:]:
                    if pred(m):
                        return t, m
            time.sleep(0.01)
        with self.lock:
            got = [getattr(m, "text", getattr(m, "msg", getattr(m, "status", m)))
                   for _, m in items[start:]]
        self.fail("timed out after %.0f s waiting for %s; got %r\nnode output:\n%s" %
                  (timeout, what, got, self.node_output()))

    def logged(self, text, start=0):
        """The node's log messages since start that contain text."""
        with self.lock:
            return [m for _, m in self.logs[start:] if text in m.msg]
