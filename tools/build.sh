#!/usr/bin/env bash
# Build the catkin workspace (Release) with Debian's python, which is the one that has rospy.
# The compiler output goes to catkin_ws/build_log.txt; a progress line (elapsed time, cmake's
# percentage and the target being built) is printed every KRR_PROGRESS_SECONDS (default 20)
# so that a first build of several minutes is never silent. On failure: the log's tail and
# its path.
case "${1:-}" in -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;; esac
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="/usr/bin:/bin:$PATH"
cd "$ROOT/catkin_ws"
[ -L src ] || ln -sfn ../src src
JOBS="${KRR_JOBS:-$(nproc)}"
LOG="$ROOT/catkin_ws/build_log.txt"
EVERY="${KRR_PROGRESS_SECONDS:-20}"
START=$SECONDS

# Run "$@" with its output appended to the log, printing a progress line every $EVERY s.
logged() {
  local what="$1"; shift
  "$@" >> "$LOG" 2>&1 &
  local pid=$! next=$((SECONDS + EVERY))
  while kill -0 "$pid" 2>/dev/null; do
    sleep 1
    if [ "$SECONDS" -ge "$next" ]; then
      next=$((SECONDS + EVERY))
      local pct target
      pct="$(tail -n 400 "$LOG" | grep -o '^\[ *[0-9]*%\]' | tail -n 1 | tr -d '[] ' || true)"
      target="$(tail -n 400 "$LOG" | grep -oE '(Building|Linking) [A-Z+]+ [a-z ]*[^ ]+$' | tail -n 1 || true)"
      echo "[build] $what $((SECONDS - START)) s ${pct:-configuring} ${target##*/}"
    fi
  done
  wait "$pid"
}

fail() {
  tail -60 "$LOG"
  echo "[build] $1 FAILED after $((SECONDS - START)) s (full log: $LOG)"
  exit 1
}

: > "$LOG"
echo "[build] catkin_make -j$JOBS (log: $LOG)"
logged workspace catkin_make -j"$JOBS" -DPYTHON_EXECUTABLE=/usr/bin/python3 \
  -DCMAKE_BUILD_TYPE=Release -DCATKIN_ENABLE_TESTING=ON "$@" || fail build
if [ "${KRR_BUILD_TESTS:-0}" = 1 ]; then
  logged tests catkin_make -j"$JOBS" tests || fail tests
fi
echo "[build] ok in $((SECONDS - START)) s"
