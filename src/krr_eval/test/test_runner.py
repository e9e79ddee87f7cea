"""Unit tests of krr_eval.runner with a fake CLI: chunking, determinism for any number of
workers, error reporting, recording and replay."""
import io
import json
import collections
import os
import shutil
import tempfile
import unittest

from krr_eval import runner
from krr_eval.runner import Runner, TrialSpec
from krr_eval.trials import TrialTable
from testdata import fake_cli


def delivery(name="d", trials=23, seed=7, br="0.5"):
    return TrialSpec(name, "delivery_trials", ["--br", br, "--condition", "learned"], seed, trials)


class FakeBinTest(unittest.TestCase):
    """Base: a temp dir with fake programs as KRR_BIN_DIR."""

    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="krr_runner_test_")
        self.saved = {k: os.environ.get(k)
                      for k in ("KRR_BIN_DIR", "FAKE_KRR_MODE", "FAKE_KRR_LOG")}
        os.environ["KRR_BIN_DIR"] = fake_cli.make_bin_dir(os.path.join(self.tmp, "bin"))
        os.environ.pop("FAKE_KRR_MODE", None)
        os.environ["FAKE_KRR_LOG"] = os.path.join(self.tmp, "calls.log")

    def tearDown(self):
        for k, v in self.saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        shutil.rmtree(self.tmp, ignore_errors=True)

    def calls(self):
        with open(os.environ["FAKE_KRR_LOG"]) as f:
            return f.read().splitlines()


class SplitTest(unittest.TestCase):
    def test_split_covers_range(self):
        self.assertEqual(runner.split(10, 3), [(0, 4), (4, 3), (7, 3)])
        self.assertEqual(runner.split(2, 5), [(0, 1), (1, 1)])
        self.assertEqual(runner.split(1, 1), [(0, 1)])
        for n in (1, 7, 100):
            for c in (1, 3, 8, 200):
                parts = runner.split(n, c)
                self.assertEqual(sum(k for _, k in parts), n)
                self.assertEqual([b for b, _ in parts], [sum(k for _, k in parts[:j])
                                                          for j in range(len(parts))])
        with self.assertRaises(ValueError):
            runner.split(0, 1)

    def test_spec_validation(self):
        with self.assertRaisesRegex(ValueError, "positive"):
            TrialSpec("x", "p", [], 1, 0)
        with self.assertRaisesRegex(ValueError, "file stem"):
            TrialSpec("a/b", "p", [], 1, 3)


class DeterminismTest(FakeBinTest):
    def run_with(self, workers, cpw=4, specs=None):
        r = Runner(workers=workers, chunks_per_worker=cpw, progress=None)
        return {k: t.to_text() for k, t in r.run(specs or [delivery()]).items()}

    def test_same_table_for_any_worker_count(self):
        one = self.run_with(1, cpw=1)
        self.assertEqual(len(self.calls()), 1)
        for w, cpw in ((2, 1), (3, 4), (8, 3)):
            self.assertEqual(self.run_with(w, cpw), one, "workers=%d chunks/worker=%d" % (w, cpw))
        # more than one chunk really ran (otherwise the comparison proves nothing)
        self.assertGreater(len(self.calls()), 10)
        t = TrialTable.from_text(one["d"])
        self.assertEqual(t.trial_indices(), list(range(23)))
        self.assertEqual(t.header[:3], ["trial", "room", "reward"])

    def test_several_sets_and_multi_row_trials(self):
        specs = [delivery("a", 9), delivery("b", 5, br="0.1"),
                 TrialSpec("nav", "nav_transfer", ["--domain", "office_30x30",
                                                   "--target-episodes", "4"], 3, 6,
                           trials_flag="--trials-out", scratch_flags=("--out",))]
        one = self.run_with(1, cpw=1, specs=specs)
        three = self.run_with(3, cpw=3, specs=specs)
        self.assertEqual(one, three)
        nav = TrialTable.from_text(one["nav"])
        self.assertEqual(len(nav), 6 * 4 * 2)
        self.assertEqual(nav.trial_indices(), sorted(nav.trial_indices()))
        self.assertNotEqual(one["a"], one["b"])

    def test_prefetched_sets_give_the_same_tables_and_run_once(self):
        specs = [delivery("a", 9), delivery("b", 5, br="0.1"), delivery("c", 7, br="0.7")]
        plain = self.run_with(2, specs=specs)

        def prefetched(twice):
            before = len(self.calls())
            r = Runner(workers=2, chunks_per_worker=4, progress=None)
            try:
                r.prefetch(specs[:2])
                if twice:
                    r.prefetch(specs[:1])  # already started: not started again
                got = {k: t.to_text() for k, t in r.run(specs[1:]).items()}  # b waits, c runs
                got.update({k: t.to_text() for k, t in r.run(specs[:1]).items()})
                ran = len(self.calls()) - before
                r.run(specs)  # all cached now
                self.assertEqual(len(self.calls()) - before, ran)
            finally:
                r.close()
            return got, ran

        once, ran_once = prefetched(False)
        twice, ran_twice = prefetched(True)
        self.assertEqual(once, plain)
        self.assertEqual(twice, plain)
        self.assertEqual(ran_twice, ran_once)
        self.assertGreater(ran_once, 3, "the sets were split into chunks")
        r2 = Runner(workers=1, progress=None)
        try:
            r2.prefetch([delivery("a", 9)])
            with self.assertRaisesRegex(ValueError, "different settings"):
                r2.run([delivery("a", 10)])
        finally:
            r2.close()

    def test_a_failed_prefetched_chunk_fails_only_its_set(self):
        os.environ["FAKE_KRR_MODE"] = "fail"
        r = Runner(workers=2, progress=None)
        try:
            r.prefetch([delivery("a", 4)])
            with self.assertRaisesRegex(RuntimeError, "delivery_trials failed"):
                r.run([delivery("a", 4)])
            os.environ.pop("FAKE_KRR_MODE")
            self.assertEqual(len(r.run([delivery("b", 4)])["b"]), 4)
        finally:
            r.close()

    def test_min_chunk_limits_processes_not_results(self):
        big = [TrialSpec("d", "delivery_trials", ["--br", "0.5", "--condition", "learned"], 7,
                         23, min_chunk=10)]
        self.assertEqual(self.run_with(4, cpw=4, specs=big), self.run_with(1, cpw=1))
        self.assertEqual(len(self.calls()), 2 + 1)  # 23 // 10 chunks, then the reference run
        with self.assertRaisesRegex(ValueError, "min_chunk"):
            TrialSpec("x", "p", [], 1, 3, min_chunk=0)

    def test_seed_changes_table(self):
        a = self.run_with(2, specs=[delivery(seed=1)])
        b = self.run_with(2, specs=[delivery(seed=2)])
        self.assertNotEqual(a, b)

    def test_cli_receives_contract_options(self):
        self.run_with(2, cpw=1, specs=[delivery(trials=4)])
        calls = sorted(self.calls())
        self.assertEqual(len(calls), 2)
        self.assertIn("--br 0.5 --condition learned --seed 7 --trials 2 --trial-begin 0 "
                      "--threads 1 --out", calls[0])
        self.assertIn("--trial-begin 2", calls[1])


    def test_single_chunk_gets_the_idle_slots_as_threads(self):
        one = [TrialSpec("d", "delivery_trials", ["--br", "0.5", "--condition", "learned"], 7,
                         6, min_chunk=100)]
        self.assertEqual(self.run_with(2, specs=one), self.run_with(1, specs=one))
        calls = self.calls()
        self.assertIn("--threads 2", calls[0])
        self.assertIn("--threads 1", calls[1])

    def test_chunks_are_split_and_ordered_by_cost(self):
        cheap = TrialSpec("a", "delivery_trials", [], 1, 1200)
        dear = TrialSpec("b", "delivery_trials", [], 1, 1200, cost=3.0)
        runner = Runner(workers=2, chunks_per_worker=4, progress=None)
        jobs, total = runner._plan([cheap, dear])
        self.assertEqual(total, 2400)
        per = collections.Counter(j[0].name for j in jobs)
        self.assertEqual((per["a"], per["b"]), (2, 6))  # equal work per chunk: 600 units
        work = [j[3] * j[0].cost for j in jobs]
        self.assertEqual(work, sorted(work, reverse=True))
        # the first chunk of every set before any set's second one (equal work)
        self.assertEqual([(j[0].name, j[2]) for j in jobs[:2]], [("a", 0), ("b", 0)])
        with self.assertRaisesRegex(ValueError, "cost"):
            TrialSpec("x", "p", [], 1, 3, cost=0)


class ErrorTest(FakeBinTest):
    def run_mode(self, mode, workers=2):
        os.environ["FAKE_KRR_MODE"] = mode
        return Runner(workers=workers, progress=None).run([delivery(trials=6)])

    def test_cli_failure_names_program_and_stderr(self):
        with self.assertRaisesRegex(RuntimeError, r"(?s)delivery_trials failed with exit code 3.*"
                                    r"config/x.yaml line 3"):
            self.run_mode("fail")

    def test_header_mismatch(self):
        with self.assertRaisesRegex(ValueError, "differs from the first chunk"):
            self.run_mode("bad_header")

    def test_missing_trial(self):
        with self.assertRaisesRegex(ValueError, r"missing \[1\]"):
            self.run_mode("skip_trial", workers=1)

    def test_missing_program(self):
        with self.assertRaisesRegex(FileNotFoundError, "no_such_cli"):
            Runner(workers=1, progress=None).run([TrialSpec("x", "no_such_cli", [], 1, 2)])

    def test_bad_cells_name_line_and_column(self):
        t = TrialTable.from_text("trial,reward\n0,1.5\n1,abc\n", "f.csv")
        with self.assertRaisesRegex(ValueError, "f.csv data row 2 column 'reward': 'abc'"):
            t.floats("reward")
        with self.assertRaisesRegex(ValueError, r"no column 'qa' \(columns: trial, reward\)"):
            t.floats("qa")
        with self.assertRaisesRegex(ValueError, "line 3: 3 fields"):
            TrialTable.from_text("trial,reward\n0,1\n1,2,3\n", "g.csv")
        with self.assertRaisesRegex(ValueError, "empty"):
            TrialTable.from_text("\n", "h.csv")


class RecordReplayTest(FakeBinTest):
    def test_record_then_replay_without_running(self):
        out = os.path.join(self.tmp, "out")
        r = Runner(workers=2, record_dir=out, progress=None)
        tables = r.run([delivery(), delivery("e", 4)])
        self.assertTrue(os.path.exists(os.path.join(out, "trials", "d.csv")))
        rec = r.records["d"]
        self.assertEqual((rec["seed"], rec["trials"], rec["rows"]), (7, 23, 23))
        with open(os.path.join(out, "params.json"), "w") as f:
            json.dump({"trial_sets": r.records}, f)
        n_calls = len(self.calls())
        os.environ["FAKE_KRR_MODE"] = "fail"  # any CLI call would now fail
        again = Runner(workers=1, record_dir=os.path.join(self.tmp, "copy"), replay_dir=out,
                       progress=None).run([delivery()])
        self.assertEqual(len(self.calls()), n_calls)
        self.assertEqual(again["d"].to_text(), tables["d"].to_text())
        self.assertTrue(os.path.exists(os.path.join(self.tmp, "copy", "trials", "d.csv")))
        # different settings than recorded, or a set never recorded: clear errors
        with self.assertRaisesRegex(ValueError, "recorded with seed = 7"):
            Runner(replay_dir=out, progress=None).run([delivery(seed=8)])
        with self.assertRaisesRegex(FileNotFoundError, "zzz.csv is missing"):
            Runner(replay_dir=out, progress=None).run([delivery("zzz")])
        with self.assertRaisesRegex(FileNotFoundError, "no trials/ folder"):
            Runner(replay_dir=self.tmp, progress=None)

    def test_cache_reuses_sets_within_a_run(self):
        r = Runner(workers=1, chunks_per_worker=1, progress=None)
        r.run([delivery()])
        r.run([delivery()])
        self.assertEqual(len(self.calls()), 1)
        with self.assertRaisesRegex(ValueError, "different settings"):
            r.run([delivery(seed=3)])


class ProgressTest(unittest.TestCase):
    def test_plain_stream_prints_at_most_every_decile(self):
        s = io.StringIO()
        p = runner.Progress(100, "exp", s)
        for _ in range(100):
            p.update(1)
        p.finish()
        lines = s.getvalue().splitlines()
        self.assertLessEqual(len(lines), 12)
        self.assertIn("[exp]", lines[-1])
        self.assertIn("100% 100/100 trials", lines[-1])


if __name__ == "__main__":
    unittest.main()
