"""The batch result reading (core.assemble_batch) gives bit for bit what the generic reading
(ResultAssembler on the BATCH backend, the oracle) gives: every packaged scene, forward and
inverse solves, closed-form and Newton poses, hostile rows (NaN, inf, 1e300, subnormal) and
angles beyond (-pi, pi]."""

import math

import numpy as np
import pytest
import scenes

from linkage_ros.core.assemble_batch import assemble_batch
from linkage_ros.core.errors import PlanError
from linkage_ros.core.execute import LinkPoses, executor
from linkage_ros.core.ops import BATCH, CArray
from linkage_ros.core.plan import Poses, ReadKind, link_poses
from linkage_ros.core.quantities import PointSpec
from linkage_ros.core.solver import Solver

_STEMS = scenes.SHIPPED
_HOSTILE = [math.nan, math.inf, -math.inf, 1e300, -1e300, 5e-324, -0.0, 1e-310, 7.0, -40.0]


def _bits(a):
    a = np.ascontiguousarray(np.asarray(a, float))
    return a.shape, a.tobytes()


def _assert_same(got, want):
    for table in ('inputs', 'joints', 'links'):
        g, w = getattr(got, table), getattr(want, table)
        assert list(g) == list(w), table
        for k in w:
            assert _bits(np.broadcast_to(g[k], np.shape(w[k]))) == _bits(w[k]), (table, k)
    assert _bits(got.residual) == _bits(want.residual)


def _columns(solver, n, rng):
    """Commands near the reference pose, and the hostile values in a row of their own each."""
    cols = []
    for s, v in zip(solver.compiled.specs, solver.compiled.ref_values):
        if isinstance(s, PointSpec):
            a = np.asarray(v, float) + rng.normal(0.0, 0.02, (n, 2))
            a[: len(_HOSTILE), 0] = _HOSTILE
        else:
            a = float(v) + rng.normal(0.0, 0.3, n)
            a[: len(_HOSTILE)] = _HOSTILE
        cols.append(a)
    return cols


def _solvers(mech):
    for knowns in scenes.knowns_sets(mech):
        for method in ('closed_form', 'newton'):
            try:
                yield Solver(mech, knowns=knowns, method=method)
            except (ValueError, PlanError):
                continue


@pytest.mark.parametrize('stem', _STEMS)
def test_batch_reading_is_the_generic_reading_bit_for_bit(stem):
    mech = scenes.load(stem)
    rng = np.random.default_rng(len(stem))
    n = 300
    tried = 0
    for solver in _solvers(mech):
        c = solver.compiled
        values = _columns(solver, n, rng)
        with np.errstate(all='ignore'):
            if c.plan.complete:  # the closed form's poses (the ground's are one value)
                run = executor(c.plan).run(values, n, c.plan.reference_signs)
                poses = run.poses
            else:  # Newton-like poses: every link an array of its own
                phi = {l: rng.normal(0.0, 2.0, n) for l in mech.links}
                T = {l: rng.normal(0.0, 1.0, (n, 2)) for l in mech.links}
                poses = link_poses(Poses(phi, T))
            asm = c.assembler(poses.phi)
            _assert_same(assemble_batch(asm, poses, values), asm(BATCH, poses, values))
            # angles far beyond (-pi, pi] (the wrap's reduction) on every link
            wide = LinkPoses(
                {l: v + 5.0 * (i + 1) for i, (l, v) in enumerate(poses.phi.items())},
                poses.rot,
                poses.T,
            )
            _assert_same(assemble_batch(asm, wide, values), asm(BATCH, wide, values))
            _assert_releases(asm, poses, values)
        tried += 1
    assert tried


def _assert_releases(asm, poses, values):
    """release=True (the batch solve's: its poses are done with after the reading) gives the
    same reading, and takes out of the poses the rot and T of every link, but those the
    knowns' point and slide readings need (read last, unless read before); phi stays whole."""
    mine = LinkPoses(dict(poses.phi), dict(poses.rot), dict(poses.T))
    want = asm(BATCH, poses, values)
    _assert_same(assemble_batch(asm, mine, values, release=True), want)
    kept = set()
    earlier = {r for _, i, r in asm.inputs if i is None} | {s[3] for s in asm.slides}
    for _, read in asm.knowns:
        if read in earlier:  # read before (once): its value kept, not its poses
            continue
        if read.kind is ReadKind.POINT:
            kept.add(read.link)
        elif read.kind is ReadKind.SLIDE:
            kept |= {read.link, read.reference}
    read_links = {l for _, child, parent, *_ in asm.revolutes for l in (child, parent)}
    read_links |= {l for _, slider, guide, *_ in asm.slides for l in (slider, guide)}
    assert set(mine.rot) == set(mine.T) == (set(poses.rot) - read_links) | (kept & set(poses.rot))
    assert mine.phi == poses.phi


def test_batch_reading_of_one_pose_in_every_row():
    """Poses that are one value in every row (read-only views, as the executor gives the
    ground's) on both sides of a joint: still the generic reading, in an array per row."""
    mech = scenes.load('four_bar')
    solver = Solver(mech, method='closed_form')
    c = solver.compiled
    n = 7
    run = executor(c.plan).run([np.full(n, 0.4)], n, c.plan.reference_signs)
    one = LinkPoses(
        {l: np.broadcast_to(v[0], (n,)) for l, v in run.poses.phi.items()},
        {
            l: CArray(*(np.broadcast_to(x[0], (n,)) for x in (z.re, z.im)))
            for l, z in run.poses.rot.items()
        },
        {
            l: CArray(*(np.broadcast_to(x[0], (n,)) for x in (z.re, z.im)))
            for l, z in run.poses.T.items()
        },
    )
    asm = c.assembler(one.phi)
    values = [np.full(n, 0.4)]
    got, want = assemble_batch(asm, one, values), asm(BATCH, one, values)
    _assert_same(got, want)
    assert np.shape(got.residual) == (n,)
