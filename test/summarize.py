#!/usr/bin/env python3
"""Sum up JUnit XML results into one line 'tests: N passed, N failed' (exit 1 on failures).

With --unittest-log LOG --rc RC it instead converts a `python -m unittest` log into a JUnit
XML file on stdout, so that Python suites are counted with the rest.
"""
import argparse
import glob
import os
import re
import sys
import xml.etree.ElementTree as ET


def unittest_to_junit(log_path, rc):
    text = open(log_path, encoding="utf-8", errors="replace").read()
    m = re.search(r"^Ran (\d+) tests?", text, re.M)
    ran = int(m.group(1)) if m else 0
    fails = 0
    m = re.search(r"^FAILED \((.*)\)", text, re.M)
    if m:
        for part in m.group(1).split(","):
            k, _, v = part.strip().partition("=")
            if k in ("failures", "errors"):
                fails += int(v)
    skipped = 0
    m = re.search(r"skipped=(\d+)", text)
    if m:
        skipped = int(m.group(1))
    if rc != 0 and fails == 0:
        fails = 1
        ran = max(ran, 1)
    cases = "".join('<testcase name="py%d"/>' % i for i in range(ran - fails - skipped))
    cases += "".join('<testcase name="pyfail%d"><failure message="see python.log"/></testcase>' % i
                     for i in range(fails))
    cases += "".join('<testcase name="pyskip%d"><skipped/></testcase>' % i for i in range(skipped))
    print('<testsuites><testsuite name="python" tests="%d" failures="%d" skipped="%d">%s'
          "</testsuite></testsuites>" % (ran, fails, skipped, cases))


def rostest_to_junit(log_path, name, rc):
    """One testcase per test of a `rostest --text` run, from its summary block and exit code."""
    text = open(log_path, encoding="utf-8", errors="replace").read()
    text = re.sub(r"\x1b\[[0-9;]*m", "", text)

    def count(key):
        m = re.findall(r"^ \* %s: (\d+)" % key, text, re.M)
        return int(m[-1]) if m else 0
    tests, errors, failures = count("TESTS"), count("ERRORS"), count("FAILURES")
    bad = errors + failures
    if rc != 0 and bad == 0:
        bad = 1
    tests = max(tests, bad, 1)
    esc = name.replace('"', "'")
    cases = "".join('<testcase name="%s#%d"/>' % (esc, i) for i in range(tests - bad))
    cases += "".join('<testcase name="%s#fail%d"><failure message="see rostest log"/></testcase>'
                     % (esc, i) for i in range(bad))
    print('<testsuites><testsuite name="%s" tests="%d" failures="%d">%s</testsuite></testsuites>'
          % (esc, tests, bad, cases))


def summarize(results_dir):
    passed = failed = skipped = 0
    for path in sorted(glob.glob(os.path.join(results_dir, "*.xml"))):
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError:
            failed += 1
            print("unreadable result file: %s" % path)
            continue
        for case in root.iter("testcase"):
            if case.find("failure") is not None or case.find("error") is not None:
                failed += 1
                print("FAILED: %s %s" % (os.path.basename(path), case.get("name")))
            elif case.find("skipped") is not None:
                skipped += 1
            else:
                passed += 1
    line = "tests: %d passed, %d failed" % (passed, failed)
    if skipped:
        line += ", %d skipped" % skipped
    print(line)
    return 1 if failed or passed == 0 else 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("results_dir", nargs="?")
    ap.add_argument("--unittest-log")
    ap.add_argument("--rostest-log")
    ap.add_argument("--name", default="rostest")
    ap.add_argument("--rc", type=int, default=0)
    a = ap.parse_args()
    if a.rostest_log:
        rostest_to_junit(a.rostest_log, a.name, a.rc)
        return 0
    if a.unittest_log:
        unittest_to_junit(a.unittest_log, a.rc)
        return 0
    return summarize(a.results_dir)


if __name__ == "__main__":
    sys.exit(main())
