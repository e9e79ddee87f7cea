"""The README's generated blocks: rendered from docs/ only, and in sync with it."""
import json
import os
import shutil
import tempfile
import unittest

from krr_eval import record_results


class RecordResultsTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="krr_record_")
        self.saved = (record_results.DOCS, record_results.README, record_results.SESSION,
                      record_results.SESSION_README)
        record_results.DOCS = os.path.join(self.tmp, "eval")
        record_results.README = os.path.join(self.tmp, "README.md")
        record_results.SESSION_README = record_results.README  # both blocks in one file here
        record_results.SESSION = os.path.join(self.tmp, "session.txt")
        os.makedirs(record_results.DOCS)
        claims = [
            {"experiment": "exp2", "claim": "learned beats outdated at br 0.7",
             "verdict": "supported"},
            {"experiment": "exp2", "claim": "fulfilment flat | across br",
             "verdict": "not supported"},
            {"experiment": "exp5", "claim": "merged beats the pick", "verdict": "supported"},
        ]
        params = {"seed": 3, "trials_scale": 1, "quick": False,
                  "times_s": {"exp2": 35.4, "exp5": 8.6}}
        models = {"trials": 40000, "brs": {"0.7": {"max_abs_error": 0.0151,
                          "policy": {"lower": 12.5, "upper": 40.25, "gap": 27.75},
                          "forced_serve_rate": 0.0067},
                  "0.1": {"max_abs_error": 0.0062, "policy": {}}}}
        for name, obj in (("claims.json", claims), ("params.json", params),
                          ("model_report.json", models)):
            with open(os.path.join(record_results.DOCS, name), "w") as f:
                json.dump(obj, f)
        with open(record_results.SESSION, "w") as f:
            f.write("$ rostopic pub ...\n\"Which item is it?\"\n")
        with open(record_results.README, "w") as f:
            f.write("# title\n\n%s\nSTALE-RESULTS\n%s\n\nmiddle\n%s\nSTALE-SESSION\n%s\ntail\n" % (
                record_results.BEGIN, record_results.END, record_results.SESSION_BEGIN,
                record_results.SESSION_END))

    def tearDown(self):
        (record_results.DOCS, record_results.README, record_results.SESSION,
         record_results.SESSION_README) = self.saved
        shutil.rmtree(self.tmp)

    def readme(self):
        with open(record_results.README) as f:
            return f.read()

    def test_block_carries_the_recorded_numbers(self):
        text = record_results.render()
        self.assertIn("seed 3, default trial counts): 2 of 3 claims supported", text)
        self.assertIn("Evaluation time 44 s wall (exp2 35 s, exp5 9 s; ", text)
        self.assertIn("| exp2 | 1 / 2 |", text)
        self.assertIn("fulfilment flat \\| across br: no", text)  # a table cell stays one cell
        self.assertIn("| 0.7 | 0.015 | [12.50, 40.25] (27.75) | 0.67 % |", text)
        self.assertIn("| 0.1 | 0.006 | [nan, nan] (nan) | - |", text)
        self.assertLess(text.index("| 0.1 |"), text.index("| 0.7 |"))
        self.assertIn("the share of 40,000 deliveries", text)

    def test_check_fails_on_drift_and_passes_after_rewriting(self):
        self.assertEqual(record_results.main(["--check"]), 1)
        self.assertEqual(record_results.main([]), 0)
        text = self.readme()
        self.assertNotIn("STALE-RESULTS", text)
        self.assertNotIn("STALE-SESSION", text)
        self.assertTrue(text.startswith("# title\n") and text.endswith("tail\n"))
        self.assertIn('"Which item is it?"', text)
        self.assertEqual(record_results.main(["--check"]), 0)
        with open(os.path.join(record_results.DOCS, "params.json"), "w") as f:
            json.dump({"seed": 4, "times_s": {}}, f)
        self.assertEqual(record_results.main(["--check"]), 1)

    def test_missing_markers_are_an_error(self):
        with open(record_results.README, "w") as f:
            f.write("no markers\n")
        with self.assertRaises(SystemExit):
            record_results.main([])


class RepositoryReadmeTest(unittest.TestCase):
    def test_readme_matches_the_recorded_run(self):
        self.assertTrue(os.path.exists(os.path.join(record_results.DOCS, "claims.json")),
                        "docs/eval is missing: run `rosrun krr_eval record_results --from "
                        "<eval out>`")
        self.assertEqual(record_results.main(["--check"]), 0,
                         "the READMEs' generated blocks differ from docs/")


if __name__ == "__main__":
    unittest.main()
