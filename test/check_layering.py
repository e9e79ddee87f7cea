#!/usr/bin/python3
"""Check the include layering of the C++ code (issue 14): exit 1 and list every violation.

Layers of krr_core:
  generic      common, plog, mdp, nav, pomdp
  domain       kb, dialog
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

Usage: check_layering.py [--root REPO]   (default: the repository holding this script)
"""
import argparse
import os
import re
import sys

CORE = "src/krr_core"
GENERIC = {"common", "plog", "mdp", "nav", "pomdp"}
DOMAIN = {"kb", "dialog"}
EXPERIMENTS = "experiments"
EXAMPLES = "examples"
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
