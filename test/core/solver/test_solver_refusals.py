"""What the solver refuses and how it says so: bad commands (a failed Result naming the problem,
and no change of state), actuator limits, unreachable inputs (naming the dyad and the miss) and
scene errors (naming the file, the key and the value).

Every expected number comes from ``oracles`` (50-digit mpmath geometry taking the float inputs
exactly) or from elementary geometry written out here -- never from the code under test.
"""

import math
import re

import numpy as np
import oracles as orc
import pytest
from scenes import four_bar, slider_crank
from solver_core_helpers import CRANK_ROCKER, TRIPLE_ROCKER, five_bar, lever

from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

# =============================================================================================
# bad commands: a failed Result naming the problem, and no change of state
# =============================================================================================


BAD_SCALAR_COMMANDS = [
    ({'crank': float('nan')}, ['crank', 'finite']),
    ({'crank': float('inf')}, ['crank', 'finite']),
    ({'crank': -float('inf')}, ['crank', 'finite']),
    ({'crank': 0.5, 'extra': 1.0}, ['unknown', 'extra']),
    ({'crnk': 0.5}, ['unknown', 'crnk']),
    ({}, ['missing', 'crank']),
    ({'crank': '0.5'}, ['crank', 'number']),
    ({'crank': None}, ['crank', 'number']),
    ({'crank': [0.5]}, ['crank', 'number']),
    ({'crank': True}, ['crank', 'number']),
    ({'crank': 1 + 0j}, ['crank', 'number']),
    ([0.5], ['command']),
]


def _parallelogram():
    return four_bar(2.0, 1.0, 2.0, 1.0)


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
@pytest.mark.parametrize('bad, words', BAD_SCALAR_COMMANDS)
def test_bad_command_is_refused_and_changes_nothing(method, bad, words):
    """The bad command fails with a reason naming the problem; the following good commands give
    exactly what they give without it (continuity history untouched). The sweep runs through a
    change point of a parallelogram, where the history decides the branch."""
    m = _parallelogram()
    seq = [0.3, 0.15, 0.0, -0.15, -0.3]

    def run(bad_at):
        s = Solver(m, method=method)
        out = []
        for i, t in enumerate(seq):
            if i == bad_at:
                r = s.solve(bad)
                assert not r.success
                assert r.reason and all(w in r.reason for w in words), r.reason
            out.append(s.solve({'crank': t}))
        return out

    clean = run(None)
    for bad_at in (1, 3):
        dirty = run(bad_at)
        for a, b in zip(clean, dirty):
            assert a.success == b.success and a.branch == b.branch
            assert a.points == b.points


BAD_POINT_COMMANDS = [
    ({'point:C': (0.5, 1.1, 0.0)}, ['point:C', 'two numbers']),
    ({'point:C': (0.5,)}, ['point:C', 'two numbers']),
    ({'point:C': 0.5}, ['point:C', 'two numbers']),
    ({'point:C': 'ab'}, ['point:C', 'two numbers']),
    ({'point:C': (0.5, float('nan'))}, ['point:C', 'finite']),
    ({'point:C': (float('inf'), 1.0)}, ['point:C', 'finite']),
    ({'C': (0.5, 1.1)}, ['unknown', "'C'"]),
]


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
@pytest.mark.parametrize('bad, words', BAD_POINT_COMMANDS)
def test_bad_point_command_is_refused_and_changes_nothing(method, bad, words):
    m = five_bar()
    seq = [(0.5, 1.1), (0.52, 1.12), (0.55, 1.1), (0.5, 1.05)]

    def run(bad_at):
        s = Solver(m, knowns=['point:C'], method=method)
        out = []
        for i, c in enumerate(seq):
            if i == bad_at:
                r = s.solve(bad)
                assert not r.success
                assert r.reason and all(w in r.reason for w in words), r.reason
            out.append(s.solve({'point:C': c}))
        return out

    clean = run(None)
    dirty = run(2)
    assert all(r.success for r in clean)
    for a, b in zip(clean, dirty):
        assert a.points == b.points and a.branch == b.branch


# =============================================================================================
# actuator limits
# =============================================================================================


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
def test_angle_limits_refuse_with_the_amount(method):
    m = four_bar(*CRANK_ROCKER, input=0.5, crank_limits={'min': -1.0, 'max': 1.0})
    s = Solver(m, method=method)
    assert s.solve({'crank': 0.999}).success
    assert s.solve({'crank': 1.0}).success
    r = s.solve({'crank': 1.5})
    assert not r.success
    assert 'crank' in r.reason and 'maximum' in r.reason and re.search(r'by 0\.5\b', r.reason)
    r = s.solve({'crank': -1.25})
    assert not r.success
    assert 'minimum' in r.reason and re.search(r'by 0\.25\b', r.reason)
    # and the refusals did not move the solver: it continues from 1.0
    r = s.solve({'crank': 0.99})
    assert r.success and r.branch == '+'


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
def test_cylinder_limits_forward_and_inverse(method):
    m = lever()
    s = Solver(m, method=method)
    r = s.solve({'cyl': 1.5})
    assert not r.success and 'cyl' in r.reason and 'maximum' in r.reason
    assert re.search(r'by 0\.1\b', r.reason), r.reason
    r = s.solve({'cyl': 0.4})
    assert not r.success and 'minimum' in r.reason and re.search(r'by 0\.1\b', r.reason)
    # inverse: a lever angle that needs the cylinder longer than its maximum
    inv = Solver(m, knowns=['lever'], method=method)
    pts = m.points
    l_op = float(np.hypot(*(pts['P'] - pts['O'])))
    c = pts['C']
    # the lever angle at which |CP| = 1.45 (> max 1.4), by the cosine rule in triangle O C P
    oc = float(np.hypot(*c))
    ang_c = math.atan2(c[1], c[0])
    gamma = math.acos((oc**2 + l_op**2 - 1.45**2) / (2 * oc * l_op))
    for target in (ang_c + gamma, ang_c - gamma):
        r = inv.solve({'lever': _wrap(target)})
        if r.success:
            continue  # not this side of the ground line
        assert 'target needs' in r.reason and 'cyl' in r.reason and 'maximum' in r.reason
        assert re.search(r'by 0\.05\b', r.reason), r.reason
        # the batch refuses the row in the same words (one rule: plan.needs_beyond_limits)
        batch = inv.solve_batch({'lever': [_wrap(target)]})
        assert not batch.ok[0] and batch.reason[0] == r.reason
        break
    else:
        pytest.fail('no lever angle needing a 1.45 m cylinder was refused')


def _wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


# =============================================================================================
# unreachable inputs
# =============================================================================================


def _miss_in(reason):
    m = re.search(r'misses by ([0-9.eE+-]+) m', reason)
    assert m, reason
    return float(m.group(1))


def test_unreachable_four_bar_names_the_dyad_and_the_miss():
    l1, l2, l3, l4 = TRIPLE_ROCKER
    m = four_bar(*TRIPLE_ROCKER)
    s = Solver(m, method='closed_form')
    for t in (0.0, 0.3, -0.5):
        want = orc.fourbar(l1, l2, l3, l4, t, 1)
        assert not want['ok']
        r = s.solve({'crank': t})
        assert not r.success
        assert 'RRR dyad: B from circles about A (coupler) and O4 (rocker)' in r.reason
        assert _miss_in(r.reason) == pytest.approx(float(want['miss']), rel=1e-5)
        assert r.inputs == {'crank': t}
    nw = Solver(m, method='newton')
    r = nw.solve({'crank': 0.0})
    assert not r.success and r.reason


def test_unreachable_slider_crank_inverse_names_the_dyad_and_the_miss():
    m = slider_crank(1.0, 3.0, 0.5, 0.3)
    s = Solver(m, knowns=['slider'], method='closed_form')
    for x in (4.5, 10.0, -5.0):
        want = orc.slider_crank_inverse(1.0, 3.0, 0.5, 0.3, x, 1)
        assert not want['ok']
        r = s.solve({'slider': x})
        assert not r.success
        assert 'RRR dyad: A from circles about O2 (crank) and B (rod)' in r.reason
        assert _miss_in(r.reason) == pytest.approx(float(want['miss']), rel=1e-5)
        assert r.targets == {'slider': x}


def test_unreachable_five_bar_point():
    m = five_bar()
    s = Solver(m, knowns=['point:C'])
    r = s.solve({'point:C': (0.5, 5.0)})
    assert not r.success and 'RRR dyad: A from circles about O1 (left) and C' in r.reason
    lens_left = 0.6
    l_ac = math.hypot(0.5, 0.6)
    assert _miss_in(r.reason) == pytest.approx(math.hypot(0.5, 5.0) - lens_left - l_ac, rel=1e-5)


# =============================================================================================
# scene errors name the file, the key and the value
# =============================================================================================

GOOD_POINTS = """\
points:
  O2: [0.0, 0.0]
  A: [0.5, 0.866]
  B: [2.6, 1.5]
  O4: [3.0, 0.0]
"""

GOOD_LINKS = """\
links:
  ground: [O2, O4]
  crank: [O2, A]
  coupler: [A, B]
  rocker: [O4, B]
"""

GOOD_ACT = """\
actuators:
  crank: {type: angle, link: crank, pivot: O2}
"""

BROKEN_SCENES = {
    'unknown_point': (
        GOOD_POINTS + GOOD_LINKS.replace('[A, B]', '[A, Z]') + GOOD_ACT,
        ['links.coupler', "unknown point 'Z'"],
    ),
    'non_numeric': (
        GOOD_POINTS.replace('[2.6, 1.5]', '[2.6, abc]') + GOOD_LINKS + GOOD_ACT,
        ['points.B[1]', 'number', "'abc'"],
    ),
    'dof_mismatch': (
        GOOD_POINTS + GOOD_LINKS + GOOD_ACT + '  rock: {type: angle, link: rocker, pivot: O4}\n',
        ['actuators', '1 degree(s) of freedom', '2 actuator(s)', "'rock'"],
    ),
    'unknown_top_key': (
        GOOD_POINTS + GOOD_LINKS + GOOD_ACT + 'linkz: {}\n',
        ['linkz', 'unknown key'],
    ),
    'duplicate_slider': (
        """\
points: {O2: [0, 0], A: [0.3, 0.4], B: [1.5, 0], C: [1.8, 0]}
links: {ground: [O2], crank: [O2, A], rod: [A, B, C], s1: [B], s2: [C]}
sliders:
  - {name: slide, guide: ground, slider: s1, point: B, direction: 0.0}
  - {name: slide, guide: ground, slider: s2, point: C, direction: 0.0}
actuators: {crank: {type: angle, link: crank, pivot: O2}}
""",
        ['sliders.slide', 'duplicate', "'slide'"],
    ),
    'actuator_named_like_cylinder': (
        """\
points: {O: [0, 0], C: [-0.5, -0.3], P: [0.4, 0.3]}
links: {ground: [O, C], lever: [O, P]}
cylinders: {cyl: {from: C, to: P}}
actuators: {cyl: {type: angle, link: lever, pivot: O}}
""",
        ['actuators.cyl', 'duplicate', "'cyl'"],
    ),
    'four_bar_bad_length': (
        'four_bar: {ground: 4, crank: abc, coupler: 4.5, rocker: 3}\n',
        ['four_bar.crank', 'number', "'abc'"],
    ),
    'four_bar_negative_length': (
        'four_bar: {ground: 4, crank: -1.5, coupler: 4.5, rocker: 3}\n',
        ['four_bar.crank', '> 0', '-1.5'],
    ),
}


#: a class-III triad (an outside reviewer's): the crank's four-bar-like chain ends in the
#: triangle B C D held by three links, which Newton places (no dyad plan)
TRIAD = {
    'name': 'triad',
    'points': {
        'O1': [0, 0],
        'A': [0.05, 0.08],
        'O2': [0.5, 0],
        'O3': [0.25, -0.2],
        'B': [0.22, 0.2],
        'C': [0.4, 0.22],
        'D': [0.3, 0.05],
    },
    'links': {
        'ground': ['O1', 'O2', 'O3'],
        'crank': ['O1', 'A'],
        'ab': ['A', 'B'],
        'o2c': ['O2', 'C'],
        'o3d': ['O3', 'D'],
        'tri': ['B', 'C', 'D'],
    },
    'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O1'}},
}


@pytest.mark.parametrize('crank, branch', [(0.99, None), (0.99, 'J-'), (1.5, 'J-')])
def test_a_newton_refusal_does_not_claim_no_assembly_where_another_mode_closes(crank, branch):
    """Just past the drawn circuit's toggle (0.99835) and in its J- mode, the triad assembles
    (the all-branches search finds it; each answer closes every link length, checked here),
    but not from the current configuration: the refusal said "cannot assemble at this input"
    from a least-squares search of one start. It now says no assembly is near."""
    mech = Scene.from_dict(TRIAD).mechanism
    modes = Solver(mech).modes({'crank': crank}).results
    closing = [r for r in modes if r.success]
    assert closing, 'the premise: some mode closes'
    for r in closing:  # each found mode closes every link's lengths (oracle: the drawing's)
        for link, members in TRIAD['links'].items():
            if link == 'ground':
                continue
            for p, q in zip(members, members[1:]):
                drawn = math.dist(TRIAD['points'][p], TRIAD['points'][q])
                assert math.dist(r.points[p], r.points[q]) == pytest.approx(drawn, abs=1e-12)
    r = Solver(mech, **({} if branch is None else {'branch': branch})).solve({'crank': crank})
    if r.success:  # reached (a better search than today's): then it closes
        assert r.residual <= 1e-12
        return
    assert 'cannot assemble' not in r.reason, r.reason
    assert 'no assembly near the current configuration' in r.reason


@pytest.mark.parametrize('name', sorted(BROKEN_SCENES))
def test_scene_errors_name_file_key_and_value(tmp_path, name):
    text, fragments = BROKEN_SCENES[name]
    path = tmp_path / f'{name}.yaml'
    path.write_text(text)
    with pytest.raises(SceneError) as exc:
        Scene.from_yaml(path)
    msg = str(exc.value)
    assert str(path) in msg, msg
    for f in fragments:
        assert f in msg, (f, msg)


def test_scene_error_duplicate_yaml_key_is_not_silently_dropped(tmp_path):
    """Two points named A in one mapping: YAML's last-one-wins would silently build a different
    mechanism than the file shows. The loader must refuse, naming the key."""
    text = GOOD_POINTS.replace('  B:', '  A: [0.6, 0.8]\n  B:') + GOOD_LINKS + GOOD_ACT
    path = tmp_path / 'dup.yaml'
    path.write_text(text)
    with pytest.raises(SceneError) as exc:
        Scene.from_yaml(path)
    msg = str(exc.value)
    assert str(path) in msg and 'A' in msg and 'duplicate' in msg.lower()
