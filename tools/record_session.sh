#!/usr/bin/env bash
# Record the example ROS session of src/krr_ros/README.md: start the headless stack (sim.launch, no simulated
# user, no free-time learner, human knowledge only, a fresh learned_dir, seed 1) on its own
# master, run the commands below (reasoner queries, a dialog typed through /user_utterance,
# navigation goals, knowledge updates), and write their real output to
# docs/example_session.txt; `rosrun krr_eval record_results` then puts it into src/krr_ros/README.md (so the
# README never shows output that was typed by hand).
#   bash tools/record_session.sh        (after bash tools/build.sh)
case "${1:-}" in -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;; esac
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="/usr/bin:/bin:$PATH"
set +u; source "$ROOT/catkin_ws/devel/setup.bash"; set -u
WORK=$(mktemp -d /tmp/krr_session_XXXXXX)
export ROS_HOME="$WORK/ros_home"
PORT=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
export ROS_MASTER_URI="http://127.0.0.1:$PORT"
# dialog_startup_trials:=0: the certified dialog policy from the first dialog (solved before
# the node serves, or loaded from the cache), so the recorded dialogs do not depend on when a
# background solve ends.
roslaunch -p "$PORT" "$ROOT/launch/sim.launch" user:=false learner:=false seed:=1 sim_rate:=0 \
  dialog_startup_trials:=0 learned_dir:="$WORK/kb" > "$WORK/roslaunch.log" 2>&1 &
LAUNCH=$!
cleanup() { kill -INT "$LAUNCH" 2>/dev/null || true; wait "$LAUNCH" 2>/dev/null || true; }
trap cleanup EXIT
for s in /reasoner/query_probability /reasoner/add_knowledge /dialog/get_loggers; do
  timeout 120 bash -c "until rosservice list 2>/dev/null | grep -qx $s; do sleep 0.5; done" \
    || { echo "record_session: $s did not come up (see $WORK/roslaunch.log)" >&2; exit 1; }
done
# The node's services are up before its policy is: wait for the policy (latched on ~policy).
timeout 300 rostopic echo -n 1 /dialog/policy > /dev/null 2>&1 \
  || { echo "record_session: dialog_node published no policy (see $WORK/roslaunch.log)" >&2; exit 1; }
OUT="$WORK/session.txt"
run() {  # run "command" [filter]: print "$ command", then its output
  echo "\$ $1" >> "$OUT"
  if [ -n "${2:-}" ]; then bash -c "$1" 2>&1 | grep -E "$2" >> "$OUT" || true
  else bash -c "$1" >> "$OUT" 2>&1 || true; fi
}
goal() {  # goal "{goal: ...}" filter: send a navigation goal, print its (unlatched) result
  echo "\$ rostopic pub -1 /navigate/goal krr_msgs/NavigateActionGoal \"$1\"" >> "$OUT"
  echo "\$ rostopic echo -n 1 /navigate/result/result     # (listening since before the goal)" >> "$OUT"
  rostopic echo -n 1 /navigate/result/result > "$WORK/result.txt" 2>&1 &
  local echo_pid=$!
  sleep 2
  rostopic pub -1 /navigate/goal krr_msgs/NavigateActionGoal "$1" > /dev/null 2>&1 || true
  timeout 120 tail --pid=$echo_pid -f /dev/null || kill $echo_pid 2>/dev/null || true
  grep -E "$2" "$WORK/result.txt" >> "$OUT" || true
}
run "rosservice call /reasoner/query_probability \"{query: '?{curr_room(bob)=room2} | do(curr_person=bob).'}\""
run "rosservice call /reasoner/query_probability \"{query: '?{curr_room(carol)=room2}'}\""
run "rosservice call /reasoner/query_probability \"{attribute: 'curr_room(bob)', evidence: 'do(curr_person=bob)'}\""
run "rostopic echo -n 1 /dialog/policy" "^(status|lower|upper|gap|precision|trials):"
# A dialog as a person types it; the robot's lines are what /robot_utterance/text carried
# after each utterance.
PYTHONUNBUFFERED=1 rostopic echo /robot_utterance/text > "$WORK/robot.txt" 2>&1 &
ECHO=$!
sleep 2
echo "\$ rostopic echo /robot_utterance/text &     # the robot's lines below" >> "$OUT"
say() {  # say "text": publish an utterance, then print what the robot said in reply
  echo "\$ rostopic pub -1 /user_utterance krr_msgs/UserUtterance \"text: '$1'\"" >> "$OUT"
  local before
  before=$(wc -l < "$WORK/robot.txt")
  rostopic pub -1 /user_utterance krr_msgs/UserUtterance "text: '$1'" > /dev/null 2>&1 || true
  sleep "${2:-2}"
  tail -n +"$((before + 1))" "$WORK/robot.txt" | grep -v '^---$' >> "$OUT" || true
}
# The person answers the question the robot actually asked (as a person would), for the request
# they have in mind: item, room, person.
converse() {  # converse ITEM ROOM PERSON: answer until the robot serves (at most 20 answers)
  local q a
  for _ in $(seq 1 20); do
    q=$(grep -v '^---$' "$WORK/robot.txt" | tail -n 1)
    case "$q" in
      *"Which item"*) a="$1" ;;
      *"Which room"*) a="$2" ;;
      *"Who is it for"*) a="$3" ;;
      *"Should I deliver a "*) [ "${q#*deliver a }" = "$1?\"" ] && a=yes || a=no ;;
      *"Should I deliver to "*) [ "${q#*deliver to }" = "$2?\"" ] && a=yes || a=no ;;
      *"Is it for "*) [ "${q#*Is it for }" = "$3?\"" ] && a=yes || a=no ;;
      *) return 0 ;;  # served (or anything that is not a question): the dialog is over
    esac
    say "$a" 3
  done
}
say "I would like a coke for Bob to office2, please"
run "rostopic echo -n 1 /dialog_belief" "^(entropy|most_likely|  (item|room|person):)"
converse coke room2 bob
say "yes" 4
say "xyzzy"
say "Could you bring a soda for John to room 3?"
converse soda room3 john
say "yes" 4
kill "$ECHO" 2> /dev/null || true
goal "{goal: {place: room1}}" "^(success|outcome|final_cell|steps|failure_reason)"
goal "{goal: {cell: 5000}}" "^(success|outcome|failure_reason)"
run "rosservice call /reasoner/add_knowledge \"{update: {source: me, atoms: [{cell: 182, move: up, time: morning, outcomes: ['212', '182'], counts: [7, 3], samples: 10}]}}\""
run "rosservice call /reasoner/add_knowledge \"{update: {source: me, atoms: [{cell: 182, move: up, time: morning, outcomes: ['212', '182'], counts: [7, 2], samples: 10}]}}\"" '^(success|message|  \\)'
run "rosservice call /reasoner/build_task_model \"{task: navigation, times: [morning]}\"" "^(success|message)"
mkdir -p "$ROOT/docs"
sed -e 's/\x1b\[[0-9;]*m//g' "$OUT" > "$ROOT/docs/example_session.txt"
echo "record_session: wrote docs/example_session.txt ($(wc -l < "$ROOT/docs/example_session.txt") lines)"
