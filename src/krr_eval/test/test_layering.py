"""The include layering of the C++ code (test/check_layering.py), run with the other suites so
that test/run_all.sh counts it: no experiment header in library or node code, no domain module
in a generic one, no ROS header in the core, no toy problem (examples) outside tests and
benchmarks.
"""
import os
import subprocess
import sys
import tempfile
import unittest

from krr_eval import paths

SCRIPT = os.path.join(paths.root(), "test", "check_layering.py")


def run(root=None):
    cmd = [sys.executable, SCRIPT] + (["--root", root] if root else [])
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


class LayeringTest(unittest.TestCase):
    def test_the_repository_is_layered(self):
        r = run()
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("0 violations", r.stdout)

    def test_each_rule_catches_a_bad_include(self):
        # The checker must fail on the includes it exists to forbid, else a green run means nothing.
        files = {
            "src/krr_core/include/krr_core/experiments/trials.h": "",
            "src/krr_core/include/krr_core/kb/domain.h": "",
            "src/krr_core/src/experiments/trials.cpp": '#include "krr_core/experiments/trials.h"\n',
            "src/krr_core/apps/trials.cpp": '#include "krr_core/experiments/trials.h"\n',
            "src/krr_ros/src/nodes/a_node.cpp": '#include "krr_core/experiments/trials.h"\n',
            "src/krr_core/src/dialog/d.cpp": '#include "../experiments/trials.cpp"\n',
            "src/krr_core/src/nav/n.cpp": '#include "krr_core/kb/domain.h"\n',
            "src/krr_core/src/common/c.cpp": "/*\n#include <ros/ros.h>\n*/\n#include <ros/ros.h>\n",
            "src/krr_core/include/krr_core/examples/toy.h": "",
            "src/krr_core/src/examples/toy.cpp": '#include "krr_core/examples/toy.h"\n',
            "src/krr_core/test/pomdp/t.cpp": '#include "krr_core/examples/toy.h"\n',
            "src/krr_core/bench/b.cpp": '#include "krr_core/examples/toy.h"\n',
            "src/krr_core/src/pomdp/p.cpp": '#include "krr_core/examples/toy.h"\n',
            "src/krr_core/src/experiments/e.cpp": '#include "../../include/krr_core/examples/toy.h"\n',
            "src/krr_core/apps/a.cpp": '#include "krr_core/examples/toy.h"\n',
        }
        with tempfile.TemporaryDirectory() as root:
            for rel, text in files.items():
                os.makedirs(os.path.dirname(os.path.join(root, rel)), exist_ok=True)
                with open(os.path.join(root, rel), "w") as f:
                    f.write(text)
            r = run(root)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        out = r.stdout
        self.assertIn("src/krr_ros/src/nodes/a_node.cpp:1: experiments:", out)
        self.assertIn("src/krr_core/src/dialog/d.cpp:1: experiments:", out)
        self.assertIn("src/krr_core/src/nav/n.cpp:1: generic:", out)
        self.assertIn("src/krr_core/src/common/c.cpp:4: ros:", out)
        self.assertIn("src/krr_core/src/pomdp/p.cpp:1: examples:", out)
        self.assertIn("src/krr_core/src/experiments/e.cpp:1: examples:", out)
        self.assertIn("src/krr_core/apps/a.cpp:1: examples:", out)
        # The experiments' own code and apps may use the experiments; tests, benchmarks and the
        # examples library itself the examples.
        self.assertIn("7 violations", out)


if __name__ == "__main__":
    unittest.main()
