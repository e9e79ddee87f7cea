"""`rosrun krr_eval evaluate` verdicts and failure handling on fake CLIs: opposite effects and noise
are reported as not supported, a failing CLI is reported by name without stopping the suite,
bad options are usage errors, and ROS-style arguments work without a master."""
import json
import os
import unittest

from test_evaluate import FakeEnv, run_suite
from krr_eval import rosnode

SMALL = ["--trials", "exp2=60,exp5=60", "--workers", "2", "--chunks-per-worker", "1",
         "--no-progress", "--no-ros"]


def read(path):
    with open(path) as f:
        return f.read()


def claims(out):
    with open(os.path.join(out, "claims.json")) as f:
        return json.load(f)


class VerdictTest(FakeEnv):
    def test_opposite_effects_are_not_supported(self):
        os.environ["FAKE_KRR_MODE"] = "reverse"
        out = os.path.join(self.tmp, "reverse")
        rc, stdout, _ = run_suite(["--out", out, "--only", "exp2,exp5,exp6"] + SMALL)
        self.assertEqual(rc, 0, stdout)
        cs = claims(out)
        merged = [c for c in cs if c["experiment"] == "5 new circ."][0]
        self.assertEqual(merged["verdict"], "NOT supported (opposite direction)")
        rewards = [c for c in cs if "higher overall reward" in c["claim"]]
        self.assertEqual(len(rewards), 6)  # expected (primary) and realised, per br
        self.assertTrue(all(c["verdict"].startswith("NOT supported") for c in rewards))
        fig4 = {c["claim"]: c["verdict"] for c in cs if c["experiment"] == "6 Fig. 4"}
        self.assertEqual(fig4["the robot starts with uniform marginals over item, person and "
                              "room"], "supported")
        for claim in ("at the end the belief is confident in <coke, Bob, office2>",
                      "after the request the robot asks about the item first",
                      "the robot never asks about the person (prior knowledge: Bob's office)",
                      "after the paper's four user turns the robot delivers a coke for Bob to "
                      "office2",
                      "the robot's own policy asks the paper's questions (Which item is it? / "
                      "Should I deliver a coke? / Should I deliver to office2?)"):
            self.assertEqual(fig4[claim], "NOT supported", claim)
        self.assertIn("NOT supported", read(os.path.join(out, "report.md")))

    def test_every_unsupported_claim_has_a_reason(self):
        """report.md explains every claim it does not support with a reason generated from the
        numbers; the experiments give their own (exp5's may fall back to the generic one)."""
        for mode, seed in (("reverse", "1"), ("noisy", "2")):
            os.environ["FAKE_KRR_MODE"] = mode
            out = os.path.join(self.tmp, "reasons_" + mode)
            rc, stdout, _ = run_suite(["--out", out, "--quick", "--seed", seed,
                                       "--trials", "exp2=200,exp4=300,exp5=60", "--workers", "2",
                                       "--chunks-per-worker", "1", "--no-progress", "--no-ros"])
            self.assertEqual(rc, 0, stdout)
            cs = claims(out)
            self.assertEqual(len({c["experiment"] for c in cs}), 6)
            bad = [c for c in cs if c["verdict"] != "supported"]
            self.assertGreater(len(bad), 10 if mode == "reverse" else 3, mode)
            rep = read(os.path.join(out, "report.md"))
            self.assertIn("### Why claims are not supported", rep)
            for c in bad:
                self.assertTrue(c["reason"] and c["reason"].strip(), c)
                self.assertIn(c["reason"], rep)
                if c["experiment"] != "5 new circ.":
                    self.assertEqual(c["reason_source"], "experiment", c)
            for c in cs:
                if c["verdict"] == "supported":
                    self.assertIsNone(c["reason"], c)

    def test_no_effect_is_not_significant(self):
        os.environ["FAKE_KRR_MODE"] = "noisy"
        out = os.path.join(self.tmp, "noisy")
        rc, stdout, _ = run_suite(["--out", out, "--only", "exp5", "--seed", "2"] + SMALL)
        self.assertEqual(rc, 0, stdout)
        v = claims(out)[0]["verdict"]
        self.assertTrue(v.startswith("NOT supported"), v)

    def test_failing_cli_is_reported_and_suite_goes_on(self):
        os.environ["FAKE_KRR_MODE"] = "fail"
        out = os.path.join(self.tmp, "fail")
        rc, stdout, _ = run_suite(["--out", out, "--only", "exp2,exp5"] + SMALL)
        self.assertEqual(rc, 1)
        self.assertIn("exp2 FAILED", stdout)
        self.assertIn("exp5 FAILED", stdout)
        with open(os.path.join(out, "params.json")) as f:
            p = json.load(f)
        self.assertIn("delivery_trials failed with exit code 3", p["failed"]["exp2"])
        self.assertIn("config/x.yaml line 3", p["failed"]["exp2"])
        self.assertIn("Failed experiments", read(os.path.join(out, "report.md")))

    def test_bad_cli_output_names_file_and_column(self):
        os.environ["FAKE_KRR_MODE"] = "garbage"
        out = os.path.join(self.tmp, "garbage")
        rc, stdout, _ = run_suite(["--out", out, "--only", "exp2"] + SMALL)
        self.assertEqual(rc, 1)
        self.assertRegex(stdout, r"delivery_br0\.\d_\w+ \(delivery_trials\) data row 1 column "
                                 r"'reward': 'oops' is not a number")


class UsageTest(FakeEnv):
    def assertUsageError(self, args, text):
        import contextlib
        import io
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            with self.assertRaises(SystemExit) as cm:
                run_suite(args)
        self.assertEqual(cm.exception.code, 2)
        self.assertIn(text, err.getvalue())

    def test_usage_errors(self):
        self.assertUsageError(["--out", self.tmp, "--only", "exp9"], "unknown experiment(s) exp9")
        self.assertUsageError(["--out", self.tmp, "--trials", "exp2=x"], "'x' is not an integer")
        self.assertUsageError(["--out", self.tmp, "--trials", "exp7=5"],
                              "unknown experiment 'exp7'")
        self.assertUsageError(["--out", self.tmp, "--trials", "1"], "at least 2 trials")
        self.assertUsageError(["--replay", self.tmp], "no params.json")
        self.assertUsageError(["--out", self.tmp, "_quick:=maybe"], "expected true or false")

    def test_replay_folder_without_trials(self):
        d = os.path.join(self.tmp, "not_an_output")
        os.makedirs(d)
        with open(os.path.join(d, "params.json"), "w") as f:
            f.write("{}")
        rc, _, err = run_suite(["--replay", d])
        self.assertEqual(rc, 2)
        self.assertIn("has no trials/ folder", err)


class RosArgsTest(FakeEnv):
    def test_split_and_params(self):
        own, ros, private = rosnode.split_ros_args(
            ["--seed", "4", "__name:=ev", "_trials_scale:=0.5", "_quick:=true", "a:=b",
             "__log:=/tmp/x.log"])
        self.assertEqual(own, ["--seed", "4"])
        self.assertEqual(ros, ["__name:=ev", "_trials_scale:=0.5", "_quick:=true", "a:=b",
                               "__log:=/tmp/x.log"])
        self.assertEqual(private, {"trials_scale": "0.5", "quick": "true"})
        self.assertEqual(rosnode.params_to_args(private, ("quick",)),
                         ["--quick", "--trials-scale", "0.5"])
        self.assertEqual(rosnode.params_to_args({"quick": "false"}, ("quick",)), [])

    def test_master_reachable(self):
        import socket
        self.assertFalse(rosnode.master_reachable("http://127.0.0.1:1", timeout=0.2))
        self.assertFalse(rosnode.master_reachable("not a uri"))
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        s.listen(1)
        try:
            self.assertTrue(rosnode.master_reachable("http://127.0.0.1:%d" % s.getsockname()[1]))
        finally:
            s.close()

    def test_rosrun_style_command_line_without_master(self):
        out = os.path.join(self.tmp, "ros")
        rc, stdout, stderr = run_suite(["__name:=krr_eval", "_out:=" + out, "_only:=exp5",
                                        "_trials:=exp5=40", "_no_progress:=true"])
        self.assertEqual(rc, 0, stdout)
        self.assertIn("no ROS master answers at http://127.0.0.1:1", stderr)
        self.assertTrue(os.path.exists(os.path.join(out, "exp5_new_circumstances.md")))
        with open(os.path.join(out, "params.json")) as f:
            self.assertEqual(json.load(f)["experiments"]["exp5"]["trials"], 40)


if __name__ == "__main__":
    unittest.main()
