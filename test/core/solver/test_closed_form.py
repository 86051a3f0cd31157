"""The one-command closed-form path (core.scalar_plan's program, core.solver.closed_form's
readout) against the batch path (core.execute on numpy, core.assemble) it twins, on every
packaged scene: ``Solver.solve`` answers what ``Solver.solve_batch`` answers for the same
commands, value for value.

Both paths run the same float operations; the only roundings that may differ between them are
numpy's sin, cos and arctan2 against libm's (numpy may take SIMD paths on some CPUs). Where
numpy's agree with libm's bit for bit on this machine (checked on the very angles), every
value must be equal; elsewhere within a few ulps propagated (1e-13 of the length scale).
"""

from __future__ import annotations

import math

import numpy as np
import oracles
import pytest
import scenes

from linkage_ros.bench.tradeoff import sweep_inputs
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

SHIPPED = scenes.SHIPPED
#: and a roller on a flat face (its residual closes on either side)
SCENES = [*SHIPPED, 'nut_cracker']


@pytest.mark.parametrize('scene', SCENES)
def test_solve_equals_solve_batch_on_every_packaged_scene(scene):
    """A warm continuous sweep through the actuator ranges, with jumps and commands out of
    reach: each command's Result (success, branch, inputs, joints, links, points, residual,
    margin) equals the batch row solved with the branch the sweep took; and every command
    solved on the reference branch (refusal words included) equals its reference batch row."""
    mech = (
        Scene.from_dict(scenes.nut_cracker()).mechanism
        if scene == 'nut_cracker'
        else scenes.load(scene)
    )
    L = mech.length_scale
    rng = np.random.default_rng(25)
    cmds = sweep_inputs(mech, 120)
    for j in range(0, len(cmds), 9):  # jumps, some beyond reach or limits
        cmds[j] = {k: v + float(rng.normal(0, 0.8)) for k, v in cmds[j].items()}
    solver = Solver(mech, method='closed_form')
    results = [solver.solve(c) for c in cmds]
    checked = 0
    for branch in [*sorted({r.branch for r in results if r.success}), None]:
        batch_solver = Solver(mech, method='closed_form', branch=branch or 'reference')
        rows = [i for i, r in enumerate(results) if r.branch == branch or branch is None]
        cols = {k: np.array([cmds[i][k] for i in rows]) for k in cmds[0]}
        batch = batch_solver.solve_batch(cols)
        exact = oracles.trig_is_libm(np.concatenate(list(cols.values())))
        for n, i in enumerate(rows):
            r = results[i] if branch is not None else batch_solver.solve(cmds[i])
            assert r.success == bool(batch.ok[n]), (i, r.reason, batch.reason[n])
            if not r.success:
                assert r.reason == batch.reason[n]
                continue
            checked += 1
            assert r.branch == ''.join('+' if s > 0 else '-' for s in batch.signs[n])
            tab = [(r.residual, batch.residual[n], 1.0), (r.margin, batch.margin[n], 1.0)]
            tables = ((r.joints, batch.joints), (r.links, batch.links), (r.inputs, batch.inputs))
            for got, want in tables:
                assert list(got) == list(want)
                tab += [(v, want[k][n], max(L, math.pi)) for k, v in got.items()]
            assert list(r.points) == list(batch.points)
            for p, (x, y) in r.points.items():
                tab += [(x, batch.points[p][n, 0], L), (y, batch.points[p][n, 1], L)]
            for got, want, scale in tab:
                if exact:
                    assert got == want, (scene, i, got, want)
                else:
                    assert abs(got - want) <= 1e-13 * scale, (scene, i, got, want)
    assert checked >= 60, f'{scene}: too few assembling commands compared ({checked})'


def test_a_closed_form_state_reads_like_one_built_by_name_and_pickles():
    """A closed-form answer's State reads its points and poses off the run on first use: they
    are the answer's (the Result's points), a pickled snapshot restores into a fresh solver,
    and the next command is then solved exactly as by the solver it came from."""
    import pickle

    mech = scenes.load('four_bar')
    cmds = sweep_inputs(mech, 40)
    a = Solver(mech, method='closed_form')
    for c in cmds[:30]:
        last = a.solve(c)
    state = a.snapshot()[-1]
    assert {p: (z.real, z.imag) for p, z in state.points.items()} == last.points
    assert set(state.poses.phi) == set(last.links)
    b = Solver(mech, method='closed_form')
    b.restore(pickle.loads(pickle.dumps(a.snapshot())))
    for c in cmds[30:]:
        assert a.solve(c).to_dict(mech) == b.solve(c).to_dict(mech)


def _commands(mech, rng):
    """A warm sweep with jumps (some beyond reach or limits), and commands the lean path of a
    forward closed-form solve does not take: ints, numpy floats, NaN, a missing, an unknown
    and an extra name."""
    cmds = sweep_inputs(mech, 60)
    for j in range(0, len(cmds), 7):
        cmds[j] = {k: v + float(rng.normal(0, 0.8)) for k, v in cmds[j].items()}
    first = next(iter(cmds[0]))
    odd = [
        {**cmds[5], first: int(round(cmds[5][first]))},
        {k: np.float64(v) for k, v in cmds[6].items()},
        {**cmds[7], first: math.nan},
        {k: v for k, v in cmds[8].items() if k != first},
        {**cmds[9], 'no_such_name': 0.0},
    ]
    return [*cmds[:30], *odd, *cmds[30:]]


@pytest.mark.parametrize('scene', SCENES)
def test_the_lean_command_answers_what_the_general_path_answers(scene):
    """Solver.solve of a forward closed form takes a lean path for a plain dict of finite
    floats (closed_form.lean_command); anything else goes the general way (solve_one), as a
    command given as another Mapping always does. Both answer the same Result, refusal words
    included, and leave the same continuity behind (commit=False: none)."""
    from types import MappingProxyType

    mech = (
        Scene.from_dict(scenes.nut_cracker()).mechanism
        if scene == 'nut_cracker'
        else scenes.load(scene)
    )
    lean, general = Solver(mech, method='closed_form'), Solver(mech, method='closed_form')
    if lean.compiled.inverse:
        pytest.skip('the lean path is for a forward solve')
    cmds = _commands(mech, np.random.default_rng(7))
    solved = 0
    for k, c in enumerate(cmds):
        commit = k % 5 != 3
        a, b = lean.solve(c, commit), general.solve(MappingProxyType(c), commit)
        assert a.to_dict(mech) == b.to_dict(mech), (scene, k, c)
        assert a == b and b == a
        assert lean.current_signs == general.current_signs
        assert [s.margins for s in lean.snapshot()] == [s.margins for s in general.snapshot()]
        solved += a.success
    assert solved >= 20


def test_a_closed_form_result_is_a_result_in_every_use():
    """The lean Result fills its dicts on first read; it compares equal to a Result with the
    same values (either way round), copies and pickles as a plain Result, keeps a value given
    before its first read, and dataclasses.replace and asdict see every field. Its values are
    the hand-written math four-bar's (bench.core_speed: theta3 and the coupler point)."""
    import copy
    import dataclasses
    import pickle

    from linkage_ros.bench.core_speed import four_bar_dims, math_four_bar
    from linkage_ros.core.solver import Result

    mech = scenes.load('four_bar')
    dims = four_bar_dims(mech)
    solver = Solver(mech)
    for t in np.linspace(-3.0, 9.0, 25).tolist():
        r = solver.solve({'crank': t})
        assert r.success
        t3, _, x, y = math_four_bar(t, **dims)
        a, b = r.points['A'], r.points['B']
        assert abs(math.remainder(t3 - math.atan2(b[1] - a[1], b[0] - a[0]), 2 * math.pi)) < 1e-12
        assert math.dist((x, y), r.points['P']) < 1e-12 * mech.length_scale
        assert r.inputs == {'crank': t}
        plain = Result(**{f.name: getattr(r, f.name) for f in dataclasses.fields(Result)})
        assert r == plain and plain == r
        assert r != dataclasses.replace(plain, branch='x')
        for twin in (pickle.loads(pickle.dumps(r)), copy.copy(r), copy.deepcopy(r)):
            assert type(twin) is Result and twin == plain
        assert dataclasses.asdict(r) == dataclasses.asdict(plain)
        assert Result(**r.__dict__) == plain and vars(r).keys() >= {'points', 'joints'}
        assert dataclasses.replace(r, reason='why') == dataclasses.replace(plain, reason='why')
    fresh = solver.solve({'crank': 1.0})
    fresh.targets = {'given': 1.0}
    fresh.points = {}
    assert fresh.targets == {'given': 1.0} and fresh.points == {} and fresh.links
