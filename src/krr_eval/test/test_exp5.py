"""Experiment 5 (new circumstances) on made-up trial tables: tables, claims with their generated
reasons, the old minimal column set, errors, and the trial spec the experiment asks for."""
import random
import re
import tempfile
import unittest

from krr_eval import experiments, stats
from krr_eval.trials import TrialTable

SETTINGS = ("morning", "noon", "afternoon")
PAIRS = [("morning", "noon"), ("morning", "afternoon"), ("noon", "afternoon")]


def fake_table(own_in, own_out, merged, n=900, seed=1, runs=5):
    """Trials as new_circumstances writes them: each setting's own controller succeeds with
    probability own_in[s] in its own setting and own_out elsewhere; the merged one with
    `merged`. Exact columns are those probabilities."""
    r = random.Random(seed)
    header = ["trial", "learning_run", "possible_settings", "true_setting", "baseline_pick",
              "success_merged", "success_baseline", "success_oracle"]
    header += ["success_own_" + s for s in SETTINGS]
    header += ["steps_merged", "steps_baseline", "steps_oracle", "p_merged", "p_baseline",
               "p_oracle"]
    header += ["p_own_" + s for s in SETTINGS] + ["p_self_" + s for s in SETTINGS]
    header += ["learned_pairs_" + s for s in SETTINGS]
    lines = [",".join(header)]
    for i in range(n):
        pair = PAIRS[r.randrange(3)]
        truth, pick = r.choice(pair), r.choice(pair)
        p_own = {s: own_in[s] if s == truth else own_out for s in SETTINGS}
        u = r.random()  # common random numbers: one uniform decides every controller
        ok = {s: int(u < p_own[s]) for s in SETTINGS}
        row = [i, i % runs, "+".join(pair), truth, pick, int(u < merged), ok[pick], ok[truth]]
        row += [ok[s] for s in SETTINGS] + [50, 50, 50, merged, p_own[pick], p_own[truth]]
        row += [p_own[s] for s in SETTINGS] + [own_in[s] for s in SETTINGS] + [1000] * 3
        lines.append(",".join(str(x) for x in row))
    return TrialTable.from_text("\n".join(lines) + "\n", "fake.csv")


def by_name(tables):
    return {t.name: t for t in tables}


class PaperLikeTest(unittest.TestCase):
    """Own controllers at 50% in their own setting and 4% out of it, merged 84%: the paper's
    26.8% vs 83.8% is what a random pick gets."""

    @classmethod
    def setUpClass(cls):
        cls.t = fake_table({s: 0.5 for s in SETTINGS}, 0.04, 0.84)
        cls.tables, cls.claims, cls.notes = experiments.exp5_analysis(cls.t)

    def test_claims_supported_with_reasons(self):
        self.assertEqual(len(self.claims), 3)
        for c in self.claims:
            self.assertEqual(c.experiment, "5 new circ.")
            self.assertTrue(c.reason and len(c.reason) > 40, c.reason)
            # one or two sentences
            self.assertLessEqual(len(re.findall(r"\. [A-Z]", c.reason)), 1, c.reason)
        beats, oracle, rates = self.claims
        self.assertTrue(beats.supported, beats.verdict)
        self.assertTrue(oracle.supported, oracle.verdict)  # merged 84% > oracle 50%
        self.assertTrue(rates.supported, (rates.ours, rates.verdict))
        self.assertIn("would reach 26.8% with wrong picks at about", rates.reason)
        self.assertNotIn("cannot fall below", rates.reason)

    def test_tables(self):
        t = by_name(self.tables)
        self.assertEqual(set(t), {"exp5_new_circumstances", "exp5_by_setting",
                                  "exp5_exact_matrix"})
        main = t["exp5_new_circumstances"]
        self.assertEqual([r[0] for r in main.rows][:3], list(experiments.EXP5_LABELS.values()))
        self.assertEqual(len(main.rows), 6)  # + the three own controllers
        self.assertIn("over learning runs (mean, 95% CI)", main.columns)
        # the paper's numbers next to ours
        self.assertEqual(main.rows[0][-1], 0.838)
        self.assertEqual(main.rows[1][-1], 0.268)
        self.assertIn("success rate (95% CI) ci95 lo", main.csv_text().splitlines()[0])
        by = t["exp5_by_setting"]
        self.assertEqual(len(by.rows), 6)
        self.assertEqual([r[:2] for r in by.rows[:2]], [["morning or noon", "morning"],
                                                        ["morning or noon", "noon"]])
        # A group's merged rate is the share of its trials where the merged one succeeded.
        idx = [i for i, (p, u) in enumerate(zip(self.t.strings("possible_settings"),
                                                self.t.strings("true_setting")))
               if p == "noon+afternoon" and u == "afternoon"]
        row = [r for r in by.rows if r[:2] == ["noon or afternoon", "afternoon"]][0]
        ok = [self.t.bools("success_merged")[i] for i in idx]
        self.assertEqual(row[2], len(idx))
        self.assertAlmostEqual(row[3].mean, sum(ok) / float(len(ok)))
        self.assertAlmostEqual(row[3].lo, stats.proportion_ci(sum(ok), len(ok)).lo)
        self.assertAlmostEqual(row[-1], (0.5 + 0.04) / 2)  # the pick's expectation
        m = t["exp5_exact_matrix"]
        self.assertEqual(m.columns, ["controller", "in morning", "in noon", "in afternoon"])
        self.assertEqual([r[1:] for r in m.rows[:3]],
                         [[0.5, 0.04, 0.04], [0.04, 0.5, 0.04], [0.04, 0.04, 0.5]])
        self.assertEqual(m.rows[3][0], "merged morning or noon")
        self.assertIsNone(m.rows[3][3])  # morning or noon is never the afternoon

    def test_notes(self):
        self.assertTrue(any("common random numbers" in n for n in self.notes))
        self.assertTrue(any("5 learning run(s)" in n for n in self.notes))


class OursLikeTest(unittest.TestCase):
    """Own controllers good in their own setting (85%), a wrong pick 10%, merged 60%."""

    @classmethod
    def setUpClass(cls):
        t = fake_table({"morning": 0.85, "noon": 0.75, "afternoon": 0.65}, 0.10, 0.60, seed=2)
        cls.tables, cls.claims, _ = experiments.exp5_analysis(t)

    def test_verdicts_and_reasons(self):
        beats, oracle, rates = self.claims
        self.assertTrue(beats.supported, beats.verdict)  # 60% vs about 43%
        self.assertEqual(oracle.verdict, "NOT supported (opposite direction)")
        self.assertIn("worst when the robot may be in", oracle.reason)
        self.assertFalse(rates.supported)
        # Generated from the numbers: the oracle's half alone exceeds 26.8%.
        self.assertIn("cannot fall below 37.5% even if every wrong pick failed", rates.reason)
        self.assertIn("oracle 75.0% (morning 85.0%, noon 75.0%, afternoon 65.0%)", rates.reason)
        self.assertIn("wrong picks 10.0%", rates.reason)
        self.assertIn("the pick expects 42.5%", rates.reason)
        self.assertIn("merged 60.0%, below the oracle", rates.reason)
        self.assertIn("more than 26.8% for every pair and true setting", rates.reason)
        for c in self.claims:  # one or two sentences
            self.assertLessEqual(len(re.findall(r"\. [A-Z]", c.reason)), 1, c.reason)

    def test_reversed_effect_reason(self):
        t = fake_table({s: 0.8 for s in SETTINGS}, 0.7, 0.3, seed=3)
        beats = experiments.exp5_analysis(t)[1][0]
        self.assertEqual(beats.verdict, "NOT supported (opposite direction)")
        self.assertIn("Merging did not help", beats.reason)
        self.assertIn("it gains most when the robot may be in", beats.reason)

    def test_no_effect_reason(self):
        t = fake_table({s: 0.6 for s in SETTINGS}, 0.6, 0.6, n=60, seed=4)
        beats = experiments.exp5_analysis(t)[1][0]
        self.assertFalse(beats.supported)
        self.assertTrue("within the noise" in beats.reason or "did not help" in beats.reason,
                        beats.reason)


class MinimalColumnsTest(unittest.TestCase):
    def test_old_format(self):
        # What the fake CLI of the suite tests writes (no draw, no own controllers).
        text = "trial,setting,success_merged,success_baseline,success_oracle,p_merged," \
               "p_baseline,p_oracle\n"
        text += "".join("%d,noon,%d,%d,1,0.8,0.3,0.9\n" % (i, i % 5 != 0, i % 3 == 0)
                        for i in range(30))
        tables, claims, notes = experiments.exp5_analysis(TrialTable.from_text(text))
        self.assertEqual([t.name for t in tables], ["exp5_new_circumstances", "exp5_by_setting"])
        self.assertEqual(len(tables[0].rows), 3)
        self.assertEqual(len(claims), 3)
        self.assertTrue(all(c.reason for c in claims))
        self.assertEqual(notes, [])

    def test_errors_name_file_and_column(self):
        with self.assertRaisesRegex(ValueError, "x.csv: no column 'success_baseline'"):
            experiments.exp5_analysis(TrialTable.from_text("trial,success_merged\n0,1\n", "x.csv"))
        t = fake_table({s: 0.5 for s in SETTINGS}, 0.1, 0.5, n=3)
        t.rows[1][t.header.index("true_setting")] = "evening"
        with self.assertRaisesRegex(ValueError, "data row 2: true setting 'evening'"):
            experiments.exp5_analysis(t)


class SpecTest(unittest.TestCase):
    class Runner(object):
        def __init__(self, table):
            self.table, self.specs = table, []

        def run(self, specs, label):
            self.specs += specs
            return {s.name: self.table for s in specs}

    def test_spec(self):
        t = fake_table({s: 0.5 for s in SETTINGS}, 0.1, 0.5, n=20)
        for quick, args, n in ((True, ("--learning-runs", "3"), 60), (False, (), 1000)):
            runner = self.Runner(t)
            ctx = experiments.Context(tempfile.gettempdir(), runner, seed=4, quick=quick)
            res = experiments.exp5_new_circumstances(ctx)
            spec = runner.specs[0]
            self.assertEqual((spec.program, spec.args, spec.seed, spec.trials),
                             ("new_circumstances", args, 4, n))
            # One process learns every learning run once (trials cost far less than learning).
            self.assertEqual(spec.min_chunk, experiments.EXP5_MIN_CHUNK)
            self.assertEqual(len(res.claims), 3)
            self.assertEqual(ctx.params["exp5"]["learning_runs"], 3 if quick else None)


if __name__ == "__main__":
    unittest.main()
