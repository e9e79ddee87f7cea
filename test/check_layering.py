#!/usr/bin/python3
"""Check the include layering and module namespaces of the C++ code (issue 14).
Exit 1 and list every violation.

Layers of krr_core:
  generic      common, plog, mdp, nav, pomdp
  domain       kb, dialog, site
  examples     krr_examples: toy problems (Tiger, grid world, grid programs), for tests and
               benchmarks only
  experiments  krr_experiments: the paper's experiments, for apps, benchmarks and tests only

Rules, checked on every #include of every C/C++ file of the repository (outside catkin_ws/):
  1. experiments: only src/krr_core/{src,include/krr_core}/experiments, apps/, bench/ and test/
     may include an experiment header, so library and node code never depends on an experiment;
  2. generic: library code of a generic module (src/<m>/, include/krr_core/<m>/) includes no
     domain module and no experiment;
  3. ros: nothing in src/krr_core includes a ROS header (the core builds without ROS);
  4. examples: only src/krr_core/{src,include/krr_core}/examples, bench/ and test/ may include
     an examples header, so no library, experiment, app or node code runs on a toy problem.
Quoted includes are also resolved relative to the including file, so "../experiments/x.h"
counts as an experiment header.
And one rule on what a header declares:
  5. namespace: every header of a module (include/krr_core/<m>/, and the private ones in
     src/<m>/) declares its code in namespace krr::<m> or a namespace nested in it (common:
     krr, but not in another module's namespace), so a name's namespace says which library
     holds it. Explicit specialisations of std or YAML templates (`template <>` in those
     namespaces, where the language puts them) are allowed.

Usage: check_layering.py [--root REPO]   (default: the repository holding this script)
"""
import argparse
import os
import re
import sys

CORE = "src/krr_core"
GENERIC = {"common", "plog", "mdp", "nav", "pomdp"}
DOMAIN = {"kb", "dialog", "site"}
EXPERIMENTS = "experiments"
EXAMPLES = "examples"
MODULES = GENERIC | DOMAIN | {EXPERIMENTS, EXAMPLES}
# Code that may use the experiments (paths relative to the repository root).
EXPERIMENT_USERS = (CORE + "/src/experiments/", CORE + "/include/krr_core/experiments/",
                    CORE + "/apps/", CORE + "/bench/", CORE + "/test/")
# Code that may use the examples.
EXAMPLE_USERS = (CORE + "/src/examples/", CORE + "/include/krr_core/examples/", CORE + "/bench/",
                 CORE + "/test/")
# First path components of ROS headers (roscpp and friends, message packages, our ROS side).
ROS_PREFIXES = {"ros", "roscpp", "rosbag", "rosconsole", "actionlib", "actionlib_msgs", "tf",
                "tf2", "tf2_ros", "tf2_geometry_msgs", "nodelet", "pluginlib", "message_filters",
                "dynamic_reconfigure", "image_transport", "cv_bridge", "xmlrpcpp", "rostest",
                "ros_type_introspection", "topic_tools", "krr_ros"}
ROS_SUFFIXES = ("_msgs", "_srvs")
SOURCE_EXT = (".h", ".hh", ".hpp", ".hxx", ".c", ".cc", ".cpp", ".cxx", ".ipp", ".inl")
SKIP_DIRS = {".git", "catkin_ws", "node_modules", "__pycache__"}
HEADER_EXT = (".h", ".hh", ".hpp", ".hxx")
# Namespaces whose templates a module may specialise (`template <> struct hash<...>`).
SPECIALISABLE = {"std", "YAML"}
INCLUDE = re.compile(r'^[ \t]*#[ \t]*include[ \t]*([<"])([^">]+)[">]', re.M)
BLOCK_COMMENT = re.compile(r"/\*.*?\*/", re.S)


def source_files(root):
    for d, dirs, files in os.walk(root):
        dirs[:] = sorted(x for x in dirs if x not in SKIP_DIRS)
        for f in sorted(files):
            if f.endswith(SOURCE_EXT):
                yield os.path.relpath(os.path.join(d, f), root).replace(os.sep, "/")


def includes(root, rel):
    """(line, delimiter, target) of every #include outside block comments."""
    with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
        text = f.read()
    text = BLOCK_COMMENT.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    for m in INCLUDE.finditer(text):
        yield text.count("\n", 0, m.start()) + 1, m.group(1), m.group(2).strip()


def module_of_path(rel):
    """krr_core module of a repository path (library code only), else None."""
    for prefix in (CORE + "/src/", CORE + "/include/krr_core/"):
        if rel.startswith(prefix):
            rest = rel[len(prefix):]
            return rest.split("/", 1)[0] if "/" in rest else None
    return None


def included_module(root, rel, delim, target):
    """krr_core module an include refers to ("krr_core/<m>/..." or a relative path), else None."""
    if target.startswith("krr_core/") and target.count("/") >= 2:
        return target.split("/")[1]
    if delim == '"':
        resolved = os.path.normpath(os.path.join(os.path.dirname(rel), target)).replace(os.sep, "/")
        if os.path.isfile(os.path.join(root, resolved)):
            return module_of_path(resolved)
    return None


# Comments, string and character literals (raw strings too) and preprocessor lines, blanked
# (newlines kept) before the namespaces of a header are read.
LEXEMES = re.compile(r'//[^\n]*|/\*.*?\*/|R"([^(\s]*)\(.*?\)\1"|"(?:\\.|[^"\\\n])*"'
                     r"|'(?:\\.|[^'\\\n])*'|^[ \t]*#(?:\\\n|[^\n])*", re.S | re.M)
NAMESPACE_OPEN = re.compile(r"(?:inline\s+)?namespace\b\s*((?:[A-Za-z_]\w*\s*::\s*)*"
                            r"[A-Za-z_]\w*)?\s*\{")
EXTERN_BLOCK = re.compile(r'extern\s*"[^"]*"\s*\{')


def blank_lexemes(text):
    """`text` with comments, literals and preprocessor lines replaced by spaces (lines kept)."""
    return LEXEMES.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)


def declared_namespaces(text):
    """(line, namespace path, declaration text) of every declaration at namespace scope.

    The path is a tuple of names ("" for an anonymous namespace); the declaration text is what
    follows up to the next ';' or '{' (enough to recognise `template <>`)."""
    code = blank_lexemes(text)
    stack = []  # per open brace: the namespace names it opened (None: any other brace)
    out, i, n = [], 0, len(code)
    while i < n:
        c = code[i]
        if c.isspace() or c == ";":
            i += 1
            continue
        at_namespace_scope = all(s is not None for s in stack)
        if c == "}":
            if stack:
                stack.pop()
            i += 1
            continue
        if c == "{":
            stack.append(None)
            i += 1
            continue
        if not at_namespace_scope:
            i += 1
            continue
        m = NAMESPACE_OPEN.match(code, i)
        if m:
            names = re.sub(r"\s", "", m.group(1)).split("::") if m.group(1) else [""]
            stack.append(names)
            i = m.end()
            continue
        m = EXTERN_BLOCK.match(code, i)
        if m:  # extern "C" { ... }: declarations stay in the enclosing namespace
            stack.append([])
            i = m.end()
            continue
        # A declaration: record it, then skip to its end (';' or its first brace, handled above).
        path = tuple(x for s in stack for x in s)
        end = i
        while end < n and code[end] not in ";{}":
            end += 1
        out.append((code.count("\n", 0, i) + 1, path, " ".join(code[i:end].split())))
        i = end
    return out


def namespace_problem(module, path, declaration):
    """Why a declaration in `path` does not belong in a header of `module`, else None."""
    if path and path[0] in SPECIALISABLE and re.match(r"template\s*<\s*>", declaration):
        return None
    if module == "common":
        if len(path) >= 1 and path[0] == "krr" and (len(path) == 1 or path[1] not in MODULES):
            return None
        want = "krr"
    else:
        if path[:2] == ("krr", module):
            return None
        want = "krr::" + module
    return "declares code in %s, not in %s" % (
        "::".join(x or "(anonymous)" for x in path) if path else "the global namespace", want)


def is_ros_header(target):
    first = target.split("/", 1)[0]
    return "/" in target and (first in ROS_PREFIXES or first.endswith(ROS_SUFFIXES))


def check(root):
    """List of 'file:line: rule: message' strings, and the number of files checked."""
    problems, checked = [], 0
    for rel in source_files(root):
        checked += 1
        own = module_of_path(rel)
        for line, delim, target in includes(root, rel):
            where = "%s:%d: " % (rel, line)
            m = included_module(root, rel, delim, target)
            if m == EXPERIMENTS and not rel.startswith(EXPERIMENT_USERS):
                problems.append(where + "experiments: library or node code includes the "
                                "experiment header %s" % target)
            if own in GENERIC and (m in DOMAIN or m == EXPERIMENTS):
                problems.append(where + "generic: generic module '%s' includes %s module "
                                "header %s" % (own, "the experiments" if m == EXPERIMENTS
                                               else "domain", target))
            if m == EXAMPLES and not rel.startswith(EXAMPLE_USERS):
                problems.append(where + "examples: code outside tests and benchmarks includes "
                                "the toy-problem header %s" % target)
            if rel.startswith(CORE + "/") and is_ros_header(target):
                problems.append(where + "ros: the core includes the ROS header %s" % target)
        if own is not None and rel.endswith(HEADER_EXT):
            with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
                text = f.read()
            reported = set()
            for line, path, declaration in declared_namespaces(text):
                why = namespace_problem(own, path, declaration)
                if why and path not in reported:  # one line per file and namespace
                    reported.add(path)
                    problems.append("%s:%d: namespace: header of module '%s' %s" %
                                    (rel, line, own, why))
    return problems, checked


def main():
    here = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    ap.add_argument("--root", default=here, help="repository root (default: %(default)s)")
    args = ap.parse_args()
    if not os.path.isdir(os.path.join(args.root, CORE)):
        print("check_layering: no %s under %s" % (CORE, args.root), file=sys.stderr)
        return 2
    problems, checked = check(args.root)
    for p in problems:
        print(p)
    print("layering: %d files checked, %d violation%s" %
          (checked, len(problems), "" if len(problems) == 1 else "s"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
