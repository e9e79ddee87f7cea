#!/usr/bin/env bash
# Every test of the stack: installs dependencies, builds, then runs
#   0. check_site on the bundled configuration (its files agree on the site's names: a
#      disagreement would otherwise surface as a confusing failure of some later test), and
#      the second bundled site, config/sites/lab: its check, a dialog_script delivery and 300
#      delivery_trials (nothing of the office is hard-wired), a site scaffolded by make_site
#      from its map and places (its domain cut by make_site, cut again by make_nav_domain,
#      checked), and one whose map make_site draws from a room / corridor description, which
#      runs a dialog_script delivery as make_site wrote it; the lab's sim.launch
#      delivery is the rostest delivery_e2e_site.test,
#   1. the core gtests (no roscore),
#   2. every rostest .test (each starts its own master; run after sourcing devel/setup.bash,
#      because `catkin_make run_tests` leaves PYTHONPATH empty for Python test nodes),
#   3. the Python unittest suites of krr_eval (src/krr_eval/test), among them test_layering.py,
#      which runs test/check_layering.py (no experiment header in library or node code, every
#      module header in its namespace krr::<module>), and test_function_length.py, which runs
#      test/check_function_length.py (no function in src/ over 120 lines but the allowlisted).
# Prints one summary line "tests: N passed, N failed" and exits non-zero on any failure.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export PATH="/usr/bin:/bin:$PATH"
if [ "${KRR_SKIP_SETUP:-0}" != 1 ]; then   # KRR_SKIP_SETUP=1: reuse the current build
  bash "$ROOT/tools/install_deps.sh" || exit 1
  KRR_BUILD_TESTS=1 bash "$ROOT/tools/build.sh" || exit 1
fi

RESULTS="$ROOT/catkin_ws/test_results_all"
rm -rf "$RESULTS"; mkdir -p "$RESULTS"
set +u; source "$ROOT/catkin_ws/devel/setup.bash"; set -u
export ROS_HOME="${ROS_HOME:-$RESULTS/ros_home}"
export KRR_ROOT="$ROOT"

echo "== site check"
if "$ROOT/catkin_ws/devel/lib/krr_core/check_site" --root "$ROOT" > "$RESULTS/check_site.log" 2>&1; then
  echo "  ok   check_site: $(head -c 160 "$RESULTS/check_site.log")"
  echo '<testsuites><testsuite name="check_site" tests="1" failures="0"><testcase name="bundled"/></testsuite></testsuites>' > "$RESULTS/check_site.xml"
else
  echo "  FAIL check_site"; cat "$RESULTS/check_site.log"
  echo '<testsuites><testsuite name="check_site" tests="1" failures="1"><testcase name="bundled"><failure message="see check_site.log"/></testcase></testsuite></testsuites>' > "$RESULTS/check_site.xml"
fi

echo "== the second bundled site (config/sites/lab: other rooms, people, items, areas and shop)"
# site_case NAME PATTERN CMD...: CMD must exit 0 and print PATTERN (grep -E) on stdout or stderr.
site_case() {
  local name="$1" pattern="$2"; shift 2
  local log="$RESULTS/site-$name.log" t0=$SECONDS ok=1
  "$@" > "$log" 2>&1 || ok=0
  [ "$ok" = 1 ] && ! grep -qE "$pattern" "$log" && ok=0
  if [ "$ok" = 1 ]; then
    echo "  ok   site $name ($((SECONDS - t0)) s)"
    echo "<testsuites><testsuite name=\"site\" tests=\"1\" failures=\"0\"><testcase name=\"$name\"/></testsuite></testsuites>" > "$RESULTS/site-$name.xml"
  else
    echo "  FAIL site $name"; tail -20 "$log"
    echo "<testsuites><testsuite name=\"site\" tests=\"1\" failures=\"1\"><testcase name=\"$name\"><failure message=\"see site-$name.log\"/></testcase></testsuite></testsuites>" > "$RESULTS/site-$name.xml"
  fi
}
B="$ROOT/catkin_ws/devel/lib/krr_core"
LAB="$ROOT/config/sites/lab"
SITE_TMP="$(mktemp -d)"
site_case check_lab '^lab: site consistent: 4 rooms' "$B/check_site" --root "$ROOT" --site "$LAB"
site_case check_office '^office: site consistent' "$B/check_site" --root "$ROOT" --site "$ROOT/config/sites/office"
site_case dialog_script_lab '^fulfilled$' "$B/dialog_script" --root "$ROOT" --site "$LAB" \
  --cache "$SITE_TMP/policies" --solver-trials 1500 --deliver --check yes --utterance "tea for Dave to the reading room" \
  --utterance dave --utterance yes --utterance yes --utterance yes
site_case delivery_trials_lab '300 trials \[0, 300\): reward' "$B/delivery_trials" --root "$ROOT" \
  --site "$LAB" --br 0.3 --condition learned --seed 1 --trials 300 --solver-trials 300 \
  --learned-cache "$SITE_TMP/learned"
# A starter site scaffolded from the lab's map and places with other people and items
# (make_site, which cuts its domain), then cut again and checked as a user would.
site_case make_site_scaffold 'domains cut: scaffold_24x16 \(24x16' "$B/make_site" --root "$ROOT" \
  --map "$LAB/map.yaml" --places "$LAB/places.yaml" --people ann,ben_li,cy --items juice,soup \
  --offices ann:kitchen,ben_li:studio --shop mailroom --cell 0.5 --out "$SITE_TMP/scaffold"
site_case make_nav_domain_scaffold '"domain": "scaffold_24x16"' "$B/make_nav_domain" \
  --root "$ROOT" --site "$SITE_TMP/scaffold"
site_case check_scaffold '^scaffold: site consistent: 4 rooms' "$B/check_site" --root "$ROOT" \
  --site "$SITE_TMP/scaffold"
# A site whose map is drawn from a room / corridor description (make_site --rooms-from-text).
printf '%s\n' 'size 20 12' 'corridor 0 5 20 7' 'room entrance 0 0 5 5 door 2 3.5' \
  'room office_a 5 0 10 5 door 7 8.5' 'room lounge 0 7 6 12 door 2 3.5' 'area hall_a 5 5 6 7' \
  > "$SITE_TMP/drawn.txt"
site_case make_site_drawn 'site consistent: 2 rooms' "$B/make_site" --root "$ROOT" \
  --rooms-from-text "$SITE_TMP/drawn.txt" --people ann,ben --items juice,cake --offices ann:office_a \
  --shop entrance --cell 0.5 --out "$SITE_TMP/drawn"
# The folder runs as make_site wrote it: a delivery before any make_nav_domain.
site_case dialog_script_drawn '^fulfilled$' "$B/dialog_script" --root "$ROOT" \
  --site "$SITE_TMP/drawn" --cache "$SITE_TMP/policies" --solver-trials 1500 --deliver \
  --check yes --utterance "juice for Ann to Ann's office" --utterance yes --utterance yes \
  --utterance yes --utterance yes --utterance yes --utterance yes
site_case make_nav_domain_drawn '"domain": "drawn_40x24".*"lounge": \{"moves"' "$B/make_nav_domain" \
  --root "$ROOT" --site "$SITE_TMP/drawn"
rm -rf "$SITE_TMP"

echo "== core gtests"
for t in $(find "$ROOT/catkin_ws/devel/lib" -maxdepth 2 -type f -perm -u+x -name '*_test_*' | sort); do
  n=$(basename "$t")
  if "$t" --gtest_output="xml:$RESULTS/gtest-$n.xml" > "$RESULTS/$n.log" 2>&1; then
    echo "  ok   $n"
  else
    echo "  FAIL $n"; tail -30 "$RESULTS/$n.log"
    # a crashed binary writes no XML: record it as a failure
    [ -f "$RESULTS/gtest-$n.xml" ] || echo "<testsuites><testsuite name=\"$n\" tests=\"1\" failures=\"1\"><testcase name=\"crashed\"><failure message=\"crashed\"/></testcase></testsuite></testsuites>" > "$RESULTS/gtest-$n.xml"
  fi
done

echo "== rostests"
# rostest --text writes no XML: record each .test from its exit code and its summary block.
for f in $(find "$ROOT/src" -path '*/test/*.test' | sort); do
  pkg=$(basename "$(dirname "$(dirname "$f")")")
  n=$(basename "$f" .test)
  log="$RESULTS/rostest-$n.log"
  if timeout 600 rostest --text "$pkg" "$(basename "$f")" > "$log" 2>&1; then
    rc=0; echo "  ok   $pkg/$n"
  else
    rc=1; echo "  FAIL $pkg/$n"; tail -40 "$log"
  fi
  /usr/bin/python3 "$ROOT/test/summarize.py" --rostest-log "$log" --name "$pkg/$n" --rc $rc \
    > "$RESULTS/rostest-$n.xml"
done

echo "== python unittests"
EVAL_TESTS="$ROOT/src/krr_eval/test"   # krr_eval's src/ first: the checkout, sourced or not
if [ -d "$EVAL_TESTS" ] && find "$EVAL_TESTS" -name 'test_*.py' | grep -q .; then
  (cd "$EVAL_TESTS" && PYTHONPATH="$ROOT/src/krr_eval/src${PYTHONPATH:+:$PYTHONPATH}" \
     /usr/bin/python3 -m unittest discover -s . -p 'test_*.py' -t . ) \
    > "$RESULTS/python.log" 2>&1; prc=$?
  tail -3 "$RESULTS/python.log"
  /usr/bin/python3 "$ROOT/test/summarize.py" --unittest-log "$RESULTS/python.log" --rc $prc \
    > "$RESULTS/python-unittest.xml"
fi

/usr/bin/python3 "$ROOT/test/summarize.py" "$RESULTS"
