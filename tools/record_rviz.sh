#!/usr/bin/env bash
# Regenerate docs/img/rviz_delivery.png: RViz (config/krr_rl.rviz) on the simulation with a
# delivery in progress. Starts Xvfb (1280x900x24) and `sim.launch rviz:=true` on its own master
# with the simulated user (hidden request <coke, room2, bob>, seed 1), no free-time learner,
# human knowledge only (a fresh learned_dir) and 2 simulated moves per second. So that the
# picture shows the colour scale, the simulated walkers get the paper's four blocking rates, one
# per area (ba1 0.7, ba2 0.5, ba3 0.1, ba4 0.3: a copy of the navigation config with per-area
# rates, passed through kb_config; by default every area has 0.3). Waits until the robot has
# picked the item up and is on its way to the room (delivery_status to_room) with a planned
# path, lets it drive about half of the route, then grabs the screen with PIL.
#   bash tools/record_rviz.sh [OUT.png]        (after bash tools/build.sh; needs rviz, xvfb)
case "${1:-}" in -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;; esac
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${1:-$ROOT/docs/img/rviz_delivery.png}"
export PATH="/usr/bin:/bin:$PATH"
set +u; source "$ROOT/catkin_ws/devel/setup.bash"; set -u
WORK=$(mktemp -d /tmp/krr_rviz_XXXXXX)
export ROS_HOME="$WORK/ros_home"
PORT=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
export ROS_MASTER_URI="http://127.0.0.1:$PORT"
D=99; while [ -e "/tmp/.X11-unix/X$D" ] || [ -e "/tmp/.X$D-lock" ]; do D=$((D + 1)); done
export DISPLAY=":$D"
Xvfb "$DISPLAY" -screen 0 1280x900x24 -nolisten tcp > "$WORK/xvfb.log" 2>&1 &
XVFB=$!
LAUNCH=
cleanup() {
  [ -n "$LAUNCH" ] && { kill -INT "$LAUNCH" 2>/dev/null || true; wait "$LAUNCH" 2>/dev/null || true; }
  kill "$XVFB" 2>/dev/null || true; wait "$XVFB" 2>/dev/null || true
}
trap cleanup EXIT

# the navigation config with per-area blocking rates, and a kb_config that points to it
/usr/bin/python3 - "$ROOT" "$WORK" <<'PY'
import os, sys, yaml
root, work = sys.argv[1:]
with open(os.path.join(root, "config", "navigation_kb.yaml")) as f:
    kb = yaml.safe_load(f)
nav_path = os.path.join(root, kb["navigation_config"])
with open(nav_path) as f:
    nav = yaml.safe_load(f)
for key in ("map", "places"):  # relative to the file's directory
    nav[key] = os.path.normpath(os.path.join(os.path.dirname(nav_path), nav[key]))
areas = nav.setdefault("simulator", {}).get("areas") or {}
for area, rate in (("ba1", 0.7), ("ba2", 0.5), ("ba3", 0.1), ("ba4", 0.3)):
    areas.setdefault(area, {})["rate"] = rate
nav["simulator"]["areas"] = areas
with open(os.path.join(work, "navigation.yaml"), "w") as f:
    yaml.safe_dump(nav, f)
kb["navigation_config"] = os.path.join(work, "navigation.yaml")
with open(os.path.join(work, "navigation_kb.yaml"), "w") as f:
    yaml.safe_dump(kb, f)
PY

sleep 1
roslaunch -p "$PORT" "$ROOT/launch/sim.launch" rviz:=true user:=true learner:=false seed:=1 \
  request:=coke,room2,bob sim_rate:=2 learned_dir:="$WORK/kb" \
  kb_config:="$WORK/navigation_kb.yaml" > "$WORK/roslaunch.log" 2>&1 &
LAUNCH=$!
mkdir -p "$(dirname "$OUT")"
/usr/bin/python3 - "$OUT" <<'PY' || { echo "record_rviz: failed (see $WORK/roslaunch.log)" >&2; exit 1; }
import os, sys, time
import rospy
from krr_msgs.msg import DeliveryStatus
from nav_msgs.msg import Path
from PIL import ImageGrab

state = {"status": None, "plan": 0, "executed": 0}
rospy.init_node("record_rviz", anonymous=True)
rospy.Subscriber("delivery_status", DeliveryStatus, lambda m: state.update(status=m.status))
rospy.Subscriber("planned_path", Path, lambda m: state.update(plan=len(m.poses)))
rospy.Subscriber("executed_path", Path, lambda m: state.update(executed=len(m.poses)))
end = time.time() + 240
first = 0  # the planned route's length when the leg to the room starts (its longest)
# on the way to the room, about halfway: the planned route ahead is half as long as at first
while True:
    if time.time() > end or rospy.is_shutdown():
        sys.exit("no delivery in progress after 240 s: %s" % state)
    if state["status"] == "to_room":
        first = max(first, state["plan"])
        if first >= 6 and 0 < state["plan"] <= first // 2:
            break
    time.sleep(0.05)
time.sleep(1.0)  # let RViz draw the latest messages
ImageGrab.grab(xdisplay=os.environ["DISPLAY"]).save(sys.argv[1])
print("record_rviz: %s (status %s, planned %d poses, executed %d)"
      % (sys.argv[1], state["status"], state["plan"], state["executed"]))
PY
