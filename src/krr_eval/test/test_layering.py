"""The include layering of the C++ code (test/check_layering.py), run with the other suites so
that test/run_all.sh counts it: no experiment header in library or node code, no domain module
in a generic one, no ROS header in the core, no toy problem (examples) outside tests and
benchmarks, and every module header declaring its code in the module's namespace (krr::<m>).
"""
import functools
import os
import unittest

import checker_support

CHECKER = checker_support.script("check_layering.py")
run = functools.partial(checker_support.run, CHECKER)
run_on_tree = functools.partial(checker_support.run_on_tree, CHECKER)


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
        r = run_on_tree(files)
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

    def test_the_namespace_rule_catches_a_header_in_another_namespace(self):
        # A module's headers declare their code in krr::<module> (common: krr); the checker must
        # fail on code in another module's namespace or none, and not on comments, strings,
        # nested namespaces or std specialisations.
        core = "src/krr_core/"
        files = {
            # violations (4)
            core + "include/krr_core/experiments/trials.h":
                "namespace krr {\nnamespace dialog {\nstruct Trial {};\n}  // namespace dialog\n}\n",
            core + "src/experiments/private_yaml.h":
                "namespace krr {\nnamespace kb {\nnamespace detail {\nint f();\n}\n}\n}\n",
            core + "include/krr_core/nav/global.h":
                "#pragma once\nnamespace krr { namespace nav { struct Grid; } }\nint loose();\n",
            core + "include/krr_core/common/seed.h":
                "namespace krr {\nint seed();\nnamespace kb {\nint wrong();\n}\n}\n",
            # fine
            core + "include/krr_core/kb/domain.h":
                "// namespace dialog {\n#define OPEN {\nnamespace krr {\nnamespace kb {\n"
                "const char* k = \"namespace dialog { }\";\nstruct D { void g() { } };\n}\n}\n",
            core + "include/krr_core/pomdp/nested.h":
                "namespace krr::pomdp::detail {\nint h();\n}\n",
            core + "include/krr_core/mdp/hash.h":
                "namespace krr { namespace mdp { struct S {}; } }\nnamespace std {\n"
                "template <> struct hash<krr::mdp::S> { int operator()() const; };\n}\n",
            core + "include/krr_core/common/helpers.h":
                "namespace krr {\nnamespace detail {\nint g();\n}\n}\n",
            core + "src/kb/not_a_header.cpp": "int main() { return 0; }\n",
        }
        r = run_on_tree(files)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        out = r.stdout
        self.assertIn(core + "include/krr_core/experiments/trials.h:3: namespace: header of "
                      "module 'experiments' declares code in krr::dialog, not in "
                      "krr::experiments", out)
        self.assertIn(core + "src/experiments/private_yaml.h:4: namespace: header of module "
                      "'experiments' declares code in krr::kb::detail", out)
        self.assertIn(core + "include/krr_core/nav/global.h:3: namespace: header of module 'nav' "
                      "declares code in the global namespace, not in krr::nav", out)
        self.assertIn(core + "include/krr_core/common/seed.h:4: namespace: header of module "
                      "'common' declares code in krr::kb, not in krr", out)
        self.assertIn("4 violations", out)


if __name__ == "__main__":
    unittest.main()
