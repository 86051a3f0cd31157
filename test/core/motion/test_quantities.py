"""Quantities designers ask for (issue 18): signed transmission angle and its extremes, an
output's swing or stroke with the input values there, and the time ratio; checked against the
closed forms of the crank-rocker and the offset slider-crank (cosine rule at the dead centres,
written here) and against a dense sweep of the 50-digit four-bar oracle."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from oracles import fourbar as oracle
from scenes import (
    CONFIG,
    CYLINDER_DRIVEN_TRIAD,
    CYLINDER_DRIVEN_TRIAD_POINTS,
    STEPHENSON_DRIVEN_AT_ITS_OUTPUT,
    STEPHENSON_III_DRIVEN_AT_ITS_OUTPUT,
    load,
)

from linkage_ros.core.motion.quantities import (
    classical_outputs,
    input_sweep,
    quantities_report,
    transmission_angles,
)
from linkage_ros.core.solver import Solver

L1, L2, L3, L4 = 0.3, 0.1, 0.25, 0.2  # config/four_bar.yaml


def close_angle(a, b, tol):
    return abs(math.remainder(a - b, 2 * math.pi)) < tol


def assert_crank_rocker_transmission(sweep) -> None:
    """The crank-rocker's transmission angle extremes by the cosine rule, crank along the
    ground (theta2 = 0 and pi), at any size of the drawing."""
    (mu,) = sweep.transmission.values()
    mu_min = math.acos((L3 * L3 + L4 * L4 - (L1 - L2) ** 2) / (2 * L3 * L4))
    mu_max = math.acos((L3 * L3 + L4 * L4 - (L1 + L2) ** 2) / (2 * L3 * L4))
    assert mu.minimum == pytest.approx(mu_min, abs=1e-12)
    assert mu.maximum == pytest.approx(mu_max, abs=1e-12)
    assert close_angle(mu.input_at_min, 0.0, 1e-6) and close_angle(mu.input_at_max, math.pi, 1e-6)


def test_crank_rocker_against_the_closed_forms():
    sweep = input_sweep(load('four_bar'), ['link:rocker'])
    assert sweep.full_turn and classical_outputs(load('four_bar')) == ['link:rocker']
    assert_crank_rocker_transmission(sweep)
    # rocker extremes: crank and coupler in line (extended, folded)
    ext = math.acos((L1 * L1 + (L2 + L3) ** 2 - L4 * L4) / (2 * L1 * (L2 + L3)))
    fold = math.pi + math.acos((L1 * L1 + (L3 - L2) ** 2 - L4 * L4) / (2 * L1 * (L3 - L2)))

    def rocker_at(theta2, reach):
        bx, by = reach * math.cos(theta2), reach * math.sin(theta2)
        return math.atan2(by, bx - L1)

    out = sweep.outputs['link:rocker']
    assert close_angle(out.input_at_min, ext, 1e-7) and close_angle(out.input_at_max, fold, 1e-7)
    assert close_angle(out.minimum, rocker_at(ext, L2 + L3), 1e-12)
    assert close_angle(out.maximum, rocker_at(fold, L2 - L3), 1e-12)
    delta = (fold - ext) % (2 * math.pi)
    want_ratio = max(delta, 2 * math.pi - delta) / min(delta, 2 * math.pi - delta)
    assert sweep.time_ratio['link:rocker'] == pytest.approx(want_ratio, rel=1e-7)
    # a dense sweep of the 50-digit oracle never leaves the reported swing
    for k in range(4000):
        theta4 = float(oracle(L1, L2, L3, L4, 2 * math.pi * k / 4000, branch=1)['theta4'])
        v = out.minimum + (theta4 - out.minimum) % (2 * math.pi)
        assert v <= out.maximum + 1e-12


def test_offset_slider_crank_stroke_and_time_ratio():
    r, rod, e = 0.05, 0.18, 0.01  # config/slider_crank.yaml
    mech = load('slider_crank')
    (name,) = classical_outputs(mech)
    sweep = input_sweep(mech, [name])
    out = sweep.outputs[name]
    x_ext, x_fold = math.sqrt((r + rod) ** 2 - e * e), math.sqrt((rod - r) ** 2 - e * e)
    assert out.maximum == pytest.approx(x_ext, abs=1e-12)
    assert out.minimum == pytest.approx(x_fold, abs=1e-12)
    t_ext, t_fold = math.atan2(e, x_ext), math.atan2(e, x_fold) + math.pi
    assert close_angle(out.input_at_max, t_ext, 1e-7)
    assert close_angle(out.input_at_min, t_fold, 1e-7)
    delta = (t_fold - t_ext) % (2 * math.pi)
    want = max(delta, 2 * math.pi - delta) / min(delta, 2 * math.pi - delta)
    assert sweep.time_ratio[name] == pytest.approx(want, rel=1e-7)
    assert sweep.time_ratio[name] > 1.0  # the offset makes the strokes unequal


def test_the_signed_transmission_angle_tells_the_modes_apart():
    """|sin mu| cannot tell the modes apart; the sign can. Both modes of one crank angle:
    equal size (the cosine rule, written here), opposite signs."""
    mech = load('four_bar')
    s = Solver(mech, method='closed_form')
    a, b = s.solve_all({'crank': 1.0})
    ((ka, mua),) = transmission_angles(s, a).items()
    ((kb, mub),) = transmission_angles(s, b).items()
    d2 = L1 * L1 + L2 * L2 - 2 * L1 * L2 * math.cos(1.0)  # |A O4|^2
    mu = math.acos((L3 * L3 + L4 * L4 - d2) / (2 * L3 * L4))
    assert ka == kb == 'A-B-O4'
    assert abs(mua) == pytest.approx(mu, abs=1e-12) and abs(mub) == pytest.approx(mu, abs=1e-12)
    assert mua * mub < 0
    assert abs(math.sin(mua)) == pytest.approx(a.margin, abs=1e-12)


def test_report_applies_to_one_input_mechanisms_only():
    assert quantities_report(load('excavator')) is None
    rep = quantities_report(load('four_bar'))
    assert rep is not None and rep['outputs']['link:rocker']['time_ratio'] > 1.0
    assert set(rep['transmission_angle']) == {'A-B-O4'}


def test_slotted_lever_quick_return_against_its_closed_form():
    """config/quick_return.yaml: crank radius r = |O2 A| = 0.1 about O2, lever pivot O4 at
    d = 0.3 below it. The lever's extremes are where it is tangent to the crank circle: it
    swings 2 asin(r / d) and the crank turns pi + 2 asin(r / d) one way, pi - 2 asin(r / d) the
    other (the classic quick-return time ratio)."""
    mech = load('quick_return')
    assert classical_outputs(mech) == ['link:lever', 'joint:ram']
    sweep = input_sweep(mech, ['link:lever'])
    alpha = math.asin(0.1 / 0.3)
    lever = sweep.outputs['link:lever']
    assert lever.maximum - lever.minimum == pytest.approx(2 * alpha, abs=1e-12)
    assert close_angle(lever.minimum, math.pi / 2 - alpha, 1e-12)  # the lever points up at rest
    assert sweep.time_ratio['link:lever'] == pytest.approx(
        (math.pi + 2 * alpha) / (math.pi - 2 * alpha), rel=1e-7
    )


def _rocker_at(l1: float, l4: float, d: float) -> float:
    """The rocker angle (rad, in [0, pi]) where |B - O2| = d: the cosine rule in the triangle
    O2 O4 B (O2 at the origin, O4 = (l1, 0), B = O4 + l4 e^{i theta4})."""
    return math.acos((d * d - l1 * l1 - l4 * l4) / (2 * l1 * l4))


@pytest.mark.parametrize(
    'scene, lengths, ends',
    [
        # non-Grashof: one circuit through both signs, the rocker's extremes where crank and
        # coupler are extended in line (|B - O2| = l2 + l3), mirrored about the ground line
        ('four_bar_non_grashof', (0.30, 0.20, 0.25, 0.22), 'mirror'),
        # Grashof double-rocker: its loop runs through both signs too, the extremes where crank
        # and coupler are in line, extended (l2 + l3) and folded (l2 - l3)
        ('four_bar_grashof_double_rocker', (0.30, 0.20, 0.10, 0.25), 'in line'),
    ],
)
def test_a_crank_stopped_by_toggles_sweeps_the_whole_circuit(scene, lengths, ends):
    """Seed 000: a crank driven from toggle to toggle comes back in the dyad's other sign; the
    rocker's range is the circuit's, as `linkage range --links` and the scene file say. check
    gave the half one sign reaches (non-Grashof swing 2.36 rad for 4.16), and refined one end in
    the other mode (2.48..2.82 for 2.00..2.82)."""
    l1, l2, l3, l4 = lengths
    if ends == 'mirror':
        low = _rocker_at(l1, l4, l2 + l3)
        want = (low, 2 * math.pi - low)
    else:
        want = (_rocker_at(l1, l4, l2 + l3), _rocker_at(l1, l4, l2 - l3))
    sweep = input_sweep(load(scene), ['link:rocker'])
    got = sweep.outputs['link:rocker']
    assert not sweep.full_turn and not sweep.turns_fully
    assert abs(got.minimum - want[0]) < 1e-12 and abs(got.maximum - want[1]) < 1e-12, got


def test_a_follower_that_turns_fully_has_no_swing_and_no_time_ratio():
    """A double-crank's follower turns fully with the crank (seed 000: 'theta4 also goes from 0
    to 2 pi'): no extremes, no time ratio (check printed a swing of 6.29 rad, over 2 pi, and a
    time ratio of 1439)."""
    sweep = input_sweep(load('four_bar_double_crank'), ['link:rocker'])
    assert sweep.full_turn and sweep.turns_fully == ('link:rocker',)
    assert 'link:rocker' not in sweep.outputs and 'link:rocker' not in sweep.time_ratio
    rep = quantities_report(load('four_bar_double_crank'))
    assert rep is not None and rep['turns_fully'] == ['link:rocker'] and not rep['outputs']


@pytest.mark.parametrize('size', [1e-300, 1e-170, 1e-150, 1.0, 1e160, 1e300])
def test_transmission_angles_at_every_size_of_the_drawing(size):
    """SCENES.md takes sizes from 2.2e-308 m to 1e308 m: the transmission angle's extremes are
    the cosine rule's at every size (its cross and dot products of lengths underflowed to 0 at
    1e-170 m, overflowed to NaN at 1e160 m; the rocker's swing was right at both)."""
    import warnings

    from scenes import four_bar

    mech = four_bar(L1 * size, L2 * size, L3 * size, L4 * size)
    with warnings.catch_warnings():
        warnings.simplefilter('error')  # no overflow warnings on the way either
        sweep = input_sweep(mech, ['link:rocker'])
    assert_crank_rocker_transmission(sweep)


@pytest.mark.parametrize('samples', [2, 0, -5, 89, 2.5, True, None])
def test_a_grid_too_coarse_to_bracket_the_extremes_is_refused(samples):
    """input_sweep(samples=2) found the non-Grashof rocker's minimum at 2.86 rad (it is 1.06:
    pi - acos((c^2 + d^2 - (a + b)^2) / 2cd)); 0 raised a bare IndexError. Refused now under
    MIN_SAMPLES, and at MIN_SAMPLES the cosine rule's minimum is found."""
    from linkage_ros.core.motion.quantities import MIN_SAMPLES

    mech = load('four_bar_non_grashof')
    with pytest.raises(ValueError, match=f'at least {MIN_SAMPLES}'):
        input_sweep(mech, ['link:rocker'], samples=samples)
    a, b, c, d = 0.30, 0.20, 0.25, 0.22  # ground, crank, coupler, rocker
    want = math.pi - math.acos((d * d + a * a - (b + c) ** 2) / (2 * a * d))
    got = input_sweep(mech, ['link:rocker'], samples=MIN_SAMPLES).outputs['link:rocker']
    assert got.minimum == pytest.approx(want, abs=1e-12)


def test_an_extreme_on_a_circuit_through_two_modes_names_the_mode_it_is_in():
    """The non-Grashof four-bar's crank swings to its toggles and back in the other mode: each
    crank value has two configurations on the circuit, so an extreme names its mode. The
    rocker's least and greatest values are the 50-digit four-bar's at their inputs in the modes
    named (branch +1: '+'), not in the other. A crank-rocker's circuit keeps one mode and names
    none."""
    from linkage_ros.core.motion.quantities import quantities_report

    dims = (0.30, 0.20, 0.25, 0.22)  # config/four_bar_non_grashof.yaml: ground crank coupler rocker
    rocker = quantities_report(load('four_bar_non_grashof'))['outputs']['link:rocker']
    for end in ('min', 'max'):
        mode, x, value = rocker[f'mode_at_{end}'], rocker[f'input_at_{end}'], rocker[end]
        assert mode in ('+', '-')
        for branch in (1, -1):
            want = float(oracle(*dims, x, branch=branch)['theta4'])
            close = abs(math.remainder(want - value, 2 * math.pi)) < 1e-9
            assert close is (('+' if branch > 0 else '-') == mode), (end, branch, want, value)
    assert rocker['mode_at_min'] != rocker['mode_at_max']
    one = quantities_report(load('four_bar'))['outputs']['link:rocker']
    assert 'mode_at_min' not in one and 'mode_at_max' not in one


def test_a_newton_placed_circuit_is_swept_over_both_halves_between_its_toggles():
    """A Stephenson six-bar driven at its output (Newton places crank, coupler, rocker, link5):
    `check` read one half of the drive's circuit between its toggles (a continuous sweep from
    the drawing) and reported the crank swinging 2.77 rad and the rocker's max 0.107 rad short
    (an outside scene author). Over both halves (the loop Jacobian's two modes) the crank
    turns fully, and the rocker's extremes are those of the four-bar O2-A-B-O4 inside it, by
    the cosine rule: |O2 B| = coupler + crank (min) and coupler - crank (max), B on the drawn
    side of the ground line; the drive there puts D on both of its circles."""
    from linkage_ros.core.model import Scene

    mech = Scene.from_dict(STEPHENSON_DRIVEN_AT_ITS_OUTPUT).mechanism
    sweep = input_sweep(mech, ['link:rocker', 'link:crank'])
    assert sweep.turns_fully == ('link:crank',)
    P = {k: tuple(map(float, v)) for k, v in STEPHENSON_DRIVEN_AT_ITS_OUTPUT['points'].items()}
    a, b = math.dist(P['O2'], P['A']), math.dist(P['A'], P['B'])
    c, d = math.dist(P['O4'], P['B']), P['O4'][0]
    rock = sweep.outputs['link:rocker']
    # Newton's answers: within its tolerance (of the length scale) at the rocker's lever c
    from linkage_ros.core.tolerances import NEWTON_TOL

    bound = 10 * NEWTON_TOL * mech.length_scale / c
    for reach, got, drive in (
        (a + b, rock.minimum, rock.input_at_min),  # (B farthest from O2: the rocker lowest)
        (b - a, rock.maximum, rock.input_at_max),
    ):
        x = (reach * reach - c * c + d * d) / (2 * d)
        bx, by = x, math.sqrt(reach * reach - x * x)
        assert abs(got - math.atan2(by, bx - d)) < bound, (got, math.atan2(by, bx - d))
        # the drive there: the crank along (min) or against (max) O2 B, the coupler's C placed
        # by its pose, D where link5 from C meets out from O6
        t = math.atan2(by, bx)
        A = (
            (a * math.cos(t), a * math.sin(t))
            if reach == a + b
            else (-a * math.cos(t), -a * math.sin(t))
        )
        phi = math.atan2(by - A[1], bx - A[0]) - math.atan2(
            P['B'][1] - P['A'][1], P['B'][0] - P['A'][0]
        )
        cx0, cy0 = P['C'][0] - P['A'][0], P['C'][1] - P['A'][1]
        C = (
            A[0] + cx0 * math.cos(phi) - cy0 * math.sin(phi),
            A[1] + cx0 * math.sin(phi) + cy0 * math.cos(phi),
        )
        D = (
            P['O6'][0] + math.dist(P['O6'], P['D']) * math.cos(drive),
            P['O6'][1] + math.dist(P['O6'], P['D']) * math.sin(drive),
        )
        assert abs(math.dist(C, D) - math.dist(P['C'], P['D'])) < 1e-9, (drive, math.dist(C, D))


def test_a_newton_placed_circuit_goes_back_from_its_cylinders_dead_centre():
    """A triad driven by a cylinder P-C on its coupler (Newton places it): the cylinder's
    stroke ends at a limit (1.3 m) and at its dead centre (1.5001 m), and the crank was read
    stopping at the dead centre (max 1.40137 rad); through it the motion goes back to the
    limit in the other Jacobian mode (an outside hydraulics engineer: crank 2.32864 at 1.3 m).
    Oracle: the four-bar O2-A-B-O4 (B on the drawing's side of O4 A) carries C; the crank
    angles where |P C| = 1.3 are the two roots, found by brentq on the cosine-rule four-bar."""
    from scipy.optimize import brentq

    from linkage_ros.core.model import Scene

    pts = CYLINDER_DRIVEN_TRIAD_POINTS
    scene = copy.deepcopy(CYLINDER_DRIVEN_TRIAD)
    scene['cylinders']['Z'].update(min=1.3, max=1.7)
    mech = Scene.from_dict(scene).mechanism
    # (every link, as `linkage check` and `range --links` read them: each extreme's search began
    # where the one before had left the solver)
    sweep = input_sweep(mech, [f'link:{link}' for link in mech.links if link != 'ground'])
    crank = sweep.outputs['link:crank']
    a = math.dist(pts['O2'], pts['A'])
    b, c = math.dist(pts['A'], pts['B']), math.dist(pts['O4'], pts['B'])
    ab0 = math.atan2(pts['B'][1] - pts['A'][1], pts['B'][0] - pts['A'][0])
    ac0 = math.atan2(pts['C'][1] - pts['A'][1], pts['C'][0] - pts['A'][0])
    ac = math.dist(pts['A'], pts['C'])

    def pc(t: float) -> float:
        ax, ay = a * math.cos(t), a * math.sin(t)
        dx, dy = 1.0 - ax, -ay
        d = math.hypot(dx, dy)
        along = (b * b - c * c + d * d) / (2 * d)
        h = math.sqrt(b * b - along * along)
        bx, by = ax + (along * dx - h * dy) / d, ay + (along * dy + h * dx) / d  # left of A O4
        phi = math.atan2(by - ay, bx - ax) - ab0 + ac0
        cx, cy = ax + ac * math.cos(phi), ay + ac * math.sin(phi)
        return math.hypot(cx - pts['P'][0], cy - pts['P'][1]) - 1.3

    # (the four-bar is non-Grashof: its crank reaches acos(-0.73) = 2.39 rad)
    roots = [brentq(pc, lo, hi, xtol=1e-15) for lo, hi in ((0.1, 0.9), (2.0, 2.38))]
    assert abs(crank.minimum - roots[0]) < 1e-9 and abs(crank.maximum - roots[1]) < 1e-9, (
        crank,
        roots,
    )
    assert abs(crank.input_at_min - 1.3) < 1e-12 and abs(crank.input_at_max - 1.3) < 1e-12


def test_a_newton_placed_links_extremes_at_the_drives_toggles_are_read_there():
    """A Stephenson-III six-bar driven at its output (Newton places the rest): the output's
    extremes over the drive's circuit are where the drive turns back, at its toggles. Each
    extreme was refined by solves walking from wherever the sweep had left the solver, which
    failed near the toggle (the crank read 0.452164 at drive 3.54594 where it is 0.4135 at the
    toggle 3.54624: an outside scene author, by 50-digit mpmath). The circuit was then read as
    the stretch between the two toggles next to the drawing, the crank swinging between them;
    it has four, and the crank turns fully (test_traced_circuits). Oracle: the drive as a
    function of the crank, by the four-bar's own circle intersections (B, then D from C on the
    drawn sides), its least and greatest over the crank's turn refined by a bounded scalar
    search."""
    from oracles import extreme_near_samples, stephenson_drive

    from linkage_ros.core.model import Scene

    scene = STEPHENSON_III_DRIVEN_AT_ITS_OUTPUT
    drive = stephenson_drive(scene['points'])
    mech = Scene.from_dict(scene).mechanism
    # (every link, as `linkage check` and `range --links` read them: each extreme's search began
    # where the one before had left the solver)
    sweep = input_sweep(mech, [f'link:{link}' for link in mech.links if link != 'ground'])
    assert sweep.turns_fully == ('link:crank',)
    output = sweep.outputs['link:output']
    cranks = np.linspace(-math.pi, math.pi, 721)
    (t_lo, d_lo), (t_hi, d_hi) = (
        extreme_near_samples(drive, cranks, sense, 0.02) for sense in (1, -1)
    )
    # the output's angle is the drive's (its offset 0): its extremes are the drive's, at them
    for value, at, want in (
        (output.minimum, output.input_at_min, d_lo),
        (output.maximum, output.input_at_max, d_hi),
    ):
        assert abs(math.remainder(value - want, 2 * math.pi)) < 1e-9, (value, want)
        assert abs(math.remainder(at - want, 2 * math.pi)) < 1e-9, (at, want)


@pytest.mark.parametrize('stem', ['scott_russell', 'hart'])
def test_a_scene_solved_by_newton_reads_its_motion_as_the_closed_form_does(stem, tmp_path):
    """The motion is geometry, whichever solver a scene asks for: with `solver: newton` the
    Scott-Russell's slider without the crank's limits was read as stroking 0 .. 0.24 m (less
    than the 0.3 m its limits alone allow) and the Hart inversor's AD swinging 3.82 rad where
    it swings 5.32, the scans walking Newton to the first toggle. Oracle: the Scott-Russell's
    slider is 2 * 0.15 cos(crank) (its AB = AC = O2A = 0.15 m), 0.3 m either way over a turn;
    the Hart inversor's, read by the closed form (that scene's own solver)."""
    import yaml

    from linkage_ros.core.model import Scene
    from linkage_ros.core.motion.common import without_limits

    text = yaml.safe_load((CONFIG / f'{stem}.yaml').read_text())
    text['solver'] = 'newton'
    forced = without_limits(Scene.from_dict(text).mechanism)
    if stem == 'scott_russell':
        slider = input_sweep(forced, ['joint:slider']).outputs['joint:slider']
        assert abs(slider.minimum + 0.3) < 1e-12 and abs(slider.maximum - 0.3) < 1e-12
        return
    closed = without_limits(load(stem))
    want = input_sweep(closed, ['link:AD']).outputs['link:AD']
    got = input_sweep(forced, ['link:AD']).outputs['link:AD']
    assert abs(got.minimum - want.minimum) < 1e-9 and abs(got.maximum - want.maximum) < 1e-9
