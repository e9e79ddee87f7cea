"""The trial runner on a Dask distributed cluster (a scheduler and two worker processes on
loopback) gives exactly the tables of the in-process run."""
import os
import shutil
import tempfile
import unittest
import warnings

from krr_eval.runner import Runner, TrialSpec
from testdata import fake_cli

try:
    from distributed import LocalCluster
except ImportError:  # pragma: no cover - python3-distributed is a declared dependency
    LocalCluster = None


@unittest.skipIf(LocalCluster is None, "python3-distributed is not installed "
                 "(tools/install_deps.sh installs it)")
class DaskRunnerTest(unittest.TestCase):
    def setUp(self):
        warnings.filterwarnings("ignore", category=DeprecationWarning, module="tornado")
        self.tmp = tempfile.mkdtemp(prefix="krr_dask_test_")
        self.saved = os.environ.get("KRR_BIN_DIR")
        os.environ["KRR_BIN_DIR"] = fake_cli.make_bin_dir(os.path.join(self.tmp, "bin"))

    def tearDown(self):
        if self.saved is None:
            os.environ.pop("KRR_BIN_DIR", None)
        else:
            os.environ["KRR_BIN_DIR"] = self.saved
        shutil.rmtree(self.tmp, ignore_errors=True)

    def test_dask_matches_local(self):
        specs = [
            # a small solver budget: the test compares runners, not policies
            TrialSpec("d1", "delivery_trials", ["--br", "0.1", "--condition", "outdated",
                                                "--solver-trials", "300"], 5, 17),
            TrialSpec("d7", "delivery_trials", ["--br", "0.7", "--condition", "learned",
                                                "--solver-trials", "300"], 5, 11),
            TrialSpec("nav", "nav_transfer", ["--domain", "office_50x50", "--target-episodes", "3"],
                      5, 5, trials_flag="--trials-out", scratch_flags=("--out",)),
        ]
        local = Runner(workers=1, chunks_per_worker=1, progress=None).run(specs)
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster:
            self.assertTrue(cluster.scheduler_address.startswith("tcp://127.0.0.1:"))
            r = Runner(scheduler=cluster.scheduler_address, chunks_per_worker=3, progress=None)
            try:
                self.assertEqual(r.slots(), 2)
                remote = r.run(specs)
            finally:
                r.close()
        for s in specs:
            self.assertEqual(remote[s.name].to_text(), local[s.name].to_text(), s.name)
        self.assertEqual(len(remote["d1"]), 17)

    def test_unreachable_scheduler_is_a_clear_error(self):
        r = Runner(scheduler="tcp://127.0.0.1:1", progress=None)
        r._connect_timeout = "1s"
        with self.assertRaisesRegex(ConnectionError, "tcp://127.0.0.1:1"):
            r.run([TrialSpec("x", "delivery_trials", [], 1, 2)])


if __name__ == "__main__":
    unittest.main()
