"""Unit tests of the experiments' parsing helpers and of the result tables (no CLI runs)."""
import math
import os
import unittest

import numpy as np

from krr_eval import experiments, navigation, report, stats
from krr_eval.trials import TrialTable

HERE = os.path.dirname(os.path.abspath(__file__))


class DialogScriptTest(unittest.TestCase):
    def test_real_cli_output(self):
        # recorded from apps/dialog_script with the paper's utterances
        t = TrialTable.read(os.path.join(HERE, "testdata", "dialog_script_sample.csv"))
        turns = experiments.read_turns(t)
        self.assertEqual([tr["turn"] for tr in turns], [0, 1, 2])
        self.assertEqual(turns[1]["user"], "a coke for Bob to office2")
        self.assertEqual(turns[1]["next"], "ask_item")
        self.assertEqual(turns[2]["action"], "ask_item")
        self.assertEqual(turns[2]["next"], "serve_coke_room2_bob")
        self.assertEqual([v for v, _ in turns[0]["marg"]["room"]],
                         ["room1", "room2", "room3", "room4", "room5"])
        self.assertAlmostEqual(dict(turns[0]["marg"]["room"])["room2"], 0.425)
        self.assertAlmostEqual(dict(turns[2]["marg"]["item"])["coke"], 0.969697)
        for tr in turns:
            for d in experiments.DIMS:
                self.assertAlmostEqual(sum(p for _, p in tr["marg"][d]), 1.0, places=5)

    def test_long_format(self):
        t = TrialTable.from_text("turn,action,observation,variable,value,probability\n"
                                 "0,,,item,coke,0.5\n0,,,item,soda,0.5\n"
                                 "0,,,office,office2,1\n1,ask_item,coke,item,coke,0.9\n"
                                 "1,ask_item,coke,item,soda,0.1\n")
        turns = experiments.read_turns(t)
        self.assertEqual(turns[0]["marg"]["room"], [("room2", 1.0)])
        self.assertEqual(turns[1]["action"], "ask_item")
        self.assertEqual(turns[1]["marg"]["item"], [("coke", 0.9), ("soda", 0.1)])

    def test_no_marginals_is_an_error(self):
        with self.assertRaisesRegex(ValueError, "no marginal columns"):
            experiments.read_turns(TrialTable.from_text("turn,robot_action\n0,none\n", "x.csv"))

    def test_person_questions(self):
        self.assertTrue(experiments._asks_person("ask_person"))
        self.assertTrue(experiments._asks_person("confirm_person_bob"))
        self.assertFalse(experiments._asks_person("serve_coke_room2_bob"))
        self.assertFalse(experiments._asks_person("confirm_room_room2"))


class HelpersTest(unittest.TestCase):
    def test_norm_room(self):
        self.assertEqual(experiments.norm_room("office3"), "room3")
        self.assertEqual(experiments.norm_room(" Room2 "), "room2")

    def test_deliveries_only(self):
        t = TrialTable.from_text("trial,action,room,entropy\n0,serve_coke_room1_john,room1,0.1\n"
                                 "1,ask_item,,0.9\n2,deliver,room5,0.2\n")
        self.assertEqual(experiments.deliveries_only(t).trial_indices(), [0, 2])
        t = TrialTable.from_text("trial,delivered,room,entropy\n0,0,room1,0.1\n1,1,room2,0.2\n")
        self.assertEqual(experiments.deliveries_only(t).trial_indices(), [1])
        t = TrialTable.from_text("trial,room,entropy\n0,,0.1\n1,room2,0.2\n")
        self.assertEqual(experiments.deliveries_only(t).trial_indices(), [1])

    def test_nav_long_and_wide_formats_agree(self):
        long_rows = ["trial,episode,condition,reward,success"]
        wide_rows = ["trial,episode,reward_with,reward_without"]
        for t in range(3):
            for e in (1, 2):
                long_rows += ["%d,%d,with,%d,1" % (t, e, 10 * t + e),
                              "%d,%d,without,%d,0" % (t, e, -e)]
                wide_rows.append("%d,%d,%d,%d" % (t, e, 10 * t + e, -e))
        e1, r1, s1 = navigation.trial_matrices(TrialTable.from_text("\n".join(long_rows)))
        e2, r2, s2 = navigation.trial_matrices(TrialTable.from_text("\n".join(wide_rows)))
        self.assertEqual(e1, [1, 2])
        self.assertEqual(e1, e2)
        np.testing.assert_array_equal(r1["with"], [[1, 2], [11, 12], [21, 22]])
        np.testing.assert_array_equal(r1["with"], r2["with"])
        np.testing.assert_array_equal(r1["without"], r2["without"])
        self.assertIsNone(s2)
        np.testing.assert_array_equal(s1["with"], np.ones((3, 2)))
        c = navigation.curve_table(e1, r1, s1)
        self.assertEqual(c["mean_with"], [11.0, 12.0])
        self.assertAlmostEqual(c["ci95_with"][0], stats.mean_ci([1, 11, 21]).half)

    def test_nav_missing_cell(self):
        t = TrialTable.from_text("trial,episode,condition,reward\n0,1,with,1\n0,1,without,2\n"
                                 "0,2,with,1\n", "nav.csv")
        with self.assertRaisesRegex(ValueError, "nav.csv: no reward for trial 0, episode 2, "
                                                "condition without"):
            navigation.trial_matrices(t)
        with self.assertRaisesRegex(ValueError, "unknown navigation condition 'maybe'"):
            navigation.condition_of("maybe")


class TableTest(unittest.TestCase):
    def test_renderings(self):
        e = stats.proportion_ci(9, 10)
        t = report.Table("t", "Title", ["name", "value", "rate", "p"],
                         [["a", 1.23456, report.Est(2.0, 0.5), report.P(0.0123)],
                          ["b", float("nan"), report.Est.of(e, "%.3f", asymmetric=True),
                           report.P(1e-9)],
                          ["c", None, None, report.P(float("nan"))]],
                         formats={"value": "%.2f"})
        md = t.markdown()
        self.assertIn("| a | 1.23 | 2.00 ± 0.50 | 0.012 |", md)
        self.assertIn("| b | n/a | 0.900 [%.3f, %.3f] | 1.0e-09 |" % (e.lo, e.hi), md)
        lines = t.csv_text().splitlines()
        self.assertEqual(lines[0], "name,value,rate,rate ci95 lo,rate ci95 hi,p")
        self.assertEqual(lines[1], "a,1.23456,2,1.5,2.5,0.0123")
        self.assertTrue(lines[2].startswith("b,,0.9,%.10g,%.10g," % (e.lo, e.hi)))
        self.assertEqual(lines[3], "c,,,,,")
        txt = t.text()
        self.assertIn("Title", txt)
        self.assertIn("2.00 ± 0.50", txt)
        with self.assertRaisesRegex(ValueError, "2 cells for 4 columns"):
            report.Table("x", "x", ["a", "b", "c", "d"], [[1, 2]])

    def test_verdicts(self):
        self.assertEqual(report.verdict(True, 0.01), "supported")
        self.assertEqual(report.verdict(True, None), "supported")
        self.assertTrue(report.verdict(True, 0.2).startswith("NOT supported (right direction"))
        self.assertTrue(report.verdict(True, math.nan).startswith("NOT supported"))
        self.assertEqual(report.verdict(False, 0.001), "NOT supported (opposite direction)")
        self.assertEqual(report.verdict(False, None), "NOT supported")
        c = report.Claim("x", "claim", "paper", "ours", True, 0.04, alpha=0.01)
        self.assertFalse(c.supported)


class ContextTest(unittest.TestCase):
    def test_trial_count_policy(self):
        ctx = experiments.Context("/tmp", None, scale=0.01)
        self.assertEqual(ctx.trials("exp2"), 100)
        self.assertEqual(ctx.trials("exp1"), 10)
        ctx = experiments.Context("/tmp", None, scale=0.0001, trials={"exp4": 7})
        self.assertEqual(ctx.trials("exp2"), 2)  # at least two
        self.assertEqual(ctx.trials("exp4"), 7)
        ctx = experiments.Context("/tmp", None, quick=True, trials={"exp2": 50},
                                  recorded={"exp5": {"trials": 33}})
        self.assertEqual(ctx.trials("exp2"), 50)
        self.assertEqual(ctx.trials("exp1"), experiments.QUICK["exp1"]["trials"])
        self.assertEqual(ctx.trials("exp5"), 33)
        self.assertEqual(ctx.setting("exp1", "target_episodes"),
                         experiments.QUICK["exp1"]["target_episodes"])
        self.assertEqual(ctx.params["exp5"]["trials"], 33)
        with self.assertRaises(ValueError):
            experiments.Context("/tmp", None, scale=0)

    def test_paper_defaults(self):
        self.assertEqual(experiments.DEFAULTS["exp1"]["trials"], 1000)
        self.assertEqual(experiments.DEFAULTS["exp2"]["trials"], 10000)
        self.assertEqual(experiments.PAPER_TABLE1[0.5]["learned"], (58.44, 0.927, 18.98))
        self.assertEqual(experiments.PAPER_TABLE2[0.7]["room1"], (0.132, 0.050, 0.207))


if __name__ == "__main__":
    unittest.main()


class PolicyReportTest(unittest.TestCase):
    """The dialog policies behind delivery trial sets: certified bounds and forced serves."""

    @staticmethod
    def table(lower, upper, forced):
        rows = "".join("%d,%s,%s,%d\n" % (i, lower, upper, f) for i, f in enumerate(forced))
        return TrialTable.from_text("trial,policy_lower,policy_upper,forced\n" + rows)

    def test_certified_policies_are_reported(self):
        prec = experiments.solver_precision()
        ctx = experiments.Context("/tmp", None)
        t = experiments.policy_report(ctx, "exp2", {"br 0.1 learned": self.table(
            10.0, 10.0 + prec / 2, [0] * 99 + [1])})
        self.assertEqual(t.rows[0][4], "yes")
        rec = ctx.params["exp2"]["policies"]["br 0.1 learned"]
        self.assertAlmostEqual(rec["gap"], prec / 2)
        self.assertAlmostEqual(rec["forced_rate"], 0.01)
        self.assertIn("exceeded by br 0.1 learned", t.note)  # 1 % is not below 1 %
        self.assertNotIn("NOT CERTIFIED", t.note)

    def test_unconverged_policies_are_refused_unless_allowed(self):
        prec = experiments.solver_precision()
        sets = {"br 0.7 outdated": self.table(-30.0, -30.0 + 2 * prec + 5, [0] * 10)}
        with self.assertRaises(experiments.UnconvergedPolicy) as e:
            experiments.policy_report(experiments.Context("/tmp", None), "exp2", sets)
        self.assertIn("br 0.7 outdated", str(e.exception))
        self.assertIn("--allow-unconverged", str(e.exception))
        ctx = experiments.Context("/tmp", None, allow_unconverged=True)
        t = experiments.policy_report(ctx, "exp2", sets)
        self.assertEqual(t.rows[0][4], "no")
        self.assertIn("NOT CERTIFIED", t.note)
        self.assertIn("met in every set", t.note)
        self.assertFalse(ctx.params["exp2"]["policies"]["br 0.7 outdated"]["certified"])
