"""The lean warm Newton command (core/solver/newton_lean.py) and its lazy Result
(newton_result.py).

Oracles: the dense Newton path on the same commands (the same Solver with the lean command
switched off: what Solver.solve answered before it), the closed-form solve of the same scene
(exact to rounding), and a plain Result of the same values.

Would fail if: the lean path answered a command differently from the dense path (another
success, branch, refusal, iteration count, or values beyond rounding), went on after a command
it should have left to the dense path (a jump past the prediction's reach, a toggle), left a
State the dense path cannot continue from, or its Result read, compared, copied or pickled
other than as the Result it stands for.
"""

from __future__ import annotations

import copy
import math
import pickle

import numpy as np
import pytest
import scenes
from hypothesis import given, settings
from hypothesis import strategies as st

from linkage_ros.bench.tradeoff import sweep_inputs
from linkage_ros.core.solver import Solver
from linkage_ros.core.solver.newton_lean import lean_newton
from linkage_ros.core.solver.newton_result import NewtonResult
from linkage_ros.core.solver.result import Result

#: the Schur kernel's scenes, then two of the dense kernel's (the bench's larger scenes)
LEAN_SCENES = [
    'four_bar',
    'slider_crank',
    'four_bar_double_crank',
    'scott_russell',
    'peaucellier',
    'excavator',
]


def _pair(mech, branch='continuous'):
    """(lean solver, dense solver) of one mechanism."""
    lean = Solver(mech, method='newton', tol=1e-12, branch=branch)
    dense = Solver(mech, method='newton', tol=1e-12, branch=branch)
    dense.compiled.__dict__['_lean_newton'] = None  # the dense path alone (as before)
    assert lean_newton(lean.compiled) is not None
    return lean, dense


def _commands(s, steps):
    """Commands moving every known from the reference input by the cumulative ``steps``
    (rad for angles, length scales for slides)."""
    ref = s.reference_values()
    L = s.mech.length_scale
    out, at = [], dict(ref)
    for h in steps:
        at = {
            k: v + (h if s.compiled.specs[i].unit == 'rad' else h * L)
            for i, (k, v) in enumerate(at.items())
        }
        out.append(dict(at))
    return out


def _same(a, b, L):
    """The lean Result ``a`` is the dense path's ``b`` to rounding."""
    assert (a.success, a.reason, a.solver) == (b.success, b.reason, b.solver)
    if not b.success:
        return
    assert (a.branch, a.branch_defined, a.iterations) == (b.branch, b.branch_defined, b.iterations)
    for f in ('inputs', 'joints', 'links'):
        got, want = getattr(a, f), getattr(b, f)
        assert got.keys() == want.keys()
        for k in want:
            assert abs(math.remainder(got[k] - want[k], 2 * math.pi)) <= 1e-11 or (
                abs(got[k] - want[k]) <= 1e-11 * L
            ), (f, k)
    for p, (x, y) in b.points.items():
        assert max(abs(a.points[p][0] - x), abs(a.points[p][1] - y)) <= 1e-11 * L
    assert abs(a.residual - b.residual) <= 4e-15 and a.residual <= 1e-12
    assert abs(a.margin - b.margin) <= 1e-11
    assert (a.cond is None) == (b.cond is None)
    if b.cond is not None:
        assert a.cond == pytest.approx(b.cond, rel=1e-6)


@pytest.mark.parametrize('name', LEAN_SCENES)
def test_a_sweep_answers_as_the_dense_path(name):
    mech = scenes.load(name)
    lean, dense = _pair(mech)
    cmds = sweep_inputs(mech, 260)  # the bench's warm sweep through every actuator's range
    answered = solved = 0
    for c in cmds:
        a, b = lean.solve(c), dense.solve(c)
        _same(a, b, mech.length_scale)
        answered += isinstance(a, NewtonResult)
        solved += b.success
    assert solved == len(cmds) and answered >= 0.9 * solved  # the lean path answers them


def test_the_four_bar_sweep_is_the_closed_form():
    mech = scenes.load('four_bar')
    lean, _ = _pair(mech)
    closed = Solver(mech, method='closed_form')
    for c in _commands(lean, [0.03] * 250):
        a, b = lean.solve(c), closed.solve(c)
        assert a.success and b.success and a.branch == b.branch
        for k, v in b.links.items():
            assert abs(math.remainder(a.links[k] - v, 2 * math.pi)) <= 1e-12
        for p, (x, y) in b.points.items():
            assert math.hypot(a.points[p][0] - x, a.points[p][1] - y) <= 1e-12 * mech.length_scale


@settings(max_examples=25, deadline=None)
@given(
    name=st.sampled_from(['four_bar', 'slider_crank']),
    branch=st.sampled_from(['continuous', 'reference', '+', '-']),
    steps=st.lists(
        st.one_of(st.floats(-0.2, 0.2), st.sampled_from([1.5, -2.5, 3.0, 0.0])),
        min_size=5,
        max_size=40,
    ),
)
def test_any_command_sequence_answers_as_the_dense_path(name, branch, steps):
    # jumps past the prediction's reach, standing still, reversals, each branch rule: wherever
    # the lean path leaves a command to the dense path, the two solvers stay the same
    mech = scenes.load(name)
    lean, dense = _pair(mech, branch)
    for c in _commands(lean, steps):
        _same(lean.solve(c), dense.solve(c), mech.length_scale)


def test_beyond_reach_both_paths_refuse_alike():
    # the slider-crank's crank cannot pass the rod's reach when the rod is short: drive a
    # four-bar that does not turn fully (non-Grashof) past its toggle
    mech = scenes.load('four_bar_non_grashof')
    if lean_newton(Solver(mech, method='newton').compiled) is None:
        pytest.skip('no lean kernel for this scene')
    lean, dense = _pair(mech)
    refused = 0
    for c in _commands(lean, [0.05] * 150):
        a, b = lean.solve(c), dense.solve(c)
        _same(a, b, mech.length_scale)
        refused += not b.success
    assert refused  # the sweep met the edge


def test_the_lazy_result_is_the_result_it_stands_for():
    mech = scenes.load('four_bar')
    lean, dense = _pair(mech)
    for c in _commands(lean, [0.02] * 5):
        a, b = lean.solve(c), dense.solve(c)
    assert isinstance(a, NewtonResult)
    plain = Result(**vars(a))
    assert type(plain) is Result and plain == a and a == plain
    assert pickle.loads(pickle.dumps(a)) == a and type(pickle.loads(pickle.dumps(a))) is Result
    assert copy.deepcopy(a) == a
    _same(plain, b, mech.length_scale)
    assert a.to_dict(mech)['links'].keys() == b.to_dict(mech)['links'].keys()
    a.links['crank'] = 9.0  # a caller's change stays (the dicts are the Result's own)
    assert a.links['crank'] == 9.0


def test_snapshots_and_the_dense_path_continue_from_lean_answers():
    mech = scenes.load('four_bar')
    lean, dense = _pair(mech)
    cmds = _commands(lean, [0.02] * 30)
    for c in cmds[:20]:
        lean.solve(c), dense.solve(c)
    snap = pickle.loads(pickle.dumps(lean.snapshot()))
    lean.compiled.__dict__['_lean_newton'] = None  # the dense path from a lean State
    for c in cmds[20:25]:
        _same(lean.solve(c), dense.solve(c), mech.length_scale)
    del lean.compiled.__dict__['_lean_newton']
    other = Solver(mech, method='newton', tol=1e-12)
    other.restore(snap)
    for c in cmds[20:]:
        a = other.solve(c)
        assert a.success
    assert np.isfinite(a.margin)
