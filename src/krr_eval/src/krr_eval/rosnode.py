"""Optional ROS node mode of the tools' scripts (rospy), never requiring a master.

Run by `rosrun`/`roslaunch`, a script receives ROS arguments (`__name:=x`, `__log:=...`,
remappings `a:=b`, private parameters `_trials_scale:=0.1`). `split_ros_args` separates them
from the script's own options and turns private parameters into options (`--trials-scale
0.1`), so `rosrun krr_eval evaluate _out:=/tmp/eval _quick:=true` works like
`rosrun krr_eval evaluate --out /tmp/eval --quick`.

`start()` initialises a rospy node only when asked (`--ros`) or when run through ROS
(`__name:=` given, or ROS_MASTER_URI set and its master answering); if no master answers it
says so and the script runs headless. The node logs to /rosout and publishes progress on
~progress (std_msgs/String) and the report path on ~report (latched std_msgs/String).
"""
import os
import socket
import sys
from urllib.parse import urlparse


def split_ros_args(argv):
    """(own arguments, ROS arguments, {private param: value}) of a command line."""
    own, ros, private = [], [], {}
    for a in argv:
        if ":=" in a and not a.startswith("-"):
            ros.append(a)
            k, v = a.split(":=", 1)
            if k.startswith("_") and not k.startswith("__"):
                private[k[1:]] = v
        else:
            own.append(a)
    return own, ros, private


def params_to_args(private, flags=()):
    """Private parameters as command-line options: _trials_scale:=0.1 -> --trials-scale 0.1;
    for a flag option (in `flags`, e.g. "quick") true/1/yes -> --quick, false -> nothing."""
    out = []
    for k in sorted(private):
        opt, v = k.replace("_", "-"), private[k]
        if opt in flags:
            if v.strip().lower() in ("true", "1", "yes", "on"):
                out.append("--" + opt)
            elif v.strip().lower() not in ("false", "0", "no", "off"):
                raise ValueError("ROS parameter _%s:=%s: expected true or false" % (k, v))
        else:
            out += ["--" + opt, v]
    return out


def master_reachable(uri=None, timeout=0.5):
    """True if something accepts TCP connections at the ROS master URI (default
    $ROS_MASTER_URI); False if unset, malformed or not answering."""
    uri = uri or os.environ.get("ROS_MASTER_URI")
    if not uri:
        return False
    try:
        u = urlparse(uri)
        host, port = u.hostname, u.port or 11311
    except ValueError:
        return False
    if not host:
        return False
    try:
        with socket.create_connection((host, port), timeout=timeout):
            return True
    except OSError:
        return False


class RosNode(object):
    """A rospy node reporting a tool's progress."""

    def __init__(self, name, ros_args):
        import rospy
        from std_msgs.msg import String
        self.rospy = rospy
        rospy.init_node(name, argv=[sys.argv[0]] + list(ros_args), anonymous=True,
                        disable_signals=True)
        self._progress = rospy.Publisher("~progress", String, queue_size=10)
        self._report = rospy.Publisher("~report", String, queue_size=1, latch=True)
        self._String = String

    def info(self, msg):
        self.rospy.loginfo(msg)

    def progress(self, msg):
        self.rospy.loginfo(msg)
        self._progress.publish(self._String(data=msg))

    def report(self, path):
        self._report.publish(self._String(data=path))

    def shutdown(self):
        self.rospy.signal_shutdown("done")


def start(name, mode, ros_args, log=None):
    """A RosNode or None. mode: 'on' (--ros), 'off' (--no-ros) or 'auto' (node if launched by
    ROS with __name:= or if $ROS_MASTER_URI answers)."""
    log = log or (lambda m: sys.stderr.write(m + "\n"))
    if mode == "off":
        return None
    launched = any(a.startswith("__name:=") for a in ros_args)
    if mode == "auto" and not launched and not os.environ.get("ROS_MASTER_URI"):
        return None
    if not master_reachable():
        if mode == "on" or launched:
            log("%s: no ROS master answers at %s; running headless"
                % (name, os.environ.get("ROS_MASTER_URI", "(ROS_MASTER_URI unset)")))
        return None
    try:
        return RosNode(name, ros_args)
    except Exception as e:  # rospy missing or failing must not stop an evaluation
        log("%s: cannot start a ROS node (%s); running headless" % (name, e))
        return None
