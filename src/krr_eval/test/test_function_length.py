"""The function length check of the C++ code (test/check_function_length.py), run with the other
suites so that test/run_all.sh counts it: no function in src/ outside tests is longer than 120
lines unless test/function_length_allowlist.txt lists it, and every entry there is still long.
"""
import functools
import unittest

import checker_support

CHECKER = checker_support.script("check_function_length.py")
run = functools.partial(checker_support.run, CHECKER)
run_on_tree = functools.partial(checker_support.run_on_tree, CHECKER)


def body(lines):
    """Statements filling `lines` lines, with braces in comments and literals that a naive
    brace count would take for code."""
    tricky = ['  int a = 0;  // {', '  const char* s = "}{";', "  char c = '{';",
              '  /* } */ int b = 1;', '  auto f = [](int x) { return x; };']
    return "\n".join(tricky[i % len(tricky)] for i in range(lines))


def function(signature, length):
    """A function of exactly `length` lines (signature line to closing brace)."""
    return "%s {\n%s\n}\n" % (signature, body(length - 2))


class FunctionLengthTest(unittest.TestCase):
    def test_the_repository_passes(self):
        r = run()
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn(", 0 problems", r.stdout)

    def test_a_long_function_fails_and_its_location_and_length_are_reported(self):
        files = {
            # fails: 121 lines, its signature on line 3
            "src/pkg/src/a.cpp": "#include <x>\nnamespace n {\n" + function("int tooLong()", 121)
                                 + function("int fine()", 120) + "}  // namespace n\n",
            # fails: an in-class member function of a header, qualified by its class
            "src/pkg/include/b.h": "#pragma once\nnamespace n {\nclass Big {\n public:\n"
                                   + function("  void run(int x) const", 130) + "};\n}\n",
            # fails: a constructor with a brace-initialised member
            "src/pkg/src/c.cpp": function("Thing::Thing(int x) : a_{x}, b_(x)", 125),
            # fine: tests are not checked
            "src/pkg/test/test_a.cpp": function("void longTest()", 300),
            # fine: a long class or namespace of short functions is not a function
            "src/pkg/src/d.cpp": "namespace m {\nstruct S {\n" + "".join(
                function("  int f%d()" % i, 10) for i in range(30)) + "};\nenum class E {\n"
                + ",\n".join("  k%d" % i for i in range(150)) + "\n};\n}\n",
            # fine: a brace initialiser at namespace scope is not a function
            "src/pkg/src/e.cpp": "const int kTable[] = {\n" + ",\n".join(
                str(i) for i in range(200)) + "\n};\n",
            # not C++: ignored
            "src/pkg/src/f.py": "x = 1\n" * 300,
        }
        r = run_on_tree(files)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        out = r.stdout
        self.assertIn("src/pkg/src/a.cpp:3: tooLong is 121 lines, longer than 120", out)
        self.assertIn("src/pkg/include/b.h:5: Big::run is 130 lines, longer than 120", out)
        self.assertIn("src/pkg/src/c.cpp:1: Thing::Thing is 125 lines, longer than 120", out)
        self.assertNotIn("fine", out)
        self.assertNotIn("longTest", out)
        self.assertNotIn("d.cpp", out)
        self.assertNotIn("e.cpp", out)
        self.assertIn("3 longer than 120 lines (0 allowlisted), 3 problems", out)

    def test_the_allowlist_admits_a_long_function_and_can_only_shrink(self):
        allow = ("# comment\n"
                 "src/pkg/src/a.cpp:stillLong  # not yet split (issue 25)\n"
                 "src/pkg/src/a.cpp:nowShort  # not yet split (issue 25)\n"
                 "src/pkg/src/a.cpp:gone  # not yet split (issue 25)\n")
        files = {
            "src/pkg/src/a.cpp": (function("void stillLong()", 200)
                                  + function("void nowShort()", 40)),
            "test/function_length_allowlist.txt": allow,
        }
        r = run_on_tree(files)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        out = r.stdout
        self.assertIn("allowlisted: src/pkg/src/a.cpp:1: stillLong is 200 lines", out)
        self.assertIn("test/function_length_allowlist.txt:3: src/pkg/src/a.cpp:nowShort is 40 "
                      "lines now, within 120: remove the entry", out)
        self.assertIn("test/function_length_allowlist.txt:4: src/pkg/src/a.cpp:gone names no "
                      "function", out)
        self.assertIn("1 longer than 120 lines (1 allowlisted), 2 problems", out)
        # With the stale entries removed, the allowlisted long function passes.
        files["test/function_length_allowlist.txt"] = allow.split("src/pkg/src/a.cpp:nowShort")[0]
        r = run_on_tree(files)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        self.assertIn("0 problems", r.stdout)


if __name__ == "__main__":
    unittest.main()
