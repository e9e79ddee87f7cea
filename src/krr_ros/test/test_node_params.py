#!/usr/bin/python3
"""rostest of the nodes' parameter validation: each node, started with one bad parameter on top
of the shipped configuration, exits with status 1 and a message naming the parameter."""
import os
import unittest

import rospy
import rostest
import yaml

from krr_test_utils import SpawnedNode

# realpath: catkin_ws/src is a symlink to the repository's src/
ROOT = os.path.realpath(os.path.join(os.path.dirname(os.path.realpath(__file__)), '..', '..', '..'))


def shipped(node):
    """The parameters the launch files give `node` (config YAMLs + base_dir + learned files)."""
    params = {}
    for f in ('navigation_kb.yaml', node + '.yaml'):
        with open(os.path.join(ROOT, 'config', f)) as fh:
            params.update(yaml.safe_load(fh))
    params['base_dir'] = ROOT
    tmp = rospy.get_param('~tmp_dir')
    params['learned_file'] = os.path.join(tmp, 'nav.plog')
    if node == 'reasoner_node':
        params['domain_learned_file'] = os.path.join(tmp, 'domain.plog')
    return params


class TestNodeParams(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_node_params')
        cls.counter = 0

    def exit_output(self, node, name, params, label):
        """Start `node` as `name` with `params`; it must exit with code 1: its output."""
        proc = SpawnedNode(node, name, params).start()
        try:
            rc = proc.wait_exit(30)
        finally:
            proc.kill()
            proc.clear_params()
        self.assertEqual(rc, 1, '%s %s: exit code %s, output:\n%s' % (node, label, rc,
                                                                      proc.output))
        return proc.output

    def refused(self, node, changes, needle, remove=()):
        params = shipped(node)
        params.update(changes)
        for k in remove:
            params.pop(k)
        TestNodeParams.counter += 1
        name = 'bad_%s_%d' % (node.split('_')[0], self.counter)
        output = self.exit_output(node, name, params, changes)
        self.assertIn('/%s/' % name, output)  # the parameter is named with its node
        self.assertIn(needle, output)

    def test_reasoner_node(self):
        self.refused('reasoner_node', {'discount': 2.0}, 'discount = 2: must be in [1e-06, 1]')
        self.refused('reasoner_node', {'discount': 'high'}, "discount = 'high': must be a number")
        self.refused('reasoner_node', {'backend': 'clingo'}, "backend = 'clingo': must be one of")
        self.refused('reasoner_node', {'domain_files': ['config/nope.plog']},
                     "domain_files[0] = '%s/config/nope.plog': no such file" % ROOT)
        self.refused('reasoner_node', {'discuont': 0.9}, 'discuont is not a parameter of this node')
        self.refused('reasoner_node', {'seed': -4}, 'seed = -4: must be in [0, 2147483647]')

    def test_navigation_node(self):
        self.refused('navigation_node', {'sim_rate': -1}, 'sim_rate = -1: must be in [0, 1000]')
        self.refused('navigation_node', {'model_source': 'magic'},
                     "model_source = 'magic': must be one of reasoner, local")
        self.refused('navigation_node', {'start_place': 'kitchen'}, "start_place = 'kitchen'")
        # No place is written in code: the default start is the site's shop; an empty one is
        # refused.
        self.refused('navigation_node', {'start_place': ''},
                     "start_place = '': must name a place of the map")
        # A site folder that is none is refused naming it (krr_core/site/site.h).
        self.refused('navigation_node', {'site': '/nonexistent_site'},
                     "site = '/nonexistent_site': site folder /nonexistent_site: no such directory")
        self.refused('navigation_node', {'time': 'midnight'}, "'midnight'")
        self.refused('navigation_node', {'ompl_paths': 'yes'}, 'ompl_paths = ')
        self.refused('navigation_node', {'domain': 'office_99x99'}, 'office_99x99')
        # The core's one blocking-rate rule and message (krr_core/nav/blocking_rate.h).
        self.refused('navigation_node', {'blocking_rate': 1.5},
                     "blocking_rate': value 1.5 must be in [0, 1] (negative: not set)")
        self.refused('navigation_node', {'executor': 'teleport'},
                     "executor = 'teleport': must be one of simulated, move_base")
        # The external server cannot be the node's own move_base face: goals would loop back.
        self.refused('navigation_node', {'executor': 'move_base', 'executor_action': '/move_base'},
                     "executor_action = '/move_base': must name the external move_base server")
        self.refused('navigation_node', {'executor_timeout': 0},
                     'executor_timeout = 0: must be in [0.1, 86400]')

    def test_learner_node(self):
        self.refused('learner_node', {'max_episodes_per_task': 0},
                     'max_episodes_per_task = 0: must be in [1, 1000000]')
        self.refused('learner_node', {'places': ['room1', 'kitchen']}, "places = 'kitchen'")
        self.refused('learner_node', {'start_place': ''},
                     "start_place = '': must name a place of the map")
        self.refused('learner_node', {'enabled': 'yes'}, "enabled = 'yes': must be true or false")
        self.refused('learner_node', {'step_cost': 50.0}, 'step_cost')
        self.refused('learner_node', {'blocking_rate': 1.5},
                     "blocking_rate': value 1.5 must be in [0, 1] (negative: not set)")
        self.refused('learner_node', {'sample_period': -1},
                     'sample_period = -1: must be in [0, 86400]')

    def test_dialog_node(self):
        # The solver budgets: -1 = the dialog config's, 0 = none (solve to the precision).
        self.refused('dialog_node', {'solver_max_trials': -2},
                     'solver_max_trials = -2: must be in [-1, 1000000000]', remove=('learned_file',))
        self.refused('dialog_node', {'startup_max_trials': 'many'},
                     "startup_max_trials = 'many': must be an integer", remove=('learned_file',))
        self.refused('dialog_node', {'startup_max_trials': -1},
                     'startup_max_trials = -1: must be in [0, 1000000000]', remove=('learned_file',))

    def test_dialog_node_refuses_an_inconsistent_site(self):
        """A language file with two stale synonyms: dialog_node does not start, and its one
        message names the file, the fields and the values of both (the site check)."""
        tmp = rospy.get_param('~tmp_dir')
        os.makedirs(tmp, exist_ok=True)
        with open(os.path.join(ROOT, 'config', 'language.yaml')) as fh:
            text = fh.read()  # as text: a YAML round trip would turn the key yes into true
        self.assertIn('\nsynonyms:\n', text)
        text = text.replace('\nsynonyms:\n', '\nsynonyms:\n  "the lab": room9\n  carol: carol\n', 1)
        bad = os.path.join(tmp, 'stale_language.yaml')
        with open(bad, 'w') as fh:
            fh.write(text)
        params = shipped('dialog_node')
        params.pop('learned_file')  # dialog_node learns nothing
        params['language_config'] = bad
        output = self.exit_output('dialog_node', 'bad_site_dialog', params, 'stale synonyms')
        for needle in (bad, "room9", "carol", 'cannot start'):
            self.assertIn(needle, output)

    def test_reasoner_node_refuses_a_site_with_other_knowledge(self):
        """A reasoner given another building's knowledge (domain_files without the dialog's
        config/office.plog): it does not start, and its one message names the parameter, the
        value and the dialog config's knowledge.office it disagrees with (the site check)."""
        tmp = rospy.get_param('~tmp_dir')
        os.makedirs(tmp, exist_ok=True)
        other = os.path.join(tmp, 'other_building.plog')
        with open(os.path.join(ROOT, 'config', 'office.plog')) as fh:
            text = fh.read()
        with open(other, 'w') as fh:
            fh.write(text)  # the same content, another file: a copy left behind by a new site
        params = shipped('reasoner_node')
        params['domain_files'] = [other]
        output = self.exit_output('reasoner_node', 'bad_site_reasoner', params, 'other knowledge')
        for needle in ('cannot start', "parameters of /bad_site_reasoner: field 'domain_files'",
                       "value '[%s]'" % other,
                       os.path.join(ROOT, 'config', 'dialog.yaml') + "'s knowledge.office",
                       os.path.join(ROOT, 'config', 'office.plog')):
            self.assertIn(needle, output)
        # The same knowledge with check_site: false starts (a test's own files on purpose).
        params['check_site'] = False
        proc = SpawnedNode('reasoner_node', 'unchecked_site_reasoner', params).start()
        try:
            rospy.wait_for_service('/unchecked_site_reasoner/query_probability', timeout=60)
        finally:
            proc.kill()
            proc.clear_params()

    def node_help(self, node):
        """Each of --help and -h, without a master: exit 0, the usage line; their stdout."""
        import subprocess
        from krr_test_utils import node_binary
        outputs = []
        for flag in ('--help', '-h'):
            env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:9')  # nobody there
            out = subprocess.run([node_binary(node), flag], env=env, timeout=20,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 universal_newlines=True)
            self.assertEqual(out.returncode, 0, '%s %s:\n%s%s' % (node, flag, out.stdout, out.stderr))
            self.assertIn('usage: rosrun krr_ros %s' % node, out.stdout)
            outputs.append(out.stdout)
        return outputs

    def test_help_needs_no_master_and_lists_the_parameters(self):
        for node, param in (('reasoner_node', 'discount:'), ('navigation_node', 'sim_rate:'),
                            ('learner_node', 'max_episodes_per_task:'),
                            ('dialog_node', 'seed:')):
            for text in self.node_help(node):
                self.assertIn(os.path.join(ROOT, 'config', node + '.yaml'), text)
                self.assertIn(param, text)
        # The Python nodes print their docstring, which starts with the node's name.
        for node in ('simulated_user', 'fake_move_base', 'belief_markers'):
            for text in self.node_help(node):
                self.assertIn('\n%s: ' % node, text)

    def test_sim_launch_passes_kb_config_to_every_node(self):
        import subprocess
        tmp = rospy.get_param('~tmp_dir')
        os.makedirs(tmp, exist_ok=True)
        alt = os.path.join(tmp, 'kb_alt.yaml')
        with open(os.path.join(ROOT, 'config', 'navigation_kb.yaml')) as f:
            kb = yaml.safe_load(f)
        kb['domain'] = 'office_50x50'
        with open(alt, 'w') as f:
            yaml.safe_dump(kb, f)
        out = subprocess.run(['roslaunch', '--dump-params', os.path.join(ROOT, 'launch', 'sim.launch'),
                              'kb_config:=' + alt, 'user:=true'],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             universal_newlines=True, timeout=60)
        self.assertEqual(out.returncode, 0, out.stdout)
        params = yaml.safe_load(out.stdout)
        for node in ('reasoner', 'navigation', 'learner', 'dialog'):
            self.assertEqual(params.get('/%s/domain' % node), 'office_50x50', node)


if __name__ == '__main__':
    rostest.rosrun('krr_ros', 'node_params', TestNodeParams)
