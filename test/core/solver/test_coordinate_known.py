"""One coordinate of a point as a known (``D.x`` / ``D.y``, m): seed 003 poses the loader's bin
by "only the x-coordinate and the orientation of this bin, and the y-coordinate will be
automatically decided" (the construction itself: test_seed_coverage_loaders.py).

Oracles: forward closed-form solves of in-limit throws (a different algorithm from the Newton
rows a coordinate known adds), and the known's own definition read off the answer's points."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scenes import load

from linkage_ros.core.errors import PlanError
from linkage_ros.core.plan import spec_for
from linkage_ros.core.quantities import CoordinateSpec
from linkage_ros.core.solver import Solver


@pytest.fixture(scope='module')
def loader():
    return load('front_loader')


def _configurations(mech):
    """Forward closed-form answers along a throw path inside the limits, in the drawing's
    assembly mode and on the drawing's side of the fold of D.x (the boom above horizontal)."""
    fwd = Solver(mech, method='closed_form', branch='reference')
    z1 = np.linspace(1.62, 2.2, 9)
    z2 = np.linspace(1.75, 2.0, 9)
    out = [fwd.solve({'Z1': a, 'Z2': b}, commit=False) for a, b in zip(z1, z2)]
    assert all(r.success for r in out)
    return out


def test_a_coordinate_name_is_its_own_known(loader):
    assert spec_for(loader, 'D.x') == CoordinateSpec('D.x', 'D', 0)
    assert spec_for(loader, 'T.y') == CoordinateSpec('T.y', 'T', 1)
    with pytest.raises(PlanError, match="point 'O7' is fixed by the ground"):
        spec_for(loader, 'O7.y')
    with pytest.raises(PlanError, match="unknown name 'D.z'"):
        spec_for(loader, 'D.z')


@pytest.mark.parametrize('axis', ['x', 'y'])
def test_a_batch_of_coordinate_targets_is_the_forward_answers_and_each_one_by_one(loader, axis):
    """Each row of a batch (D.<axis>, bin) gives back the throws it came from, its D.<axis> and
    bin as asked, and the very answer of a one-command solve of that row."""
    name, k = f'D.{axis}', 'xy'.index(axis)
    src = _configurations(loader)
    cols = {
        name: np.array([r.points['D'][k] for r in src]),
        'bin': np.array([r.links['bin'] for r in src]),
    }
    solver = Solver(loader, knowns=[name, 'bin'])
    batch = solver.solve_batch(cols)
    L = loader.length_scale
    for i, r in enumerate(src):
        assert batch.ok[i], batch.reason[i]
        for a in ('Z1', 'Z2'):
            assert batch.inputs[a][i] == pytest.approx(r.inputs[a], abs=1e-10 * L)
        assert batch.points['D'][i, k] == pytest.approx(cols[name][i], abs=1e-12 * L)
        one = Solver(loader, knowns=[name, 'bin']).solve(
            {name: cols[name][i], 'bin': cols['bin'][i]}
        )
        assert one.success, one.reason
        for p, xy in one.points.items():
            assert math.dist(xy, batch.points[p][i]) <= 1e-10 * L, p
        assert math.remainder(one.links['bin'] - cols['bin'][i], 2 * math.pi) == pytest.approx(
            0.0, abs=1e-12
        )


def test_a_coordinate_known_needs_newton_and_says_so_for_the_closed_form(loader):
    with pytest.raises(PlanError, match='no closed-form dyad plan'):
        Solver(loader, knowns=['D.x', 'bin'], method='closed_form')
    assert Solver(loader, knowns=['D.x', 'bin']).compiled.mode.value in ('hybrid', 'newton')


def test_a_sequence_of_coordinate_targets_follows_the_mechanism(loader):
    """One solver answering the path in order (each solve continues from the last): the throws
    of the source path, step by step."""
    solver = Solver(loader, knowns=['D.y', 'bin'])
    for r in _configurations(loader):
        got = solver.solve({'D.y': r.points['D'][1], 'bin': r.links['bin']})
        assert got.success, got.reason
        assert got.inputs['Z1'] == pytest.approx(r.inputs['Z1'], abs=1e-10)
        assert got.inputs['Z2'] == pytest.approx(r.inputs['Z2'], abs=1e-10)


def test_a_target_beyond_the_fold_is_found_in_mode_within_limits():
    """Given one coordinate, a Newton inverse has two roots in one assembly mode, either side of
    the coordinate's fold (the loader's boom line O4 C horizontal for C.x). The continuous
    answer from the drawing is the root beyond a limit; the rule (mode_rule: a solution in the
    current mode within limits where one exists) must find the other, the throws the target
    came from, not refuse the target as needing a throw it does not need."""
    from linkage_ros.engine import Engine, EngineSettings

    for scene, throws, names in (
        ('front_loader', {'Z1': 1.50, 'Z2': 1.6}, ('C.x', 'bin')),
        ('excavator', {'Z1': 1.1674, 'Z2': 2.0951, 'Z3': 1.436}, ('L.x', 'stick', 'bucket')),
    ):
        mech = load(scene)
        src = Solver(mech, method='closed_form', branch='reference').solve(throws)
        assert src.success
        values = {n: src.points[n[0]][0] if n.endswith('.x') else src.links[n] for n in names}
        got = Engine(mech, EngineSettings()).target(values)
        assert got.success, (scene, got.reason)
        for a, v in throws.items():
            assert got.inputs[a] == pytest.approx(v, abs=1e-9), (scene, a)


@pytest.mark.parametrize(
    ('scene', 'name'), [('scott_russell', 'C.x'), ('quick_return', 'C.y'), ('peaucellier', 'Q.x')]
)
def test_a_coordinate_the_mechanism_keeps_constant_is_refused_as_such(scene, name):
    """The straight-line point of Scott-Russell, the slotted lever's slider on its line and
    Peaucellier's Q keep one coordinate whatever the input (seed 001): as the one known it fixes
    nothing. The refusal said 'two of them fix the same motion' of a single known."""
    with pytest.raises(PlanError, match=f"the known '{name}' does not determine") as err:
        Solver(load(scene), knowns=[name])
    assert 'does not change as the mechanism moves' in str(err.value)


def test_the_refusal_of_a_constant_coordinate_names_the_modes_it_moves_in():
    """Hart's Q moves on a straight line in the drawn assembly mode, so Q.x fixes nothing
    there; where the cell closes the other way (modes ++ and --) Q.x moves with the crank. The
    refusal said it 'does not change as the mechanism moves' of every mode (an adversary's
    finding); oracle: the forward closed form in each mode at two crank angles."""
    mech = load('hart')
    with pytest.raises(PlanError, match="the known 'Q.x' does not determine") as err:
        Solver(mech, knowns=['Q.x'])
    text = str(err.value)
    assert 'in its drawn assembly mode' in text
    drawn = Solver(mech, method='closed_form').reference_values()['crank']
    moving = []
    for mode in ('++', '+-', '-+', '--'):
        fwd = Solver(mech, method='closed_form', branch=mode)
        a, b = (fwd.solve({'crank': drawn + d}, commit=False) for d in (0.1, 0.3))
        if a.success and b.success and abs(a.points['Q'][0] - b.points['Q'][0]) > 1e-6:
            moving.append(mode)
    assert moving and f'assembly mode(s) {", ".join(moving)},' in text, (moving, text)


def test_the_solutions_of_one_coordinate_carry_the_mode_they_are_in(capsys):
    """The four-bar's coupler point P at a given x: four solutions, two in each assembly mode
    (either side of the extreme of P.x in each). Each is labelled with its mode (it showed no
    branch, and the CLI called each one an assembly mode); oracle: the forward closed form at
    its crank angle in that mode places P at the same point."""
    from linkage_ros.cli.parser import main

    mech = load('four_bar')
    found = Solver(mech, knowns=['P.x']).modes({'P.x': 0.1})
    assert len(found.results) == 4
    assert sorted(r.branch for r in found.results) == ['+', '+', '-', '-']
    for r in found.results:
        fwd = Solver(mech, method='closed_form', branch=r.branch).solve(
            {'crank': r.inputs['crank']}
        )
        assert math.dist(fwd.points['P'], r.points['P']) <= 1e-12 * mech.length_scale
        assert r.points['P'][0] == pytest.approx(0.1, abs=1e-12)
    assert main(['solve', 'four_bar', '--target', 'P.x=0.1', '--all-branches']) == 0
    out = capsys.readouterr().out
    assert out.startswith('solutions: 4 found in 2 assembly mode(s) +, - (Newton')
    assert '--- solution 1 of 4 (branch ' in out


def test_a_coordinate_takes_the_point_prefix(loader):
    """`point:D.x` is D.x (the prefix docs/TOPICS.md gives for a point named like a joint): it
    was refused as 'has no point named D.x'."""
    assert spec_for(loader, 'point:D.x') == CoordinateSpec('point:D.x', 'D', 0)


@pytest.mark.parametrize('target', [{'P.x': 0.2}, {'P.y': 0.0}])
def test_a_coordinate_only_the_other_mode_reaches_is_found_on_request(target):
    """four_bar's coupler point: mode + covers P.x in [0.0034, 0.1707]; P.x = 0.2 (and P.y = 0)
    only mode - reaches. ~/target_any_mode / --any-mode refused it as out of reach (no search
    of the other modes for a target Newton places); now it is answered there with its
    mode_change, and a plain target's refusal says the other modes are searched on request.
    Oracle: the 50-digit four-bar at the answer's crank angle in mode - puts P there."""
    from oracles import fourbar

    from linkage_ros.engine import Engine, EngineSettings

    e = Engine(load('four_bar'), EngineSettings())
    plain = e.target(target)
    assert not plain.success and 'searched on request (~/target_any_mode' in plain.reason
    r = e.target(target, allow_mode_change=True)
    # (a crank-rocker's other sign: another circuit)
    assert r.success and r.mode_change == '+ -> - (another circuit)', (r.reason, r.mode_change)
    want = fourbar(0.3, 0.1, 0.25, 0.2, r.inputs['crank'], branch=-1, coupler_point=(0.18, 0.45))
    ((name, value),) = target.items()
    axis = 0 if name.endswith('.x') else 1
    assert abs(float(want['P'][axis]) - value) <= 1e-12 * 0.3
    assert math.dist(r.points['P'], [float(c) for c in want['P']]) <= 1e-12 * 0.3
