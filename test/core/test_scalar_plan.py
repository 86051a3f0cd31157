"""A plan's one-command program (core.scalar_plan) against the batch executor it twins
(core.execute on numpy), step kind by step kind: every packaged scene, every set of knowns it
admits in closed form (forward, inverse by joints, point targets: ground, known points, rigid
transfers, point + angle, angle relations, RRR, RRP and RPR dyads), both branch choices, and
commands spread wide enough that some dyads do not close.

Each command's run equals its batch row: whether it closed, the step that did not and by how
much, the branch signs and dyad margins, every point and link pose; except at a change point
(coincident circles), where one command has a rule of its own (executor and program alike). As in
test/core/solver/test_closed_form.py, value for value where numpy's sin, cos and arctan2 round
as libm's on this machine, else within 1e-13 of the length scale.
"""

from __future__ import annotations

import math

import numpy as np
import oracles
import pytest
import scenes

from linkage_ros.core.errors import PlanError
from linkage_ros.core.model import Scene
from linkage_ros.core.scalar_plan import program
from linkage_ros.core.solver import Solver

SHIPPED = scenes.SHIPPED
#: and a roller on a flat face (its SIDE step: both sides of the face)
SCENES = [*SHIPPED, 'nut_cracker']


def _mech(scene):
    if scene == 'nut_cracker':
        return Scene.from_dict(scenes.nut_cracker()).mechanism
    return scenes.load(scene)


def _complete_plans(mech):
    """(closed-form Solver, its complete plan) for every knowns set of ``mech`` that has one."""
    for knowns in scenes.knowns_sets(mech):
        try:
            s = Solver(mech, knowns=knowns, method='closed_form', branch='reference')
        except PlanError:
            continue
        if s.compiled.full_plan.complete:
            yield s, s.compiled.full_plan


@pytest.mark.parametrize('scene', SCENES)
def test_a_run_equals_its_batch_row(scene):
    mech = _mech(scene)
    L = mech.length_scale
    rng = np.random.default_rng(3)
    n, compared, kinds = 16, 0, set()
    for s, plan in _complete_plans(mech):
        kinds |= {st.op for st in plan.steps}
        ref = s.compiled.ref_values
        cols = []
        for v in ref:
            if np.ndim(v):
                cols.append(np.asarray(v, float) + rng.normal(0, 0.1 * L, (n, 2)))
            else:
                cols.append(float(v) + rng.normal(0, 0.5, n))
        exact = oracles.trig_is_libm(np.concatenate([c.reshape(-1) for c in cols]))
        for signs in {plan.reference_signs, tuple(-x for x in plan.reference_signs)}:
            poses, points, info = plan.run(cols, n, signs)
            for i in range(n):
                vals = [c[i] if c.ndim == 2 else float(c[i]) for c in cols]
                run = program(plan).run(vals, signs)
                if run.ok and 0.0 in run.margins:
                    # a change point (coincident circles: a rhombus folded flat) or an exact
                    # toggle: one command keeps the point continuity predicts, a batch has no
                    # such rule; both see the configuration as degenerate
                    assert not info['ok'][i] or info['margin'][i] < 1e-6, (s.knowns, i)
                    continue
                assert run.ok == bool(info['ok'][i]), (s.knowns, i)
                if not run.ok:
                    assert run.failure == info['failure'][i]
                    # (the violation, how far the dyad is from closing: its last bits too)
                    v, want = run.violation, info['violation'][i]
                    assert v == want if exact else abs(v - want) <= 1e-12 * max(abs(want), L)
                    continue
                compared += 1
                assert run.signs == tuple(info['signs'][i])
                pairs = [(run.margin, info['margin'][i], 1.0)]
                assert list(run.points) == list(points)
                for p, z in run.points.items():
                    pairs += [(z.real, points[p][i, 0], L), (z.imag, points[p][i, 1], L)]
                assert list(run.poses.phi) == list(poses.phi)
                for link, phi in run.poses.phi.items():
                    T = run.poses.T[link]
                    pairs += [(phi, poses.phi[link][i], math.pi)]
                    pairs += [(T.real, poses.T[link][i, 0], L), (T.imag, poses.T[link][i, 1], L)]
                # where numpy's trigonometry is not libm's, the last bits differ and a dyad
                # near its toggle magnifies them as 1 / margin (|sin| of its transmission angle)
                near = 1.0 / min(1.0, max(run.margin, 1e-6))
                for got, want, scale in pairs:
                    if exact:
                        assert got == want, (s.knowns, i, got, want)
                    else:
                        assert abs(got - want) <= 1e-13 * scale * near, (s.knowns, i, got, want)
    assert compared >= 16, f'{scene}: too few closing commands compared ({compared})'


def test_links_a_run_turns_alike_have_the_very_same_angle_and_rotation():
    """ScalarProgram.same_turn names the links a slide weld joins (the member moved along the
    slide, not turned) within a welded body: every run sets their angle and rotation registers
    to the same floats, so the readout skips their angle's miss (closed_form). Over the knowns
    of every shipped scene with such a weld, on commands spread wide around the reference."""
    rng = np.random.default_rng(11)
    pairs_seen = 0
    for scene in SCENES:
        mech = _mech(scene)
        for s, plan in _complete_plans(mech):
            prog = program(plan)
            if not prog.same_turn:
                continue
            for _ in range(12):
                vals = [
                    np.asarray(v, float) + rng.normal(0, 0.1 * mech.length_scale, 2)
                    if np.ndim(v)
                    else float(v) + float(rng.normal(0, 0.3))
                    for v in s.compiled.ref_values
                ]
                run = program(plan).run(vals)
                if not run.ok:
                    continue
                for pair in prog.same_turn:
                    a, b = sorted(pair)
                    pairs_seen += 1
                    assert run.poses.phi[a] == run.poses.phi[b], (scene, s.knowns, pair)
                    assert run.poses.rot[a] == run.poses.rot[b], (scene, s.knowns, pair)
    assert pairs_seen >= 20
