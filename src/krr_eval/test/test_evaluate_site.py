"""`evaluate --only exp2 --site DIR`: Table I-style delivery trials on another building.

On the fake CLIs: every delivery_trials call gets the site folder, the tables carry the site's
rooms, the paper's office comparisons (its numbers, p-values and claims) are skipped and say so,
the other experiments are refused, and a replay recomputes the same tables. One real run on the
bundled lab site (config/sites/lab) when the core programs are built (skipped otherwise, as the
end-to-end tests are)."""
import contextlib
import csv
import io
import json
import os
import shutil
import subprocess
import tempfile
import unittest

from krr_eval import paths, suite
from test_evaluate import FakeEnv, run_suite, table_files
from test_evaluate_e2e import EVALUATE, missing

LAB = "config/sites/lab"  # relative: resolved against the repository root from any directory
LAB_ROOMS = {"lab", "kitchen", "library", "studio"}
OFFICE_ROOMS = {"room1", "room2", "room3", "room4", "room5"}


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def refusal(args):
    """The usage error `evaluate args` exits with (its stderr), or None when it runs."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        try:
            run_suite(args)
        except SystemExit as e:
            return "exit %s: %s" % (e.code, err.getvalue())
    return None


class SiteSuiteTest(FakeEnv):
    @classmethod
    def setUpClass(cls):
        super(SiteSuiteTest, cls).setUpClass()
        cls.out = os.path.join(cls.tmp, "lab")
        cls.rc, cls.stdout, cls.stderr = run_suite(
            ["--out", cls.out, "--quick", "--only", "exp2", "--site", LAB, "--workers", "1",
             "--chunks-per-worker", "1", "--trials", "exp2=120"])
        with open(os.environ["FAKE_KRR_LOG"]) as f:
            cls.calls = f.read().splitlines()

    def test_every_trial_set_runs_on_the_site(self):
        self.assertEqual(self.rc, 0, self.stdout + self.stderr)
        lab = os.path.realpath(paths.repo(*LAB.split("/")))
        delivery = [c for c in self.calls if c.startswith("delivery_trials ")]
        self.assertEqual(len(delivery), 9, self.calls)  # 3 br x 2 conditions + 3 ablation sets
        for c in delivery:
            self.assertIn("--site %s" % lab, c)
        with open(os.path.join(self.out, "params.json")) as f:
            self.assertEqual(json.load(f)["site"], lab)
        self.assertIn("on site %s" % lab, self.stdout)

    def test_rooms_come_from_the_site(self):
        trials = read_csv(os.path.join(self.out, "trials", "delivery_br0.1_learned.csv"))
        rooms = {r["room"] for r in trials}
        self.assertTrue(rooms and rooms <= LAB_ROOMS, rooms)
        with open(os.path.join(self.out, "exp2_serve_reward.md")) as f:
            ablation = f.read()
        self.assertIn("always-reached rooms", ablation)
        self.assertFalse(OFFICE_ROOMS & set(ablation.replace(",", " ").replace(")", " ").split()))

    def test_the_paper_comparison_is_skipped_and_says_so(self):
        with open(os.path.join(self.out, "claims.json")) as f:
            self.assertEqual(json.load(f), [])
        for table in ("exp2_table1.csv", "exp2_significance.csv"):
            rows = read_csv(os.path.join(self.out, table))
            self.assertEqual(len(rows), 3 * (2 if table == "exp2_table1.csv" else 1), table)
            self.assertEqual([c for c in rows[0] if "paper" in c], [], table)
        with open(os.path.join(self.out, "report.md")) as f:
            report = f.read()
        self.assertIn("the paper's comparison is skipped", report)
        self.assertIn("not the paper's office", report)
        self.assertNotIn("182.07", report)  # the paper's Table I reward at br 0.1
        self.assertIn("(no claims: the paper's claims are about its office and are skipped on "
                      "site lab)", self.stdout)

    def test_a_replay_recomputes_the_same_tables(self):
        before = len(self.calls)
        out = os.path.join(self.tmp, "lab_replay")
        rc, stdout, stderr = run_suite(["--replay", self.out, "--out", out, "--no-progress"])
        self.assertEqual(rc, 0, stdout + stderr)
        self.assertEqual(self.ncalls(), before)
        self.assertEqual(table_files(out), table_files(self.out))


class SiteRefusalTest(FakeEnv):
    def test_other_experiments_are_refused(self):
        for only in ([], ["--only", "exp1"], ["--only", "exp2,exp3"]):
            why = refusal(["--out", os.path.join(self.tmp, "x"), "--quick", "--site", LAB] + only)
            self.assertIsNotNone(why, only)
            self.assertIn("exit 2", why)
            self.assertIn("--site supports exp2 only", why)
        self.assertEqual(self.ncalls(), 0)

    def test_a_folder_without_site_yaml_is_refused(self):
        why = refusal(["--out", os.path.join(self.tmp, "y"), "--only", "exp2", "--site",
                       self.tmp])
        self.assertIsNotNone(why)
        self.assertIn("no site folder there", why)
        self.assertEqual(self.ncalls(), 0)


@unittest.skipIf(os.environ.get("KRR_E2E") == "0", "KRR_E2E=0")
class SiteEndToEndTest(unittest.TestCase):
    """The real delivery_trials on the lab: small counts, an uncertified 300-trial policy."""

    def test_exp2_on_the_lab(self):
        why = missing("exp2")
        if why:
            self.skipTest(why)
        tmp = tempfile.mkdtemp(prefix="krr_e2e_site_")
        self.addCleanup(shutil.rmtree, tmp, True)
        out = os.path.join(tmp, "lab")
        env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:1")
        res = subprocess.run(
            ["/usr/bin/python3", EVALUATE, "--quick", "--only", "exp2", "--site", LAB,
             "--trials", "exp2=200", "--solver-trials", "300", "--allow-unconverged",
             "--out", out, "--no-progress", "--no-ros"],
            capture_output=True, text=True, env=env, timeout=1200, cwd=tmp)
        self.assertEqual(res.returncode, 0, res.stdout[-3000:] + res.stderr[-3000:])
        self.assertIn("exp2 done in", res.stdout)
        rooms = {r["room"] for r in read_csv(os.path.join(out, "trials",
                                                          "delivery_br0.5_learned.csv"))}
        self.assertTrue(rooms and rooms <= LAB_ROOMS, rooms)
        with open(os.path.join(out, "claims.json")) as f:
            self.assertEqual(json.load(f), [])
        with open(os.path.join(out, "report.md")) as f:
            self.assertIn("the paper's comparison is skipped", f.read())


if __name__ == "__main__":
    unittest.main()
