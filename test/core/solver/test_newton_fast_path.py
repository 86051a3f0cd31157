"""The warm Newton path on the compiled solve's kernel (newton_path.solve_newton with
newton_kernel: lean.LeanSchur where J reduces to 3 x 3, else scalar.DenseKernel) and its lazy
Result (newton_result.NewtonResult over lazy_result.LazyResult).

Oracles: the 50-digit four-bar and slider-crank (test/oracles.py), the closed-form solve of the
same scene on the branch the answer reports (exact to rounding), numpy's 1-norm condition
number of the dense J at the answer, the ResultAssembler's residual (build_result's), and a
plain Result of the same values.

Would fail if: a kernel's prediction or fast path left an answer off its configuration, on
another branch than it reports or than asked, with a condition number above the exact one
(LAPACK's estimate never is) or a residual other than build_result's; a State could not be
continued from (snapshot, restore); or the lazy Result read, compared, copied or pickled other
than as the Result it stands for.
"""

from __future__ import annotations

import copy
import math
import pickle

import numpy as np
import oracles as orc
import pytest
import scenes
from hypothesis import given, settings
from hypothesis import strategies as st
from scenes import four_bar, slider_crank

from linkage_ros.core.newton.evaluate import jacobian
from linkage_ros.core.newton.lean import LeanSchur, evaluate_lean
from linkage_ros.core.newton.scalar import DenseKernel
from linkage_ros.core.ops import SCALAR
from linkage_ros.core.solver import Solver
from linkage_ros.core.solver.newton_path import newton_kernel
from linkage_ros.core.solver.newton_result import NewtonResult
from linkage_ros.core.solver.result import Result

#: the Schur kernel's scenes, then the dense kernel's (the bench's larger scenes)
SCENES = ['four_bar', 'slider_crank', 'four_bar_double_crank', 'scott_russell']
DENSE_SCENES = ['peaucellier', 'excavator']
TIGHT = 1e-12


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


def _is_closed_form(a, poses, mech, command):
    """A successful Newton Result ``a`` (its link ``poses``: the solver's state after it) is
    the closed form's answer on the branch it reports, its cond at most numpy's exact 1-norm
    one and its residual the assembler's."""
    s = Solver(mech, method='newton')
    closed = Solver(mech, method='closed_form', branch=a.branch).solve(command)
    assert closed.success and closed.branch == a.branch
    L = mech.length_scale
    for k, v in closed.links.items():
        assert abs(math.remainder(a.links[k] - v, 2 * math.pi)) <= 1e-10, k
    for p, (x, y) in closed.points.items():
        assert math.hypot(a.points[p][0] - x, a.points[p][1] - y) <= 1e-10 * L, p
    assert a.residual <= TIGHT
    assert abs(a.margin - closed.margin) <= 1e-9
    # cond: LAPACK's estimate of the scale-free J's 1-norm condition number at the answer
    c = s.compiled
    x = c.system.x_from_poses(poses)
    t = c.system.tables
    _, jv, _ = evaluate_lean(t, x.tolist(), c.parse(command))
    exact = np.linalg.cond(jacobian(t, jv, t.tpl_s), 1)
    assert a.cond is not None and a.cond <= exact * (1 + 1e-9) and a.cond >= exact / 10


def test_each_compiled_solve_has_its_kernel():
    # the four-bar's and slider-crank's 9 x 9 J reduce to a 3 x 3 M; Peaucellier and the
    # excavator do not; closed-form and hybrid solves predict nothing
    for name in SCENES:
        assert isinstance(
            newton_kernel(Solver(scenes.load(name), method='newton').compiled), LeanSchur
        )
    for name in DENSE_SCENES:
        k = newton_kernel(Solver(scenes.load(name), method='newton').compiled)
        assert isinstance(k, DenseKernel)
    assert newton_kernel(Solver(scenes.load('four_bar'), method='closed_form').compiled) is None


@pytest.mark.parametrize('name', SCENES + DENSE_SCENES)
def test_a_warm_sweep_is_the_closed_form(name):
    from linkage_ros.bench.tradeoff import sweep_inputs

    mech = scenes.load(name)
    s = Solver(mech, method='newton', tol=1e-12)
    cmds = sweep_inputs(mech, 120)  # the bench's warm sweep through every actuator's range
    for i, command in enumerate(cmds):
        a = s.solve(command)
        assert a.success, (i, a.reason)
        assert isinstance(a, NewtonResult)
        # the residual is build_result's: the assembler's over every joint and known, read
        # off the answer's poses (the state the solver keeps after it)
        poses = s.snapshot()[-1].poses
        got = s.compiled.assembler(poses.phi)(SCALAR, poses, s.parse(command))
        assert abs(a.residual - got.residual) <= 4e-15
        if i % 7 == 0:  # (the closed-form solver per answer is the slow part)
            _is_closed_form(a, poses, mech, command)


@pytest.mark.parametrize('name', SCENES)
def test_a_warm_command_solves_its_steps_and_one_tangent(name, monkeypatch):
    # the tangent a prediction extrapolates along is solved once, at the answer it starts from
    # (kept in the State), not again by each of the next two predictions: a warm command on
    # the Schur kernel solves J y = F for its Newton and chord steps and for its answer's
    # tangent only (an answer it took no step for: none)
    from linkage_ros.bench.tradeoff import sweep_inputs

    mech = scenes.load(name)
    s = Solver(mech, method='newton', tol=1e-12)
    cmds = sweep_inputs(mech, 60)
    for command in cmds[:3]:
        assert s.solve(command).success
    calls = [0]
    solve = LeanSchur.solve

    def counted(self, fac, F):
        calls[0] += 1
        return solve(self, fac, F)

    monkeypatch.setattr(LeanSchur, 'solve', counted)
    for command in cmds[3:]:
        calls[0] = 0
        r = s.solve(command)
        assert r.success
        assert calls[0] == r.iterations + 1, (calls[0], r.iterations)


def test_the_four_bar_and_slider_crank_sweeps_are_the_50_digit_answers():
    l1, l2, l3, l4 = 4.0, 1.5, 4.5, 3.0  # Grashof crank-rocker
    fb = Solver(four_bar(l1, l2, l3, l4), method='newton', tol=1e-12)
    for t in np.linspace(-3.0, 3.0, 241):  # 0.025 rad steps: every one warm
        r = fb.solve({'crank': float(t)})
        want = orc.fourbar(l1, l2, l3, l4, float(t), 1)
        assert r.success and r.branch == '+' and r.residual <= TIGHT
        assert orc.point_error(r.points['B'], want['B']) <= 1e-11 * fb.mech.length_scale
        assert orc.angle_error(r.links['rocker'], want['theta4']) <= 1e-11
    m = slider_crank(1.0, 3.0, 0.5, 0.3)
    sc = Solver(m, method='newton', tol=1e-12)
    assert isinstance(newton_kernel(sc.compiled), LeanSchur)
    for t in np.linspace(-3.0, 3.0, 241):
        r = sc.solve({'crank': float(t)})
        want = orc.slider_crank(1.0, 3.0, 0.5, 0.3, float(t), 1 if r.branch == '+' else -1)
        assert r.success and r.residual <= TIGHT
        assert orc.point_error(r.points['B'], want['B']) <= 1e-11 * m.length_scale


@settings(max_examples=25, deadline=None)
@given(
    name=st.sampled_from(['four_bar', 'slider_crank']),
    branch=st.sampled_from(['continuous', 'reference', '+', '-']),
    steps=st.lists(
        st.one_of(st.floats(-0.2, 0.2), st.sampled_from([1.5, -2.5, 3.0, 0.0])),
        min_size=5,
        max_size=30,
    ),
)
def test_any_command_sequence_answers_on_its_branch(name, branch, steps):
    # jumps past the prediction's reach, standing still, reversals, each branch rule: every
    # answer is the closed form's on the branch it reports, and the asked one where asked
    mech = scenes.load(name)
    s = Solver(mech, method='newton', tol=1e-12, branch=branch)
    for command in _commands(s, steps):
        a = s.solve(command)
        if not a.success:
            continue
        if branch in ('+', '-'):
            assert a.branch == branch
        assert isinstance(a, NewtonResult)  # (every Newton answer: the walk's too)
        _is_closed_form(a, s.snapshot()[-1].poses, mech, command)


def test_the_lazy_result_is_the_result_it_stands_for():
    mech = scenes.load('four_bar')
    s = Solver(mech, method='newton', tol=1e-12)
    for command in _commands(s, [0.02] * 5):
        a = s.solve(command)
    assert isinstance(a, NewtonResult)
    _is_closed_form(a, s.snapshot()[-1].poses, mech, command)
    given = a.links['crank']
    plain = Result(**vars(a))
    assert type(plain) is Result and plain == a and a == plain
    assert pickle.loads(pickle.dumps(a)) == a and type(pickle.loads(pickle.dumps(a))) is Result
    assert copy.deepcopy(a) == a
    assert a.to_dict(mech)['links'].keys() == mech.links.keys()
    a.links['crank'] = 9.0  # a caller's change stays (the dicts are the Result's own)
    assert a.links['crank'] == 9.0 and given != 9.0


def test_snapshots_continue_from_kernel_factors():
    mech = scenes.load('four_bar')
    s = Solver(mech, method='newton', tol=1e-12)
    cmds = _commands(s, [0.02] * 30)
    for command in cmds[:20]:
        s.solve(command)
    snap = pickle.loads(pickle.dumps(s.snapshot()))
    other = Solver(mech, method='newton', tol=1e-12)
    other.restore(snap)
    for command in cmds[20:]:
        a, b = other.solve(command), s.solve(command)
        assert a.success and isinstance(a, NewtonResult)
        _is_closed_form(a, other.snapshot()[-1].poses, mech, command)
        assert a.iterations == b.iterations  # the restored State predicts as the kept one


@pytest.mark.parametrize('s', [1e-300, 1.0, 4e307])
def test_answers_at_every_length_scale(s):
    """A four-bar drawn at 1e-300 m, 1 m and 4e307 m (its ground 1e308 m: one sum of the
    answer's values overflows there, not any value) answers every command, each the closed
    form's on the same branch."""
    mech = four_bar(2 * s, s, 2.5 * s, 2 * s)
    newton = Solver(mech, method='newton', tol=1e-12)
    closed = Solver(mech)
    for command in _commands(newton, [0.05] * 6):
        a, b = newton.solve(command), closed.solve(command)
        assert a.success, a.reason
        assert a.branch == b.branch
        for name, angle in b.links.items():
            assert abs(math.remainder(a.links[name] - angle, 2 * math.pi)) <= 1e-12, name


def test_a_kept_result_keeps_no_solve_behind_it():
    """Results kept by a caller (a trajectory's answers) hold what their fields are read
    from, not the solve's J or its factorisation: the excavator's (LAPACK's LU of its 33 x 33
    J, ~18 kB per answer) would grow a kept Result about six times."""
    import tracemalloc

    mech = scenes.load('excavator')
    s = Solver(mech, method='newton', tol=1e-12)
    cmds = _commands(s, [0.0004, -0.0004] * 130)  # (about the drawing: no limit is met)
    for command in cmds[:10]:
        s.solve(command)
    tracemalloc.start()
    try:
        before = tracemalloc.take_snapshot()
        kept = [s.solve(command) for command in cmds[10:]]
        after = tracemalloc.take_snapshot()
    finally:
        tracemalloc.stop()
    assert all(isinstance(r, NewtonResult) for r in kept)
    grown = sum(st.size_diff for st in after.compare_to(before, 'filename'))
    assert grown / len(kept) < 8000, f'{grown / len(kept):.0f} bytes per kept Result'
    full = kept[-1]
    values = Result(**vars(full))
    assert full == values
