#!/usr/bin/python3
"""rostest of reasoner_node: queries, knowledge updates, persistence across a crash, errors."""
import os
import shutil
import unittest

import rospy
import rostest
from krr_msgs.msg import KnowledgeUpdate, LearnedAtom
from krr_msgs.srv import AddKnowledge, BuildTaskModel, QueryProbability

from krr_test_utils import SpawnedNode

BOB_QUERY = '?{curr_room(bob)=room2} | do(curr_person=bob).'


def atom(cell, move, outcomes, counts, time='morning', samples=None):
    return LearnedAtom(cell=cell, move=move, time=time, outcomes=outcomes, counts=counts,
                       samples=sum(counts) if samples is None else samples)


def nav_query(cell, move, outcome, time='morning'):
    return '?{next_cell=%s} | do(curr_cell=%d), do(act_move=%s), obs(curr_time=%s)' % (
        outcome, cell, move, time)


class Reasoner:
    """Service proxies of one reasoner node."""

    def __init__(self, ns):
        for s in ('query_probability', 'add_knowledge', 'build_task_model'):
            rospy.wait_for_service(ns + '/' + s, timeout=30)
        self.query = rospy.ServiceProxy(ns + '/query_probability', QueryProbability)
        self.add = rospy.ServiceProxy(ns + '/add_knowledge', AddKnowledge)
        self.build = rospy.ServiceProxy(ns + '/build_task_model', BuildTaskModel)

    def update(self, atoms=(), statements=''):
        return self.add(KnowledgeUpdate(source='test', atoms=list(atoms), statements=statements))


class TestReasonerNode(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node('test_reasoner_node')
        cls.r = Reasoner('/reasoner')
        cls.learned_dir = rospy.get_param('~learned_dir')

    def test_known_probability_from_office_kb(self):
        res = self.r.query(query=BOB_QUERY)
        self.assertTrue(res.success, res.message)
        self.assertAlmostEqual(res.probability, 0.8, places=9)
        # P(curr_room(bob)=room5 | do(curr_person=bob)): the other four rooms share 0.2.
        res = self.r.query(query='?{curr_room(bob)=room5} | do(curr_person=bob)')
        self.assertAlmostEqual(res.probability, 0.05, places=9)

    def test_distribution_of_an_attribute(self):
        res = self.r.query(attribute='curr_room(john)', evidence='do(curr_person=john)')
        self.assertTrue(res.success, res.message)
        dist = dict(zip(res.values, res.probabilities))
        self.assertEqual(sorted(dist), ['room1', 'room2', 'room3', 'room4', 'room5'])
        self.assertAlmostEqual(dist['room5'], 0.8, places=9)
        self.assertAlmostEqual(sum(dist.values()), 1.0, places=9)

    def test_navigation_kb_human_knowledge(self):
        # Free space (room1, no blocking area): the intended cell with 0.8.
        res = self.r.query(query=nav_query(213, 'up', '243'), knowledge_base='navigation')
        self.assertTrue(res.success, res.message)
        self.assertAlmostEqual(res.probability, 0.8, places=9)

    def test_malformed_queries_are_errors_and_the_node_survives(self):
        bad = self.r.query(query='?{curr_room(bob)=room2 | do(')
        self.assertFalse(bad.success)
        self.assertIn('<query>:1:', bad.message)  # location of the syntax error
        bad = self.r.query(query='?{curr_room(carol)=room2}')
        self.assertFalse(bad.success)
        self.assertIn("'carol'", bad.message)
        bad = self.r.query(query='?{curr_room(bob)=room9}')
        self.assertFalse(bad.success)
        self.assertIn("'room9'", bad.message)
        bad = self.r.query(query=BOB_QUERY, knowledge_base='kitchen')
        self.assertFalse(bad.success)
        self.assertIn("'kitchen'", bad.message)
        bad = self.r.query()
        self.assertFalse(bad.success)
        self.assertIn('exactly one', bad.message)
        bad = self.r.query(attribute='curr_room(', evidence='')
        self.assertFalse(bad.success)
        self.assertTrue(self.r.query(query=BOB_QUERY).success)

    def test_add_knowledge_changes_the_model_and_is_persisted(self):
        res = self.r.update([atom(182, 'up', ['212', '182'], [7, 3])])
        self.assertTrue(res.success, res.message)
        self.assertEqual(res.atoms_added, 1)
        self.assertGreaterEqual(res.total_learned, 1)
        q = self.r.query(query=nav_query(182, 'up', '212'), knowledge_base='navigation')
        self.assertAlmostEqual(q.probability, 0.7, places=9)
        # Only in its context: at noon human knowledge still applies.
        q = self.r.query(query=nav_query(182, 'up', '212', 'noon'), knowledge_base='navigation')
        self.assertAlmostEqual(q.probability, 0.8, places=9)
        text = open(os.path.join(self.learned_dir, 'learned_navigation.plog')).read()
        self.assertIn('pr(next_cell=212 | curr_cell=182, act_move=up, curr_time=morning) = 7/10.',
                      text)
        self.assertIn('learned(182, up, morning).', text)
        m = self.r.build(task='navigation', times=['morning'])
        self.assertTrue(m.success, m.message)
        s = list(m.state_cells).index(182)
        self.assertEqual(m.learned[s * 4 + 0], 1)  # move up = action 0
        lo, hi = m.row_offsets[s * 4], m.row_offsets[s * 4 + 1]
        row = {m.state_cells[m.next_states[i]]: m.probabilities[i] for i in range(lo, hi)}
        self.assertAlmostEqual(row[212], 0.7, places=9)
        self.assertAlmostEqual(row[182], 0.3, places=9)

    def test_bad_updates_are_refused_and_change_nothing(self):
        path = os.path.join(self.learned_dir, 'learned_navigation.plog')
        before = open(path).read() if os.path.exists(path) else None
        total = self.r.build(task='navigation', times=['morning']).num_learned
        cases = [
            ([atom(183, 'sideways', ['213'], [1])], "atoms[0].move: 'sideways'"),
            ([atom(183, 'up', ['213', '183'], [3, 3], samples=5)], 'sum to 6'),
            ([atom(0, 'up', ['1'], [1])], 'atoms[0].cell'),
            ([atom(183, 'up', ['213'], [1], time='midnight')], "'midnight'"),
            ([atom(183, 'up', ['x'], [1])], "'x' is neither"),
            ([atom(183, 'up', ['300'], [1])], 'atoms[0].outcomes[0]: cell 300 is neither'),
            ([atom(183, 'up', ['213', 'trapped'], [1, 1])], "'trapped' is impossible"),
            ([atom(183, 'up', ['213'], [0], samples=0)], 'atoms[0].'),
            ([atom(183, 'up', ['213'], [1]), atom(183, 'up', ['183'], [1])], 'a second atom'),
            ([], 'neither atoms, area knowledge nor statements'),
            # Counts near INT64_MAX must not wrap around the "sum to samples" check.
            ([atom(183, 'up', ['213', '183'], [9223372036854775807, 3], samples=10)],
             'atoms[0].counts[0]: 9223372036854775807 is not in [1, samples = 10]'),
            ([atom(183, 'up', ['213', '183'], [4611686018427387904, 4611686018427387904],
                   samples=10)], 'is not in [1, samples = 10]'),
        ]
        for atoms, needle in cases:
            res = self.r.update(atoms)
            self.assertFalse(res.success, needle)
            self.assertIn(needle, res.message)
        # A valid atom with an invalid statement: all or nothing.
        res = self.r.update([atom(183, 'up', ['213'], [1])], statements='pr(curr_room(bob')
        self.assertFalse(res.success)
        self.assertIn('<update from test>:1:', res.message)
        # Statements that make the domain KB incoherent (probabilities summing above 1).
        res = self.r.update(statements='pr(curr_room(bob)=room3 | place(bob,room2)=true) = 5/10.')
        self.assertFalse(res.success)
        self.assertIn('incoherent', res.message)
        self.assertAlmostEqual(self.r.query(query=BOB_QUERY).probability, 0.8, places=9)
        self.assertEqual(self.r.build(task='navigation', times=['morning']).num_learned, total)
        after = open(path).read() if os.path.exists(path) else None
        self.assertEqual(before, after)

    def own_reasoner_params(self, name, **overrides):
        """The launched reasoner's parameters with its own, fresh learned files under `name`."""
        params = rospy.get_param('/reasoner')
        d = os.path.join(self.learned_dir, name)
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
        params['learned_file'] = os.path.join(d, 'nav.plog')
        params['domain_learned_file'] = os.path.join(d, 'domain.plog')
        params.update(overrides)
        return params

    def answers(self, r=None):
        """What the node answers on both knowledge bases (to compare states)."""
        r = r or self.r
        out = [r.query(query=BOB_QUERY).probability,
               tuple(r.query(attribute='curr_room(john)', evidence='do(curr_person=john)')
                     .probabilities),
               r.query(query='?{request(coke, room2, bob)}').probability,
               r.query(query=nav_query(213, 'up', '243'), knowledge_base='navigation')
               .probability]
        return out

    def test_a_refused_statement_update_leaves_the_state_identical(self):
        before = self.answers()
        self.assertTrue(all(x is not None for x in before))
        for statements in ('obs(curr_person=john).', 'obs(curr_person=john). obs(curr_person=bob).',
                           'pr(curr_room(bob)=room3 | place(bob,room2)=true) = 5/10.'):
            res = self.r.update(statements=statements)
            self.assertFalse(res.success, statements)
            self.assertIn('nothing changed', res.message)
            self.assertEqual(self.answers(), before, statements)
        # Later updates still work (the refused one did not poison the knowledge base).
        ok = self.r.update([atom(184, 'up', ['214', '184'], [1, 1])])
        self.assertTrue(ok.success, ok.message)
        self.assertTrue(self.r.query(query=BOB_QUERY).success)

    def test_area_knowledge_is_validated_applied_and_persisted(self):
        path = os.path.join(self.learned_dir, 'learned_navigation.plog')
        before = open(path).read() if os.path.exists(path) else None
        walkers = '?{walkers(ba1)=true} | obs(curr_time=%s)'
        for time, text, needle in (
                ('midnight', 'learned_noise(midnight).', "area_time 'midnight'"),
                ('noon', 'pr(walkers(ba1)=true | curr_time=noon) = 1/', 'area knowledge'),
                ('noon', 'pr(walkers(ba9)=true | curr_time=noon) = 1/4.', 'ba9')):
            res = self.r.add(KnowledgeUpdate(source='test', area_time=time, area_statements=text))
            self.assertFalse(res.success, text)
            self.assertIn(needle, res.message)
        after = open(path).read() if os.path.exists(path) else None
        self.assertEqual(before, after)  # refused: nothing changed, nothing written
        q = self.r.query(query=walkers % 'noon', knowledge_base='navigation')
        self.assertAlmostEqual(q.probability, 0.5, places=9)  # human knowledge at noon
        ok = self.r.add(KnowledgeUpdate(
            source='test', area_time='noon',
            area_statements='pr(walkers(ba1)=true | curr_time=noon) = 1/4.\n'
                            'learned_area(ba1, noon).\n'))
        self.assertTrue(ok.success, ok.message)
        self.assertIn('area knowledge for noon', ok.message)
        q = self.r.query(query=walkers % 'noon', knowledge_base='navigation')
        self.assertAlmostEqual(q.probability, 0.25, places=9)
        self.assertIn('learned_area(ba1, noon).', open(path).read())

    def test_build_task_model_errors(self):
        res = self.r.build(task='navigation', times=['midnight'])
        self.assertFalse(res.success)
        self.assertIn("'midnight'", res.message)
        res = self.r.build(task='cooking')
        self.assertFalse(res.success)
        self.assertIn("'cooking'", res.message)
        res = self.r.build(task='dialog')
        self.assertFalse(res.success)
        self.assertIn('not available', res.message)
        res = self.r.build(task='navigation', discount=1.5)
        self.assertFalse(res.success)
        res = self.r.build(task='navigation')  # all times marginalised
        self.assertTrue(res.success, res.message)
        self.assertEqual(res.num_states, 470)  # 469 free cells + trapped

    def test_a_runaway_rule_is_refused_within_the_budget(self):
        # q has no sort to stop its recursion: only the grounding budget ends it.
        import time
        params = self.own_reasoner_params('budget', query_seconds=1.0)
        node = SpawnedNode('reasoner_node', 'reasoner_budget', params).start()
        try:
            r = Reasoner('/reasoner_budget')
            before = self.answers(r)
            t0 = time.monotonic()
            res = r.update(statements='q(X + 1) :- q(X).\nq(0).\n')
            took = time.monotonic() - t0
            self.assertFalse(res.success, res.message)
            self.assertIn('nothing changed', res.message)
            self.assertIn('<update from test>:1:', res.message)  # the rule is named
            self.assertLess(took, 15.0)
            self.assertEqual(self.answers(r), before)
            self.assertFalse(os.path.exists(params['domain_learned_file']))
            node.kill()
            node.start()
            self.assertEqual(self.answers(Reasoner('/reasoner_budget')), before)
        finally:
            node.kill()
            node.clear_params()

    def test_programs_outside_the_native_fragment_are_answered_or_refused_by_backend(self):
        # An even loop through `not` splits every possible world in two: P(lp) = 1/2. The
        # native engine alone cannot answer it (~backend: native refuses the update, nothing
        # changes); the default, auto, answers through clingo and the KB's other answers stay.
        loop = 'lp : boolean.\nlq : boolean.\nlp :- not lq.\nlq :- not lp.\n'
        for backend in ('native', 'auto'):
            params = self.own_reasoner_params('backend_' + backend, backend=backend)
            name = 'reasoner_backend_' + backend
            node = SpawnedNode('reasoner_node', name, params).start()
            try:
                r = Reasoner('/' + name)
                before = self.answers(r)
                res = r.update(statements=loop)
                if backend == 'native':
                    self.assertFalse(res.success, res.message)
                    self.assertIn('nothing changed', res.message)
                    self.assertIn('ASP back end', res.message)
                    self.assertEqual(self.answers(r), before)
                else:
                    self.assertTrue(res.success, res.message)
                    q = r.query(query='?{lp}')
                    self.assertTrue(q.success, q.message)
                    self.assertAlmostEqual(q.probability, 0.5, places=9)
                    # now answered through clingo: the same numbers up to rounding
                    after = self.answers(r)
                    self.assertEqual(len(after), len(before))
                    for a, b in zip(after, before):
                        a = a if isinstance(a, tuple) else (a,)
                        b = b if isinstance(b, tuple) else (b,)
                        self.assertEqual(len(a), len(b))
                        for x, y in zip(a, b):
                            self.assertAlmostEqual(x, y, places=9)
            finally:
                node.kill()
                node.clear_params()

    def test_start_up_recovers_and_never_refuses_what_it_wrote(self):
        params = self.own_reasoner_params('startup')
        nav, dom = params['learned_file'], params['domain_learned_file']
        d = os.path.dirname(nav)
        # An update a kill interrupted after its commit point: the journal holds both files.
        nav_text = ('pr(next_cell=212 | curr_cell=182, act_move=up, curr_time=morning) = 7/10.\n'
                    'pr(next_cell=182 | curr_cell=182, act_move=up, curr_time=morning) = 3/10.\n'
                    'learned(182, up, morning).\n')
        dom_text = 'pr(curr_room(bob)=room2 | place(bob,room2)=true) = 9/10.\n'
        entries = ''.join('file %d %d\n%s%s\n' % (len(p), len(t), p, t)
                          for p, t in ((nav, nav_text), (dom, dom_text)))
        with open(nav + '.journal', 'w') as f:
            f.write('krr-file-transaction 1\n' + entries + 'end\n')
        orphan = os.path.join(d, '.tmp_Ab12Cd')
        with open(orphan, 'w') as f:
            f.write('half a write')
        os.utime(orphan, (0, 0))
        node = SpawnedNode('reasoner_node', 'reasoner_startup', params).start()
        try:
            r = Reasoner('/reasoner_startup')
            self.assertAlmostEqual(r.query(query=BOB_QUERY).probability, 0.9, places=9)
            q = r.query(query=nav_query(182, 'up', '212'), knowledge_base='navigation')
            self.assertAlmostEqual(q.probability, 0.7, places=9)
            self.assertFalse(os.path.exists(nav + '.journal'))
            self.assertFalse(os.path.exists(orphan))
            node.kill()
            # A corrupt learned file (e.g. edited by hand) is moved aside, the node starts.
            with open(nav, 'w') as f:
                f.write('pr(next_cell=212 | curr_cell=182, act_move=up, curr_time=morning) = '
                        '-9223372036854775808/1000000.\n')
            with open(dom, 'w') as f:
                f.write('this is not P-log\n')
            node.start()
            r = Reasoner('/reasoner_startup')
            self.assertAlmostEqual(r.query(query=BOB_QUERY).probability, 0.8, places=9)
            self.assertEqual(r.build(task='navigation', times=['morning']).num_learned, 0)
            aside = sorted(os.listdir(d))
            self.assertTrue(any(n.startswith('nav.plog.corrupt-') for n in aside), aside)
            self.assertTrue(any(n.startswith('domain.plog.corrupt-') for n in aside), aside)
            ok = r.update([atom(182, 'up', ['212', '182'], [1, 1])], statements=dom_text)
            self.assertTrue(ok.success, ok.message)
            node.kill()
            node.start()  # what it wrote itself loads again
            r = Reasoner('/reasoner_startup')
            self.assertAlmostEqual(r.query(query=BOB_QUERY).probability, 0.9, places=9)
            self.assertEqual(r.build(task='navigation', times=['morning']).num_learned, 1)
        finally:
            node.kill()
            node.clear_params()

    def test_kills_during_mixed_updates_lose_or_half_apply_nothing(self):
        # Update n writes the pair (182, up) as n/(n+1) and one statement block: after every
        # kill -9 and restart both files must hold the same update, the last acknowledged one
        # or the one in flight.
        import random
        import threading
        params = self.own_reasoner_params('kills')
        dom = params['domain_learned_file']
        node = SpawnedNode('reasoner_node', 'reasoner_kills', params).start()
        rng = random.Random(7)
        acked = 0
        try:
            for round_ in range(6):
                r = Reasoner('/reasoner_kills')
                n = open(dom).read().count('% added by') if os.path.exists(dom) else 0
                self.assertIn(n, (acked, acked + 1), 'round %d: statements' % round_)
                q = r.query(query=nav_query(182, 'up', '212'), knowledge_base='navigation')
                self.assertAlmostEqual(q.probability, n / (n + 1.0) if n else 0.8, places=9,
                                       msg='round %d: the pair belongs to the same update' % round_)
                acked = n
                killer = threading.Timer(rng.uniform(0.05, 0.5), node.kill)
                killer.start()
                try:
                    for _ in range(200):
                        k = acked + 1
                        res = r.update([atom(182, 'up', ['212', '182'], [k, 1])],
                                       statements='%% update %d\n' % k)
                        self.assertTrue(res.success, res.message)
                        acked = k
                except (rospy.ServiceException, rospy.ROSException):
                    pass
                killer.join()
                node.kill()
                rospy.loginfo('kill round %d: %d updates acknowledged so far', round_, acked)
                node.start()
            self.assertGreater(acked, 6, 'updates must have run between the kills')
        finally:
            node.kill()
            node.clear_params()

    def test_knowledge_survives_a_crash_and_restart(self):
        # A second reasoner with its own files, killed with SIGKILL (no clean shutdown).
        params = self.own_reasoner_params('restart')
        node = SpawnedNode('reasoner_node', 'reasoner_restart', params).start()
        try:
            r = Reasoner('/reasoner_restart')
            # 188 -> right enters blocking area ba1 (cell 189).
            res = r.update([atom(188, 'right', ['189', '188', 'trapped'], [2, 1, 1])],
                           statements='pr(curr_room(bob)=room2 | place(bob,room2)=true) = 9/10.')
            self.assertTrue(res.success, res.message)
            self.assertAlmostEqual(r.query(query=BOB_QUERY).probability, 0.9, places=9)
            node.kill()
            node.start()
            r = Reasoner('/reasoner_restart')
            self.assertEqual(r.build(task='navigation', times=['morning']).num_learned, 1)
            q = r.query(query=nav_query(188, 'right', 'trapped'), knowledge_base='navigation')
            self.assertTrue(q.success, q.message)
            self.assertAlmostEqual(q.probability, 0.25, places=9)
            self.assertAlmostEqual(r.query(query=BOB_QUERY).probability, 0.9, places=9)
        finally:
            node.kill()
            node.clear_params()
        # The launched reasoner was not affected.
        self.assertAlmostEqual(self.r.query(query=BOB_QUERY).probability, 0.8, places=9)


if __name__ == '__main__':
    rostest.rosrun('krr_ros', 'reasoner_node', TestReasonerNode)
