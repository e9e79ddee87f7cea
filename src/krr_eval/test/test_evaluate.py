"""`evaluate` on fake CLIs: every experiment runs and writes its outputs, tables do not
depend on the number of workers, and --replay recomputes them without running anything."""
import glob
import io
import json
import os
import shutil
import tempfile
import unittest

from krr_eval import experiments, suite
from testdata import fake_cli

ENV = ("KRR_BIN_DIR", "FAKE_KRR_MODE", "FAKE_KRR_LOG", "ROS_MASTER_URI")


def run_suite(args):
    out, err = io.StringIO(), io.StringIO()
    rc = suite.main(args, stdout=out, stderr=err)
    return rc, out.getvalue(), err.getvalue()


def table_files(d):
    """Result tables (md/csv) and trial files, which must not depend on workers or replay."""
    names = [os.path.relpath(p, d) for p in glob.glob(os.path.join(d, "*.csv")) +
             glob.glob(os.path.join(d, "*.md")) + glob.glob(os.path.join(d, "trials", "*.csv"))]
    out = {}
    for n in sorted(names):
        if n in ("report.md",):
            continue
        with open(os.path.join(d, n)) as f:
            out[n] = f.read()
    return out


class FakeEnv(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="krr_eval_test_")
        cls.saved = {k: os.environ.get(k) for k in ENV}
        os.environ["KRR_BIN_DIR"] = fake_cli.make_bin_dir(os.path.join(cls.tmp, "bin"))
        os.environ["FAKE_KRR_LOG"] = os.path.join(cls.tmp, "calls.log")
        os.environ["ROS_MASTER_URI"] = "http://127.0.0.1:1"  # nothing listens there
        os.environ.pop("FAKE_KRR_MODE", None)

    @classmethod
    def tearDownClass(cls):
        for k, v in cls.saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def setUp(self):
        os.environ.pop("FAKE_KRR_MODE", None)

    def ncalls(self):
        p = os.environ["FAKE_KRR_LOG"]
        if not os.path.exists(p):
            return 0
        with open(p) as f:
            return len(f.read().splitlines())


class SuiteTest(FakeEnv):
    @classmethod
    def setUpClass(cls):
        super(SuiteTest, cls).setUpClass()
        cls.out = os.path.join(cls.tmp, "full")
        cls.rc, cls.stdout, cls.stderr = run_suite(
            ["--out", cls.out, "--quick", "--workers", "1", "--chunks-per-worker", "1",
             "--seed", "3", "--trials", "exp2=120,exp4=200,exp5=80"])

    def test_every_experiment_ran_and_wrote_its_outputs(self):
        self.assertEqual(self.rc, 0, self.stdout)
        for f in ("report.md", "params.json", "claims.md", "claims.csv", "claims.json",
                  "exp1_nav_transfer.png", "exp1_nav_transfer.md", "exp1_curve_small.csv",
                  "exp2_table1.md", "exp2_table1.csv", "exp2_significance.csv",
                  "exp3_cdf.png", "exp3_qa_cost.csv", "exp4_table2.md",
                  "exp5_new_circumstances.csv", "exp6_belief_bars.png", "exp6_dialog.md",
                  "exp2_paired_rates.csv", "exp2_trial_count.csv", "exp3_cdf_other_br.png",
                  "exp6_policy_dialog.md", "trials/dialog_script_policy.csv",
                  "trials/delivery_br0.7_learned.csv", "trials/dialog_script.csv"):
            self.assertTrue(os.path.exists(os.path.join(self.out, f)), f)
        for png in glob.glob(os.path.join(self.out, "*.png")):
            with open(png, "rb") as f:
                self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n", png)
        for k in ("exp1", "exp2", "exp3", "exp4", "exp5", "exp6"):
            self.assertRegex(self.stdout, r"%s done in \d+\.\d s" % k)
        self.assertIn("Time per experiment", self.stdout)
        self.assertIn("[exp2]", self.stderr)  # progress bar

    def test_params_record_seed_counts_versions_and_trial_files(self):
        with open(os.path.join(self.out, "params.json")) as f:
            p = json.load(f)
        self.assertEqual(p["seed"], 3)
        self.assertEqual(p["experiments"]["exp2"]["trials"], 120)
        self.assertEqual(p["experiments"]["exp1"]["trials"],
                         experiments.QUICK["exp1"]["trials"])  # --quick
        self.assertEqual(p["experiments"]["exp2"]["brs"], [0.1, 0.5, 0.7])
        self.assertEqual(p["completed"], ["exp1", "exp2", "exp3", "exp4", "exp5", "exp6"])
        ts = p["trial_sets"]["delivery_br0.5_outdated"]
        self.assertEqual((ts["program"], ts["seed"], ts["trials"], ts["rows"]),
                         ("delivery_trials", 3, 120, 120))
        self.assertIn("--condition", ts["args"])
        self.assertIn("sha256", p["versions"]["programs"]["delivery_trials"])
        self.assertIn("numpy", p["versions"])
        self.assertEqual(set(p["times_s"]), {"exp1", "exp2", "exp3", "exp4", "exp5", "exp6"})

    def test_report_has_paper_numbers_and_claim_lines(self):
        with open(os.path.join(self.out, "report.md")) as f:
            rep = f.read()
        for paper_number in ("182.07", "206.21", "0.932", "18.73", "-40.33", "0.028", "0.049",
                             "0.274 (0.090) / 0.419", "0.838", "0.268"):
            self.assertIn(paper_number, rep)
        with open(os.path.join(self.out, "claims.json")) as f:
            claims = json.load(f)
        self.assertGreaterEqual(len(claims), 25)
        lines = [l for l in rep.splitlines() if l.startswith("| ") and ("supported" in l)]
        self.assertEqual(len(lines), len(claims))
        by = {c["claim"]: c for c in claims}
        # effects the fake makes large are found, in the right direction
        self.assertEqual(by["merging learned models beats a random pick of one"]["verdict"],
                         "supported")
        self.assertEqual(by["with extraction the robot learns faster (large domain)"]["verdict"],
                         "supported")
        self.assertEqual(by["the robot never asks about the person (prior knowledge: Bob's "
                            "office)"]["verdict"], "supported")
        # Table I as the paper means it: identification, navigation success, delivered; the
        # paired tests; the trial count and nothing tuned to the paper's magnitudes
        for text in ("identified", "navigation success", "delivered", "expected reward",
                     "paired on the same trials", "McNemar", "Nothing is tuned towards the "
                     "paper's magnitudes", "Trial count.", "taken as the paper's setting",
                     "exp3_cdf_other_br.png"):
            self.assertIn(text, rep)

    def test_tables_identical_for_other_worker_counts(self):
        out3 = os.path.join(self.tmp, "w3")
        rc, stdout, _ = run_suite(["--out", out3, "--quick", "--workers", "3", "--seed", "3",
                                   "--chunks-per-worker", "3", "--no-progress",
                                   "--only", "exp2,exp5",
                                   "--trials", "exp2=120,exp4=200,exp5=80"])
        self.assertEqual(rc, 0, stdout)
        full, three = table_files(self.out), table_files(out3)
        self.assertGreater(len(three), 8)
        for name, text in three.items():
            if name.startswith("claims"):
                continue
            self.assertEqual(text, full[name], name)

    def test_replay_recomputes_without_running(self):
        n = self.ncalls()
        os.environ["FAKE_KRR_MODE"] = "fail"  # any CLI run would fail now
        out2 = os.path.join(self.tmp, "replayed")
        rc, stdout, _ = run_suite(["--replay", self.out, "--out", out2, "--no-progress"])
        self.assertEqual(rc, 0, stdout)
        self.assertEqual(self.ncalls(), n)
        self.assertEqual(table_files(out2), table_files(self.out))
        with open(os.path.join(out2, "params.json")) as f:
            self.assertEqual(json.load(f)["replayed_from"], self.out)
        # replaying part of a folder into itself keeps the rest of its record
        rc, stdout, _ = run_suite(["--replay", out2, "--only", "exp5", "--no-progress"])
        self.assertEqual(rc, 0, stdout)
        with open(os.path.join(out2, "params.json")) as f:
            p = json.load(f)
        self.assertEqual(len(p["completed"]), 6)
        self.assertIn("nav_transfer_small", p["trial_sets"])


if __name__ == "__main__":
    unittest.main()
