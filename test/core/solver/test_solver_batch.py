"""One command and a batch give the same answers (plan.run_one and solve_batch on every
shipped scene), and warm-started Newton over a batch of instances (Solver.solve_batch(start=)):
against the closed form, the careful path for the rows it cannot vouch for, and its checks of
the start and the columns."""

import math

import numpy as np
import pytest
import scenes
from scenes import CONFIG, four_bar, slider_crank
from solver_core_helpers import AGREE, CRANK_ROCKER, TIGHT, TRIPLE_ROCKER

from linkage_ros.core.errors import PlanError
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Result, Solver, compiling

# ---- one command and a batch: the same answers (plan.run_one and solve_batch) -----------------

SHIPPED = scenes.SHIPPED


@pytest.mark.parametrize('scene', SHIPPED)
def test_one_command_and_batch_backends_agree(scene):
    """Solver.solve (the one-command program) and Solver.solve_batch (the batch executor):
    for every knowns set a shipped scene admits in closed form, with all outputs and pruned to
    one, they agree on success, points, joints, links and inputs to 1e-12 of the length scale,
    and both close their loops."""
    mech = Scene.from_yaml(f'config/{scene}.yaml').mechanism
    L = mech.length_scale
    rng = np.random.default_rng(7)
    checked = 0
    for knowns in scenes.knowns_sets(mech):
        for outputs in (None, list(mech.outputs)[:1]):
            try:
                s = Solver(
                    mech, knowns=knowns, outputs=outputs, method='closed_form', branch='reference'
                )
            except PlanError:
                continue
            ref = s.reference_values()
            cols = {}
            for k, v in ref.items():
                if isinstance(v, (list, tuple)):
                    cols[k] = np.asarray(v, float) + rng.normal(0, 0.05 * L, (12, 2))
                else:  # wide spread: some commands are beyond a limit or do not assemble
                    cols[k] = v + rng.normal(0, 0.6, 12)
            batch = s.solve_batch(cols)
            for i in range(12):
                cmd = {k: (c[i].tolist() if c.ndim == 2 else float(c[i])) for k, c in cols.items()}
                r = s.solve(cmd)
                assert r.success == bool(batch.ok[i]), (
                    knowns,
                    outputs,
                    cmd,
                    r.reason,
                    batch.reason[i],
                )
                if not r.success:
                    continue
                checked += 1
                assert r.residual <= TIGHT and batch.residual[i] <= TIGHT
                assert set(r.points) == set(batch.points)
                for p, xy in r.points.items():
                    assert np.max(np.abs(np.asarray(xy) - batch.points[p][i])) <= TIGHT * L, p
                for table, got in (
                    (batch.joints, r.joints),
                    (batch.links, r.links),
                    (batch.inputs, r.inputs),
                ):
                    assert set(got) == set(table)
                    for name, v in got.items():
                        d = v - table[name][i]
                        if name in mech.joint_names and name in mech.prismatics:
                            assert abs(d) <= TIGHT * L, name
                        else:  # angles: compare on the circle
                            assert abs(math.remainder(d, 2 * math.pi)) <= TIGHT, name
    assert checked >= 6, f'{scene}: too few assembling commands to compare ({checked})'


# ---- warm-started Newton over a batch of instances (Solver.solve_batch(start=)) ---------------


def _instance_paths(mech, n, steps):
    """n instances spread along a closed path through the actuator ranges, each moving one
    small step per batch: columns for steps 0..steps."""
    ref = Solver(mech, method='newton').reference_values()
    out = []
    for k in range(steps + 1):
        cols = {}
        for j, a in enumerate(mech.actuators):
            act = mech.actuators[a]
            phase = 2 * np.pi * (np.arange(n) / n) + 0.02 * k
            if act.min is None or act.max is None:
                cols[a] = ref[a] + phase
            else:
                mid, amp = 0.5 * (act.min + act.max), 0.3 * (act.max - act.min)
                cols[a] = mid + amp * np.sin(phase * (j + 1))
        out.append(cols)
    return out


@pytest.mark.parametrize('scene', ['four_bar', 'slider_crank', 'peaucellier', 'excavator'])
def test_newton_batch_of_instances_matches_the_closed_form(scene):
    """Each row is one mechanism advancing along its own path, warm-started from its previous
    answer. Oracle: the dyad plan (a different method) at the same inputs on the reference
    branch. The rows are answered mostly by the vectorised path, all close their loops."""
    mech = Scene.from_yaml(f'config/{scene}.yaml').mechanism
    L = mech.length_scale
    newton = Solver(mech, method='newton')
    closed = Solver(mech, method='closed_form', branch='reference')
    paths = _instance_paths(mech, 40, 3)
    batch = newton.solve_batch(paths[0])  # no start: the rows are solved as one path
    assert batch.ok.all() and batch.x is not None
    for cols in paths[1:]:
        batch = newton.solve_batch(cols, start=batch)
        want = closed.solve_batch(cols)
        assert batch.ok.all() and want.ok.all()
        assert np.sum(batch.careful) <= 4, np.sum(batch.careful)
        assert np.max(batch.residual) <= TIGHT
        for p in mech.points:
            assert np.max(np.abs(batch.points[p] - want.points[p])) <= AGREE * L, p
        assert np.array_equal(batch.signs, want.signs)
        for j in mech.joint_names:
            assert np.max(
                np.abs(np.remainder(batch.joints[j] - want.joints[j] + np.pi, 2 * np.pi) - np.pi)
            ) <= AGREE * max(L, 1.0), j


@pytest.mark.parametrize('scene', ['four_bar', 'slider_crank', 'peaucellier', 'excavator'])
def test_newton_batch_of_instances_one_sweep_step_each(scene):
    """The bench's case: the 200 inputs of a closed sweep as 200 instances, each warm-started
    from its answer at the input before it. Oracle: the scalar Solver walking the sweep one
    command at a time. Every row is answered by the vectorised path (none by the careful path:
    on the excavator 16 first steps from the start cut max|F| only 9.6-9.9-fold, judged now as
    the scalar path's prediction is), on the scalar answer's branch, within 1e-10 of its
    points."""
    from linkage_ros.bench import sweep_inputs

    mech = Scene.from_yaml(f'config/{scene}.yaml').mechanism
    L = mech.length_scale
    cmds = sweep_inputs(mech, 200)
    walk = Solver(mech, method='newton')
    want = [walk.solve(c) for c in cmds]
    assert all(r.success for r in want)
    newton = Solver(mech, method='newton')
    cols = {a: np.array([c[a] for c in cmds], float) for a in mech.actuators}
    start = newton.solve_batch({a: np.roll(v, 1) for a, v in cols.items()})
    batch = newton.solve_batch(cols, start=start)
    assert batch.ok.all() and batch.careful is not None and not batch.careful.any()
    assert np.max(batch.residual) <= TIGHT
    for p in mech.points:
        got = batch.points[p]
        ref = np.array([r.points[p] for r in want])
        assert np.max(np.abs(got - ref)) <= 1e-10 * L, p
    assert [batch.row(i).branch for i in range(200)] == [r.branch for r in want]


def test_newton_batch_rows_it_cannot_vouch_for_take_the_careful_path():
    """Bad rows fail with a reason and leave the others alone; a big jump (no fast-path proof)
    is solved by Solver.solve's careful path from that row's start, like the closed form; a row
    whose start failed starts from the reference pose; an input past a toggle is refused."""
    mech = four_bar(*TRIPLE_ROCKER)  # non-Grashof: the crank cannot turn fully
    newton = Solver(mech, method='newton')
    closed = Solver(mech, method='closed_form', branch='reference')
    t0 = closed.reference_values()['crank']
    start = newton.solve_batch({'crank': np.array([t0, t0 + 0.1, t0, t0 - 0.1, np.nan])})
    assert list(start.ok) == [True, True, True, True, False]
    cmd = np.array([t0 + 0.02, t0 + 0.12, np.nan, t0 + 0.9, t0 + 0.03])
    before = newton.snapshot()
    got = newton.solve_batch({'crank': cmd}, start=start)
    assert newton.snapshot() == before  # the solver's own state is untouched
    assert not got.ok[2] and 'finite' in got.reason[2]
    assert got.careful[3] and got.careful[4] and not got.careful[0] and not got.careful[1]
    want = closed.solve_batch({'crank': np.nan_to_num(cmd)})
    for i in (0, 1, 3, 4):
        assert got.ok[i] == want.ok[i], (i, got.reason[i], want.reason[i])
        if got.ok[i]:
            for p in mech.points:
                assert np.max(np.abs(got.points[p][i] - want.points[p][i])) <= AGREE * 4.0
    # crank at 0 rad: A = (3, 0) is 1 from O4 (4, 0), closer than coupler - rocker = 2.5
    far = newton.solve_batch({'crank': np.zeros(5)}, start=got)
    assert not far.ok.any(), 'a crank angle outside the input range was assembled'
    assert all(far.reason)


def test_newton_batch_start_is_checked():
    mech = four_bar(*CRANK_ROCKER)
    newton = Solver(mech, method='newton')
    t = np.linspace(0.0, 1.0, 5)
    start = newton.solve_batch({'crank': t})
    with pytest.raises(ValueError, match='5 rows'):
        newton.solve_batch({'crank': t[:3]}, start=start)
    closed = Solver(mech, method='closed_form')
    with pytest.raises(ValueError, match='newton'):
        closed.solve_batch({'crank': t}, start=start)
    with pytest.raises(ValueError, match='newton BatchResult'):
        newton.solve_batch({'crank': t}, start=closed.solve_batch({'crank': t}))


def test_newton_batch_start_must_come_from_the_same_solver_and_be_intact():
    mech = four_bar(*CRANK_ROCKER)
    newton = Solver(mech, method='newton')
    t = np.linspace(0.0, 1.0, 5)
    start = newton.solve_batch({'crank': t})
    # the same width (9 unknowns) but another mechanism: its x means something else
    other = Solver(slider_crank(0.05, 0.18, 0.01), method='newton')
    assert other.system.n == newton.system.n
    with pytest.raises(ValueError, match="mechanism \\('slider_crank'.*got one of 'four_bar'"):
        other.solve_batch({'crank': t}, start=start)
    # another four-bar geometry under the same names
    with pytest.raises(ValueError, match='reference geometry'):
        Solver(four_bar(0.3, 0.1, 0.26, 0.2), method='newton').solve_batch(
            {'crank': t}, start=start
        )
    for field, bad in (
        ('det_sign', start.det_sign[:3]),
        ('x', start.x.tolist()),
        ('ok', start.ok[:2]),
    ):
        tampered = newton.solve_batch({'crank': t})
        setattr(tampered, field, bad)
        with pytest.raises(ValueError, match='wrong shape'):
            newton.solve_batch({'crank': t}, start=tampered)
    # an intact start still works, and an empty batch is an empty result, in every mode
    assert newton.solve_batch({'crank': t}, start=start).ok.all()
    for method in ('closed_form', 'newton'):
        b = Solver(mech, method=method).solve_batch({'crank': []})
        assert b.n == 0 and b.ok.shape == (0,) and b.points['B'].shape == (0, 2)
    b = newton.solve_batch({'crank': []})
    assert newton.solve_batch({'crank': []}, start=b).n == 0


def test_batch_columns_must_hold_real_numbers():
    solver = Solver(four_bar(*CRANK_ROCKER))
    for bad, kind in (
        ([True, False], 'bool'),
        (['0.5', '1.0'], '<U3'),
        ([0.5 + 1j, 1.0], 'complex'),
        ([{}, 1.0], 'object'),
    ):
        with pytest.raises(ValueError, match=f"column 'crank' must hold real numbers.*{kind}"):
            solver.solve_batch({'crank': bad})
    with pytest.raises(ValueError, match=r"column 'crank' must have shape \(n,\)"):
        solver.solve_batch({'crank': np.zeros((3, 2))})
    pts = Solver(Scene.from_yaml(CONFIG / 'plagiograph.yaml').mechanism, knowns=['point:D'])
    with pytest.raises(ValueError, match=r"column 'point:D' must have shape \(n, 2\)"):
        pts.solve_batch({'point:D': np.zeros(6)})
    assert solver.solve_batch({'crank': np.array([1, 2], dtype=np.int32)}).ok.all()


def test_command_values_of_the_wrong_type_are_refused_by_name():
    mech = Scene.from_yaml(CONFIG / 'plagiograph.yaml').mechanism
    solver = Solver(mech, knowns=['point:D'])
    ref = solver.solve({'point:D': tuple(mech.points['D'])})
    assert ref.success
    for bad in (
        ['0.12', '0.18'],
        [True, False],
        (0.12 + 1j, 0.18),
        '12',
        {'x': 1, 'y': 2},
        (10**400, 0.18),
    ):
        r = solver.solve({'point:D': bad})
        assert (
            not r.success
            and r.reason.startswith('point:D: a point needs two numbers')
            or 'finite' in r.reason
        ), (bad, r.reason)
    crank = Solver(four_bar(*CRANK_ROCKER))
    for big in (10**400, -(10**400)):
        r = crank.solve({'crank': big})
        # the echo is cut to 80 characters (one rule for every echoed value)
        assert (
            not r.success and r.reason == f'crank: value must be finite (got {repr(big)[:77]}...)'
        )
    # nothing changed: the same answer as before the refusals
    again = solver.solve({'point:D': tuple(mech.points['D'])})
    assert again.points == ref.points


def test_solver_arguments_of_the_wrong_type_are_refused():
    mech = four_bar(*CRANK_ROCKER)
    with pytest.raises(PlanError, match='tolerance'):
        Solver(mech, tol=True)
    with pytest.raises(PlanError, match='max_iter'):
        Solver(mech, max_iter=True)
    with pytest.raises(PlanError, match="outputs must be a list of names \\(got 'AB'\\)"):
        Solver(mech, outputs='AB')
    for knowns in ([None], [1], 'crank'):
        with pytest.raises(PlanError, match='knowns must be a list of names'):
            Solver(mech, knowns=knowns)


def test_knowns_that_do_not_determine_the_mechanism_are_refused():
    """A point on a grounded crank gives 2 values but fixes 1 motion: with it as the only known
    of a 2-DOF mechanism another link stays free (J singular everywhere). Refused at
    construction, naming the knowns; independent knowns of the same count are fine."""
    mech = Scene.from_yaml(CONFIG / 'plagiograph.yaml').mechanism
    for point in ('A', 'C'):
        with pytest.raises(
            PlanError,
            match=rf"knowns \['point:{point}'\] do not determine "
            "'plagiograph'.*leave a motion of '(\\w+)' free",
        ):
            Solver(mech, knowns=[f'point:{point}'])
    for knowns in (['point:D'], ['point:E'], ['theta_A', 'link:ABD'], None):
        Solver(mech, knowns=knowns)
    # O2-A-B-C is a parallelogram: BCE turns with crank_A, so its angle and theta_A fix one
    # motion and leave crank_C free (the sparsity pattern cannot see it; J is singular in
    # every pose). This pair used to be accepted and answered with an arbitrary crank_C.
    with pytest.raises(
        PlanError,
        match=r"knowns \['theta_A', 'link:BCE'\] do not determine.*"
        'fix the same motion',
    ):
        Solver(mech, knowns=['theta_A', 'link:BCE'])
    loader = Scene.from_yaml(CONFIG / 'front_loader.yaml').mechanism
    with pytest.raises(PlanError, match='do not determine'):
        Solver(loader, knowns=['point:A'])


def test_closure_guard_refuses_a_false_assembly(monkeypatch):
    """The last line of defence: without the structural check above, the hybrid solve placed
    the crank through a known point out of its reach (two known points) and reported success
    with its loop open by 0.126 of the length scale. The closure guard refuses it, scalar and
    batch; a point on the crank circle still solves."""
    from linkage_ros.core.newton import LoopSystem

    monkeypatch.setattr(LoopSystem, 'unfixed_links', lambda self: [])
    monkeypatch.setattr(compiling, 'check_determined', lambda c, n: None)
    mech = Scene.from_yaml(CONFIG / 'plagiograph.yaml').mechanism
    solver = Solver(mech, knowns=['point:A'])
    assert solver.mode == 'hybrid'
    r = solver.solve({'point:A': (0.3, 0.1)})  # |O2 A| = 0.316, the crank is 0.25
    assert not r.success and r.reason.startswith(
        'cannot assemble: the configuration found misses loop closure by 0.126'
    )
    on = tuple(mech.points['A'])
    b = solver.solve_batch({'point:A': np.array([(0.3, 0.1), on])})
    assert b.ok.tolist() == [False, True] and b.reason[0] == r.reason
    good = solver.solve({'point:A': on})
    assert good.success and good.residual <= 1e-12
    assert math.dist(good.points['A'], on) < 1e-12


def test_adopt_and_restore_refuse_what_is_not_a_configuration():
    """adopt() returns False and restore() raises for anything unusable, and neither changes
    the solver: the next solves are those of a solver that never saw them."""
    mech = four_bar(*CRANK_ROCKER)
    clean, probed = Solver(mech, method='newton'), Solver(mech, method='newton')
    first = clean.solve({'crank': 0.4})
    assert probed.solve({'crank': 0.4}).points == first.points
    broken = []
    r = Solver(mech).solve({'crank': 0.9})
    nan_point = Result(**{**r.__dict__, 'points': {**r.points, 'B': (math.nan, 0.0)}})
    moved = Result(
        **{**r.__dict__, 'points': {**r.points, 'B': (r.points['B'][0] + 1e-3, r.points['B'][1])}}
    )
    no_point = Result(**{**r.__dict__, 'points': {k: v for k, v in r.points.items() if k != 'B'}})
    bad_angle = Result(**{**r.__dict__, 'links': {**r.links, 'coupler': 'x'}})
    broken += [nan_point, moved, no_point, bad_angle, Result(False, 'no'), None, 'xyz']
    for b in broken:
        assert probed.adopt(b) is False, b
    for snap in ('xyz', [1, 2], (None,)):
        with pytest.raises(ValueError, match='restore'):
            probed.restore(snap)
    assert probed.adopt(r)  # a real configuration is adopted
    clean.adopt(r)
    for t in (1.0, 1.2, 1.5):
        assert probed.solve({'crank': t}).points == clean.solve({'crank': t}).points


@pytest.mark.parametrize('value', [np.array(1.0), np.array(1), np.float32(1.0), np.array(1.0)[()]])
def test_solve_takes_a_0d_array_as_solve_batch_does(value):
    """solve_batch took a 0-d array as a batch of one; solve refused it ('value must be a
    number in rad (got array(1.))'). Oracle: the same command as a plain float."""
    mech = scenes.load('four_bar')
    got = Solver(mech).solve({'crank': value})
    want = Solver(mech).solve({'crank': float(value)})
    assert got.success, got.reason
    assert got.points == want.points and got.joints == want.joints
    refused = Solver(mech).solve({'crank': np.array([1.0])})  # (not a number: one row of one)
    assert not refused.success and 'must be a number' in refused.reason


@pytest.mark.parametrize('method', ['closed_form', 'newton'])
def test_a_refused_rows_signs_are_0_as_documented(method):
    """BatchResult: signs (n, k), 0 in a refused row. The closed form's kept the fixed branch
    signs in rows refused for NaN or for not assembling (the Newton path's were 0)."""
    mech = scenes.load('four_bar_non_grashof')
    solver = Solver(mech, method=method)
    cols = {'crank': np.array([0.5, math.nan, 3.0, 1.0])}  # 3.0: past the toggles
    got = solver.solve_batch(cols)
    assert got.ok.tolist() == [True, False, False, True]
    assert got.signs[~got.ok].tolist() == [[0], [0]]
    assert np.all(got.signs[got.ok] != 0)


@pytest.mark.parametrize('method', ['newton', 'closed_form'])
@pytest.mark.parametrize(
    'taken, given',
    [('four_bar', 'quick_return'), ('quick_return', 'four_bar'), ('slider_crank', 'four_bar')],
)
def test_restore_refuses_another_mechanisms_snapshot(method, taken, given):
    """restore() checked only the number of values: a snapshot of another mechanism with a
    known of the same name ('crank') was taken, and the next Newton solve raised IndexError or
    AttributeError, or refused a reachable command. ValueError now, and no change."""
    a, b = Solver(scenes.load(taken), method=method), Solver(scenes.load(given), method=method)
    assert a.solve({'crank': 1.0}).success and b.solve({'crank': 1.1}).success
    before = b.snapshot()
    with pytest.raises(ValueError, match='of a solver of this mechanism'):
        b.restore(a.snapshot())
    assert b.snapshot() == before
    fresh = Solver(scenes.load(given), method=method)
    fresh.restore(before)  # a snapshot of its own mechanism is taken
    assert fresh.solve({'crank': 1.2}).points == b.solve({'crank': 1.2}).points
