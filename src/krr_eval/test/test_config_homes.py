"""One home per setting (issue 14 part 2): every YAML under config/ is loaded and

- no leaf key path is defined in two files (config/**.yaml): the navigation task and R-Max live
  in navigation.yaml, the dialog in dialog.yaml;
- a setting that has one meaning wherever it is named (ONE_HOME: R-Max's M, the reward, the
  blocking rate, the time of day...) is defined under one key path of one base file, not again
  under another section or file (dialog.yaml's learning.known_threshold next to
  navigation.yaml's rmax_learning.known_threshold would be two homes of R-Max's M); A node file (config/*_node.yaml,
  simulated_user.yaml) is the private namespace of its node, so its paths are the node's
  (learner_node's ~seed is not dialog_node's ~seed);
- node files carry ROS wiring only (topics, rates, file paths, seeds, budgets): no leaf named
  like a physical / task setting (reward, discount, R-Max, blocking rate, speech model);
- a site folder's files (config/sites/NAME/, krr_core/site/site.h) are the building's own,
  replacing the office's names, and define no physical / task setting (but the per-area
  overrides of their own areas);
- an experiment file (config/experiments/NAME.yaml) overrides keys of the base files only,
  each with a value different from the base (it names only what it changes), and keeps its own
  protocol (episodes, places...) in its section NAME, whose keys no base file has and which
  names no ONE_HOME setting (nav_transfer.time would be a second home of context.time).
"""
import glob
import os
import unittest

import yaml

from krr_eval import paths

CONFIG = os.path.join(paths.root(), "config")

# Leaf names that denote a physical or task setting: never in a node file.
PHYSICAL = {
    "step_cost", "rmax", "discount", "model_discount", "known_threshold", "replan_every",
    "optimism", "refine_known", "blocking_rate", "blocking_mode", "move_success", "slip_stay",
    "slip_lateral", "trap_probability", "trap_reference_cell_size", "time_of_day",
    "general_question_cost", "confirm_question_cost", "success_reward", "failure_reward",
    "turn_limit", "max_redeliveries", "failure_penalty", "wrong_delivery_penalty",
    "p_own", "p_general", "p_yesno", "items", "rooms", "persons", "offices", "time",
}

# Leaf names that mean one setting wherever they stand: at most one key path of the base files.
# (Not `discount`: the dialog POMDP, the delivery trips, the task's planning and R-Max each have
# their own, under their own section.)
ONE_HOME = {
    "step_cost", "rmax", "known_threshold", "replan_every", "optimism", "refine_known",
    "blocking_rate", "blocking_mode", "move_success", "slip_stay", "slip_lateral",
    "trap_probability", "trap_reference_cell_size", "time", "model_discount",
    "general_question_cost", "confirm_question_cost", "success_reward", "failure_reward",
    "turn_limit", "max_redeliveries", "failure_penalty", "wrong_delivery_penalty",
}


def leaves(node, prefix=()):
    """Leaf key paths of a loaded YAML document -> value (lists are leaves)."""
    if isinstance(node, dict):
        out = {}
        for k, v in node.items():
            out.update(leaves(v, prefix + (str(k),)))
        return out
    return {prefix: node} if prefix else {}


def classify(rel):
    """'experiment', 'node' or 'base' for a path relative to config/."""
    if rel.split(os.sep)[0] == "experiments":
        return "experiment"
    if rel.split(os.sep)[0] == "sites":
        return "site"
    name = os.path.basename(rel)
    if name.endswith("_node.yaml") or name == "simulated_user.yaml":
        return "node"
    return "base"


def check(files):
    """Violations of the rules above; files: {path relative to config/: loaded document}."""
    problems = []
    owner = {}   # leaf path -> first non-experiment file defining it
    base = {}    # leaf path -> value, over the base files
    homes = {}   # ONE_HOME leaf name -> (file, key) of its first definition in a base file
    for rel in sorted(files):
        kind = classify(rel)
        if kind == "experiment":
            continue
        if kind == "site":
            # A site folder (config/sites/NAME) is one building's own files, which replace the
            # office's (its language file, places, map): not a second home of a base key, but
            # it names no physical or task setting, except the per-area overrides of its own
            # blocking areas (site.yaml's `areas`, navigation.yaml's simulator.areas format).
            for path in sorted(leaves(files[rel])):
                if (PHYSICAL | ONE_HOME) & set(path) and not (
                        os.path.basename(rel) == "site.yaml" and path[0] == "areas"):
                    problems.append("%s: site file defines the physical / task setting %s (its "
                                    "home is a base file)" % (rel, ".".join(path)))
            continue
        for path, value in sorted(leaves(files[rel]).items()):
            if kind == "node":   # the node's private namespace
                path = ("~" + os.path.splitext(os.path.basename(rel))[0],) + path
            key = ".".join(path)
            if path in owner:
                problems.append("%s is defined in %s and in %s" % (key, owner[path], rel))
            else:
                owner[path] = rel
            if kind == "base":
                base[path] = value
                name = path[-1]
                if name in ONE_HOME:
                    if name in homes and homes[name] != (rel, key):
                        problems.append("%s is set in %s (%s) and in %s (%s): one setting, two "
                                        "homes" % (name, homes[name][0], homes[name][1], rel, key))
                    homes.setdefault(name, (rel, key))
            elif PHYSICAL & set(path):
                problems.append("%s: node file defines the physical / task setting %s (its home "
                                "is a base file)" % (rel, key))
    for rel in sorted(files):
        if classify(rel) != "experiment":
            continue
        own = os.path.splitext(os.path.basename(rel))[0]
        doc = files[rel]
        if not isinstance(doc, dict):
            problems.append("%s: not a mapping" % rel)
            continue
        for path, value in sorted(leaves(doc).items()):
            key = ".".join(path)
            if path[0] == own:
                # A base section inside the experiment's own (own.planning.step_cost) would be
                # a second name for a base setting, and so would a ONE_HOME name (own.time).
                if path in base or (len(path) > 2 and path[1:] in base):
                    problems.append("%s: %s is a base setting, not the experiment's own" %
                                    (rel, key))
                elif path[-1] in ONE_HOME:
                    problems.append("%s: %s names the setting %s of a base file (%s): override "
                                    "that key instead" % (rel, key, path[-1],
                                                          homes.get(path[-1], ("?", "?"))[1]))
            elif path not in base:
                problems.append("%s: %s overrides no key of a base file" % (rel, key))
            elif base[path] == value:
                problems.append("%s: %s = %r is the base's value (name only what changes)" %
                                (rel, key, value))
    return problems


def load_config(root=CONFIG):
    files = {}
    for f in sorted(glob.glob(os.path.join(root, "**", "*.yaml"), recursive=True)):
        with open(f) as h:
            files[os.path.relpath(f, root)] = yaml.safe_load(h) or {}
    return files


class ConfigHomesTest(unittest.TestCase):
    def test_every_setting_has_one_home(self):
        files = load_config()
        self.assertIn(os.path.join("experiments", "nav_transfer.yaml"), files)
        self.assertIn(os.path.join("experiments", "new_circumstances.yaml"), files)
        self.assertIn("navigation.yaml", files)
        self.assertEqual(check(files), [])

    def test_the_homes(self):
        files = load_config()
        nav = leaves(files["navigation.yaml"])
        for key in ("step_cost", "rmax", "discount"):
            self.assertIn(("planning", key), nav)
        for key in ("known_threshold", "discount", "replan_every"):
            self.assertIn(("rmax_learning", key), nav)
        self.assertIn(("simulator", "blocking_rate"), nav)
        self.assertIn(("dialog", "discount"), leaves(files["dialog.yaml"]))
        self.assertIn(("context", "time"), nav)
        for rel in files:
            if rel != "navigation.yaml":
                self.assertNotIn("known_threshold", {p[-1] for p in leaves(files[rel])
                                                     if classify(rel) == "base"}, rel)
        # The delivery experiments' M lives in their experiment file, as a change of the base.
        delivery = leaves(files[os.path.join("experiments", "delivery_trials.yaml")])
        self.assertEqual(delivery[("rmax_learning", "known_threshold")], 30)

    def test_a_second_definition_fails(self):
        # The checker must catch what it exists to forbid, else a green run means nothing.
        base = {"navigation.yaml": {"planning": {"step_cost": 1.0}},
                "dialog.yaml": {"dialog": {"discount": 0.99}}}
        self.assertEqual(check(base), [])
        twice = dict(base, **{"other.yaml": {"planning": {"step_cost": 1.0}}})
        self.assertTrue(any("planning.step_cost is defined in" in p for p in check(twice)))
        nodes = dict(base, **{"a_node.yaml": {"seed": 1}, "b_node.yaml": {"seed": 1}})
        self.assertEqual(check(nodes), [])   # each node's own ~seed
        node = dict(base, **{"learner_node.yaml": {"seed": 1, "discount": 0.95}})
        self.assertTrue(any("node file defines" in p for p in check(node)))
        exp = os.path.join("experiments", "x.yaml")
        ok = dict(base, **{exp: {"x": {"episodes": 3}, "planning": {"step_cost": 0.5}}})
        self.assertEqual(check(ok), [])
        # One setting under two sections or files: the second home is caught, whatever its path.
        two = dict(base, **{"dialog.yaml": {"dialog": {"discount": 0.99},
                                            "learning": {"known_threshold": 30}},
                            "navigation.yaml": {"planning": {"step_cost": 1.0},
                                                "rmax_learning": {"known_threshold": 5}}})
        self.assertTrue(any("known_threshold is set in" in p for p in check(two)), check(two))
        time = dict(base, **{"navigation.yaml": {"planning": {"step_cost": 1.0},
                                                 "context": {"time": "morning"}},
                             "dialog.yaml": {"dialog": {"discount": 0.99},
                                             "navigation": {"time": "morning"}}})
        self.assertTrue(any("time is set in" in p for p in check(time)), check(time))
        node_time = dict(base, **{"learner_node.yaml": {"time": "morning"}})
        self.assertTrue(any("node file defines" in p for p in check(node_time)))
        for doc, what in (({"planning": {"speed": 2}}, "overrides no key"),
                          ({"planning": {"step_cost": 1.0}}, "the base's value"),
                          ({"x": {"planning": {"step_cost": 2.0}}}, "not the experiment's own"),
                          ({"x": {"time": "noon"}}, "names the setting time")):
            problems = check(dict(base, **{exp: doc}))
            self.assertTrue(any(what in p for p in problems), (doc, problems))


if __name__ == "__main__":
    unittest.main()
