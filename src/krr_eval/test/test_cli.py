"""The package's programs (scripts/): `--help` exits 0, prints the usage and runs nothing, from
any directory; the repository root is found without the current directory."""
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

from krr_eval import paths

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts")
PROGRAMS = ("evaluate", "record_results", "bench_evaluate", "nav_transfer", "bag_table")


class CliTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="krr_cli_")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def test_every_program_is_a_script(self):
        self.assertEqual(sorted(PROGRAMS), sorted(os.listdir(SCRIPTS)))

    def test_help_exits_0_and_runs_nothing(self):
        env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:1")
        env.pop("KRR_ROOT", None)
        for name in PROGRAMS:
            with self.subTest(program=name):
                res = subprocess.run([sys.executable, os.path.join(SCRIPTS, name), "--help"],
                                     cwd=self.tmp, env=env, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, universal_newlines=True,
                                     timeout=60)
                self.assertEqual(res.returncode, 0, res.stderr)
                self.assertTrue(res.stdout.startswith("usage: " + name), res.stdout[:200])
                self.assertEqual(os.listdir(self.tmp), [], "--help wrote files")

    def test_tools_scripts_help_prints_their_header_and_runs_nothing(self):
        tools = os.path.join(paths.root(), "tools")
        scripts = sorted(f for f in os.listdir(tools) if f.endswith(".sh"))
        self.assertIn("run_main.sh", scripts)
        for name in scripts:
            path = os.path.join(tools, name)
            with open(path) as f:
                lines = f.read().split("\n")[1:]
            header = []
            for line in lines:
                if not line.startswith("#"):
                    break
                header.append(line[2:] if line.startswith("# ") else line[1:])
            for flag in ("--help", "-h"):
                with self.subTest(script=name, flag=flag):
                    # KRR_OUT in the test's folder: a script that ran would write there.
                    env = dict(os.environ, KRR_OUT=os.path.join(self.tmp, "out"))
                    res = subprocess.run(["bash", path, flag], cwd=self.tmp, env=env,
                                         stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                         universal_newlines=True, timeout=30)
                    self.assertEqual(res.returncode, 0, res.stderr)
                    self.assertEqual(res.stdout, "\n".join(header) + "\n")
                    self.assertEqual(res.stderr, "")
                    self.assertEqual(os.listdir(self.tmp), [])

    def test_root_is_the_repository(self):
        root = paths.root()
        self.assertTrue(os.path.isfile(os.path.join(root, "config", "dialog.yaml")))
        self.assertTrue(os.path.isdir(os.path.join(root, "src", "krr_eval")))
        old = os.getcwd()
        try:
            os.chdir(self.tmp)
            self.assertEqual(paths.find_root(), root)
        finally:
            os.chdir(old)


if __name__ == "__main__":
    unittest.main()
