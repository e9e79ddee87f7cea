#!/usr/bin/env bash
# Build the catkin workspace (Release) with Debian's python, which is the one that has rospy.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="/usr/bin:/bin:$PATH"
cd "$ROOT/catkin_ws"
[ -L src ] || ln -sfn ../src src
JOBS="${KRR_JOBS:-$(nproc)}"
catkin_make -j"$JOBS" -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCMAKE_BUILD_TYPE=Release \
  -DCATKIN_ENABLE_TESTING=ON "$@" > "$ROOT/catkin_ws/build_log.txt" 2>&1 || {
  tail -60 "$ROOT/catkin_ws/build_log.txt"; echo "[build] FAILED (full log: catkin_ws/build_log.txt)"; exit 1; }
if [ "${KRR_BUILD_TESTS:-0}" = 1 ]; then
  catkin_make -j"$JOBS" tests >> "$ROOT/catkin_ws/build_log.txt" 2>&1 || {
    tail -60 "$ROOT/catkin_ws/build_log.txt"; echo "[build] tests FAILED"; exit 1; }
fi
echo "[build] ok"
