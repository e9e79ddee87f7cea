"""Tests of the `plog` command-line program (src/krr_core/apps/plog.cpp).

The binary is found through the environment variable KRR_PLOG_BIN, else in the catkin
workspace the test runner builds (catkin_ws/devel/lib/krr_core/plog). Under the test runner
(KRR_ROOT set) a missing binary is a failure; a bare `python3 -m unittest` without a build
skips these tests.
"""
import json
import os
import shutil
import subprocess
import tempfile
import unittest

from krr_eval import paths

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = paths.root()
DATA = os.path.join(ROOT, "src", "krr_core", "test", "data", "plog")
MONTY = os.path.join(DATA, "monty_hall.plog")
MONTY2 = os.path.join(DATA, "monty_hall_plog2.plog")


def find_plog():
    env = os.environ.get("KRR_PLOG_BIN")
    if env:
        return env
    path = os.path.join(ROOT, "catkin_ws", "devel", "lib", "krr_core", "plog")
    return path if os.path.isfile(path) else None


PLOG = find_plog()


def run(*args, timeout=120):
    return subprocess.run([PLOG, *args], capture_output=True, text=True, timeout=timeout)


class PlogCliTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if PLOG is None or not os.path.isfile(PLOG):
            if os.environ.get("KRR_ROOT"):
                raise AssertionError("plog binary not found (set KRR_PLOG_BIN or build "
                                     "catkin_ws): %r" % PLOG)
            raise unittest.SkipTest("plog binary not built (set KRR_PLOG_BIN)")
        cls.tmp = tempfile.mkdtemp(prefix="plog_cli_")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def write(self, name, text):
        path = os.path.join(self.tmp, name)
        with open(path, "w") as f:
            f.write(text)
        return path

    def json_answers(self, *args):
        r = run(*args, "--json")
        self.assertEqual(r.returncode, 0, r.stderr)
        rows = [json.loads(line) for line in r.stdout.splitlines()]
        for row in rows:
            self.assertIn("query", row)
            self.assertIn("probability", row)
        return rows

    def test_monty_hall_plain_output(self):
        r = run(MONTY)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stdout.splitlines(),
                         ["?{prize=3} : 0.6666666667", "?{prize=1} : 0.3333333333"])
        self.assertEqual(r.stderr, "")

    def test_monty_hall_json_and_command_line_query(self):
        rows = self.json_answers(MONTY, "--query", "?{prize = 2}")
        self.assertEqual([row["query"] for row in rows],
                         ["?{prize=3}", "?{prize=1}", "?{prize = 2}"])
        self.assertAlmostEqual(rows[0]["probability"], 2.0 / 3.0, places=12)
        self.assertAlmostEqual(rows[1]["probability"], 1.0 / 3.0, places=12)
        self.assertEqual(rows[2]["probability"], 0.0)  # the opened door never hides the prize
        self.assertEqual(rows[0]["backend"], "native")

    def test_backends_agree(self):
        asp_dir = os.path.join(DATA, "asp")
        cases = [
            (MONTY, []),
            (MONTY2, []),
            (os.path.join(asp_dir, "monty_hall.plog"), []),
            (os.path.join(asp_dir, "dice.plog"),
             ["?{roll(d1) = 6}", "?{even(d1) = true} | obs(roll(d2) = 6)",
              "?{roll(d1) = 6} | obs(even(d1) = true)", "?{roll(d2) = 6} | do(roll(d1) = 6)"]),
            (os.path.join(asp_dir, "dynamic_range.plog"),
             ["?{b = 4}", "?{a = 1} | obs(b = 1)", "?{b = 3} | do(a = 3)"]),
        ]
        for program, queries in cases:
            args = [program]
            for q in queries:
                args += ["--query", q]
            with self.subTest(program=os.path.relpath(program, DATA)):
                native = self.json_answers(*args, "--backend", "native")
                asp = self.json_answers(*args, "--backend", "asp")
                self.assertTrue(native, "no queries for " + program)
                self.assertEqual([r["query"] for r in native], [r["query"] for r in asp])
                self.assertEqual(asp[0]["backend"], "asp")
                for n, a in zip(native, asp):
                    self.assertAlmostEqual(n["probability"], a["probability"], places=9,
                                           msg=n["query"])
        # Hand-derived values through the clingo back end: Monty Hall 2/3; Mike's die
        # P(6) = 1/4, P(even) = 3/20 + 3/20 + 1/4; dynamic range sum_a 1/4 * 1/(5 - a).
        rows = self.json_answers(MONTY, "--backend", "asp")
        self.assertAlmostEqual(rows[0]["probability"], 2.0 / 3.0, places=12)
        rows = self.json_answers(os.path.join(asp_dir, "dice.plog"), "--backend", "asp",
                                 "--query", "?{even(d1) = true}")
        self.assertAlmostEqual(rows[0]["probability"], 0.55, places=12)
        rows = self.json_answers(os.path.join(asp_dir, "dynamic_range.plog"), "--backend", "asp",
                                 "--query", "?{b = 4}")
        self.assertAlmostEqual(rows[0]["probability"], (1 / 4 + 1 / 3 + 1 / 2 + 1) / 4,
                               places=12)

    def test_parse_error_prints_file_line_col_and_fails(self):
        bad = self.write("bad.plog", "doors = {1, 2}.\nprize : doors.\nrandom(prize) :- .\n")
        for backend in ("native", "asp"):
            with self.subTest(backend=backend):
                r = run(bad, "--backend", backend)
                self.assertNotEqual(r.returncode, 0)
                self.assertEqual(r.stdout, "")
                first = r.stderr.splitlines()[0]
                self.assertTrue(first.startswith(bad + ":3:18: "), r.stderr)

    def test_bad_command_line_query_names_its_position(self):
        r = run(MONTY, "--query", "?{prize = 7}")
        self.assertEqual(r.returncode, 1)
        self.assertIn("<command line>:1:", r.stderr)
        self.assertIn("'7'", r.stderr)
        self.assertEqual(len(r.stdout.splitlines()), 2)  # the file's queries are still answered

    def test_missing_file_errors_cleanly(self):
        missing = os.path.join(self.tmp, "does_not_exist.plog")
        r = run(missing)
        self.assertEqual(r.returncode, 1)
        self.assertEqual(r.stdout, "")
        self.assertIn(missing, r.stderr)
        self.assertIn("cannot open", r.stderr)
        self.assertNotIn("terminate", r.stderr)

    def test_usage_errors(self):
        self.assertEqual(run(MONTY, "--backend", "prolog").returncode, 2)
        self.assertEqual(run().returncode, 2)
        self.assertEqual(run(MONTY, "--frobnicate").returncode, 2)


if __name__ == "__main__":
    unittest.main()
