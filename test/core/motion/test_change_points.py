"""Change points: where a dyad's two solutions cross (seed 000's s + l = p + q; seed 001's
Scott-Russell with O2A = AB = AC), the motion carries on smoothly into the other sign, as the
continuous solve and a real mechanism do. `linkage check` / `range` follow the motion there, not
the fixed sign that turns a corner onto the other curve. Checked against formulas written here:
B = 2 a cos(theta) for the Scott-Russell, the cosine rule at crank and coupler in line for a
change-point four-bar (its smooth motion takes two crank turns to repeat), a parallelogram's
rocker turning with its crank."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scenes import double_parallelogram, four_bar

from linkage_ros.core.model import Scene
from linkage_ros.core.motion import actuator_range, oscillation_range, toggle_positions
from linkage_ros.core.motion.circuits import reference_circuit
from linkage_ros.core.motion.quantities import quantities_report
from linkage_ros.core.motion.touches import crosses, crossing_root
from linkage_ros.core.solver import Solver
from linkage_ros.engine import Engine, EngineSettings


def scott_russell(a: float, drawn_at: float) -> Scene:
    """O2A = AB = AC = a (m), the slider on the x axis through O2, drawn at crank ``drawn_at``
    (rad, |drawn_at| < pi / 2: B = 2 a cos on the positive side), the crank unlimited."""
    ax, ay = a * math.cos(drawn_at), a * math.sin(drawn_at)
    bx = 2 * a * math.cos(drawn_at)
    return _slider_on_x(
        'scott_russell_free',
        {'O2': [0.0, 0.0], 'A': [ax, ay], 'B': [bx, 0.0], 'C': [2 * ax - bx, 2 * ay]},
        ['B', 'A', 'C'],
        {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'A'}},
    )


def _slider_on_x(name: str, points: dict, rod: list, actuators: dict) -> Scene:
    """A slider-crank scene: crank O2 A, a rod through ``rod``'s points, the slider B on the x
    axis through O2 (the slide ``s``, measured from O2)."""
    return Scene.from_dict(
        {
            'name': name,
            'points': points,
            'links': {'ground': ['O2'], 'crank': ['O2', 'A'], 'rod': rod, 'slider': ['B']},
            'sliders': [
                {
                    'name': 's',
                    'guide': 'ground',
                    'slider': 'slider',
                    'point': 'B',
                    'direction': 0.0,
                    'origin': 'O2',
                }  # fmt: skip
            ],
            'actuators': actuators,
        }
    )


@pytest.mark.parametrize(('a', 'drawn_at'), [(0.1, math.pi / 3), (0.037, -1.2), (2.5, 0.1)])
def test_scott_russell_through_a_full_turn_strokes_4a_with_time_ratio_1(a, drawn_at):
    mech = scott_russell(a, drawn_at).mechanism
    report = quantities_report(mech)
    assert report is not None and report['full_turn']
    s = report['outputs']['joint:s']
    # B = 2 a cos(theta): 2a at theta = 0, -2a at theta = pi (the fixed sign parks B on O2
    # past +-90 deg: stroke 2a, time ratio 2.98)
    assert s['max'] == pytest.approx(2 * a, rel=1e-12)
    assert s['min'] == pytest.approx(-2 * a, rel=1e-12)
    assert abs(math.remainder(s['input_at_max'], 2 * math.pi)) < 1e-6
    assert abs(math.remainder(s['input_at_min'] - math.pi, 2 * math.pi)) < 1e-6
    assert s['time_ratio'] == pytest.approx(1.0, abs=1e-9)
    # the two change points, once each
    toggles = toggle_positions(mech, 'crank')
    assert len(toggles) == 2
    # (a crossing's root: Richardson-extrapolated line roots of the V-shaped margin)
    assert sorted(abs(math.remainder(t, 2 * math.pi)) for t in toggles) == pytest.approx(
        [math.pi / 2] * 2, abs=1e-11
    )


def test_scott_russell_past_ninety_degrees_the_drawing_goes_on_in_a_straight_line():
    """Seed 001: C "will generate a vertical straight line". At 100 deg the drawing's circuit
    holds the other sign, where C.x = 0; the drawn sign there has B parked on O2."""
    a = 0.1
    mech = scott_russell(a, math.pi / 3).mechanism
    circuit = reference_circuit(mech)
    assert circuit is not None
    theta = math.radians(100)
    on = {b for b in ('+', '-') if circuit.holds((1 if b == '+' else -1,), theta)}
    assert len(on) == 1
    (branch,) = on
    r = Solver(mech, branch=branch).solve({'crank': theta})
    assert r.success
    assert r.points['C'][0] == pytest.approx(0.0, abs=1e-15)
    assert r.points['B'][0] == pytest.approx(2 * a * math.cos(theta), abs=1e-15)


def _change_point_oracle(g, a, b, c):
    """(swing, crank at the rocker's min, at its max, time ratio) of a change-point four-bar
    (ground g, crank a, coupler b, rocker c; O2 = 0, O4 = (g, 0)) over its smooth motion: one
    side of A -> O4 for a crank turn, then the other (it crosses at the flat pose, crank 0).
    The same two-turn loop from any drawing. Sampled, then each extreme taken from the cosine
    rule at crank and coupler in line (|O2 B| = b +- a)."""
    th = np.linspace(0.0, 2 * math.pi, 400001)[1:-1]

    def rocker(theta, side):
        A = np.stack([a * np.cos(theta), a * np.sin(theta)], -1)
        d_vec = np.array([g, 0.0]) - A
        d = np.hypot(d_vec[:, 0], d_vec[:, 1])
        u = d_vec / d[:, None]
        along = (b * b - c * c + d * d) / (2 * d)
        off = np.sqrt(np.maximum(b * b - along * along, 0.0))
        B = A + along[:, None] * u + side * off[:, None] * np.stack([-u[:, 1], u[:, 0]], -1)
        return np.arctan2(B[:, 1], B[:, 0] - g)

    u = np.concatenate([th, th + 2 * math.pi])
    r = np.unwrap(np.concatenate([rocker(th, 1.0), rocker(th, -1.0)]))
    exact = []  # (crank, rocker angle) at crank and coupler in line
    for l, folded in ((b + a, False), (b - a, True)):
        phi = math.acos(max(-1.0, min(1.0, (g * g + c * c - l * l) / (2 * g * c))))
        for psi in (math.pi - phi, math.pi + phi):
            B = (g + c * math.cos(psi), c * math.sin(psi))
            exact.append((math.atan2(B[1], B[0]) + (math.pi if folded else 0.0), psi))

    def refined(i):
        crank, ang = min(
            exact, key=lambda e: abs(math.remainder(e[0] - u[i], 2 * math.pi))
            + abs(math.remainder(e[1] - r[i], 2 * math.pi)),
        )  # fmt: skip
        return u[i] + math.remainder(crank - u[i], 2 * math.pi), r[i] + math.remainder(
            ang - r[i], 2 * math.pi
        )

    (u_max, r_max), (u_min, r_min) = refined(int(np.argmax(r))), refined(int(np.argmin(r)))
    fwd = (u_max - u_min) % (4 * math.pi)
    return r_max - r_min, u_min, u_max, max(fwd, 4 * math.pi - fwd) / min(fwd, 4 * math.pi - fwd)


@pytest.mark.parametrize(
    ('lengths', 'drawn_at'), [((0.5, 0.2, 0.6, 0.3), 1.745), ((0.5, 0.2, 0.6, 0.3), -2.0)]
)
def test_a_change_point_four_bar_swings_over_two_crank_turns(lengths, drawn_at):
    g, a, b, c = lengths
    assert min(lengths) + max(lengths) == pytest.approx(sum(lengths) - min(lengths) - max(lengths))
    mech = four_bar(*lengths, input=drawn_at)
    report = quantities_report(mech)
    assert report is not None and report['full_turn']
    rocker = report['outputs']['link:rocker']
    swing, at_min, at_max, ratio = _change_point_oracle(g, a, b, c)
    # the fixed sign's swing is 2.214 rad, its time ratio 1
    assert rocker['stroke'] == pytest.approx(swing, rel=1e-12)
    assert abs(math.remainder(rocker['input_at_min'] - at_min, 2 * math.pi)) < 1e-6
    assert abs(math.remainder(rocker['input_at_max'] - at_max, 2 * math.pi)) < 1e-6
    assert rocker['time_ratio'] == pytest.approx(ratio, rel=1e-12)


def test_a_parallelogram_rocker_turns_with_its_crank():
    """Ground = coupler, crank = rocker: the parallelogram's rocker turns fully (the fixed
    sign becomes the anti-parallelogram at the flat poses and swings pi)."""
    mech = four_bar(0.4, 0.2, 0.4, 0.2, input=1.0)
    report = quantities_report(mech)
    assert report is not None and report['full_turn']
    # its change points: the flat poses, crank 0 and pi
    toggles = toggle_positions(mech, 'crank')
    assert len(toggles) == 2
    assert sorted(abs(math.remainder(t, 2 * math.pi)) for t in toggles) == pytest.approx(
        [0.0, math.pi], abs=1e-11
    )
    assert 'link:rocker' in report['turns_fully']
    assert 'link:rocker' not in report['outputs']


def _rocker(g, a, b, c, theta, side):
    """The four-bar's rocker angle (rad) at crank ``theta``, B on the ``side`` (+1: left) of
    A -> O4 (the cosine rule; O2 = 0, O4 = (g, 0))."""
    ax, ay = a * math.cos(theta), a * math.sin(theta)
    dx, dy = g - ax, -ay
    d = math.hypot(dx, dy)
    along = (b * b - c * c + d * d) / (2 * d)
    off = math.sqrt(max(b * b - along * along, 0.0))
    bx, by = ax + (along * dx - side * off * dy) / d, ay + (along * dy + side * off * dx) / d
    return math.atan2(by, bx - g)


def test_a_change_point_inside_the_crank_limits():
    """Limits -0.5 .. 1.5 rad around the change point at crank 0: from the drawing (0.3, the
    left side) the rocker runs on the left side up to 1.5 and, past 0, on the right side down
    to -0.5; both extremes are at the limits. The report had taken the limits' arc on the
    other turn of the stretch past the change point (swing 3.18 rad, an input of -4.78)."""
    lengths = (0.5, 0.2, 0.6, 0.3)
    mech = four_bar(*lengths, input=0.3, crank_limits={'min': -0.5, 'max': 1.5})
    top, bottom = _rocker(*lengths, 1.5, 1.0), _rocker(*lengths, -0.5, -1.0)
    assert bottom < _rocker(*lengths, 0.0, 1.0) < top  # (the extremes are the limits')
    report = quantities_report(mech)
    assert report is not None and not report['full_turn']
    rocker = report['outputs']['link:rocker']
    assert rocker['max'] == pytest.approx(top, abs=1e-12)
    assert rocker['min'] == pytest.approx(bottom, abs=1e-12)
    assert (rocker['input_at_min'], rocker['input_at_max']) == pytest.approx((-0.5, 1.5))
    lo, hi = oscillation_range(mech, 'rocker')
    assert (lo, hi) == pytest.approx((bottom, top), abs=1e-12)


@pytest.mark.parametrize('drawn_at', [0.0, 1e-9, 5e-8, -1e-9])
def test_a_change_point_four_bar_drawn_on_its_change_point(drawn_at):
    """The drawing on (or within 1e-7 of) the change point: the motion from it is the same
    two-turn circuit (it had merged two stretches into one sign: time ratio 2.77)."""
    lengths = (0.5, 0.2, 0.6, 0.3)
    report = quantities_report(four_bar(*lengths, input=drawn_at))
    assert report is not None
    swing, _, _, ratio = _change_point_oracle(*lengths)
    rocker = report['outputs']['link:rocker']
    assert rocker['stroke'] == pytest.approx(swing, rel=1e-12)
    assert rocker['time_ratio'] == pytest.approx(ratio, rel=1e-12)


def test_toggles_of_a_micro_scale_slide_are_two():
    """A slide-driven slider-crank (crank 4e-8 m, rod 1e-6 m): its two toggles (the slide at
    rod -+ crank, the crank along the line) are 8e-8 m apart; they were merged by a 1e-7 m
    dedupe. The same at 1000x scale for comparison."""

    def slider_crank(r, rod):
        th = 1.0
        ax, ay = r * math.cos(th), r * math.sin(th)
        bx = ax + math.sqrt(rod**2 - ay**2)
        return _slider_on_x(
            'micro',
            {'O2': [0.0, 0.0], 'A': [ax, ay], 'B': [bx, 0.0]},
            ['A', 'B'],
            {'s': {'type': 'slide', 'joint': 's'}},
        ).mechanism

    for r, rod in ((4e-8, 1e-6), (4e-5, 1e-3)):
        toggles = actuator_range(slider_crank(r, rod), 's')['toggles']
        assert toggles == pytest.approx([rod - r, rod + r], rel=1e-9), (r, rod, toggles)


def test_a_crossing_is_a_v_and_its_root_is_found_to_the_last_digits():
    """touches.crosses tells a V-shaped margin (|g|, g changing sign: the solutions cross) from
    a U-shaped one (g^2: they touch and part on one side); crossing_root finds g's root from a
    start 1e-8 off, through g's curvature."""
    root = 0.7

    def v(xs):
        g = (xs - root) * (1.0 + 3.0 * (xs - root))  # curved, changing sign at root
        return np.abs(g)

    def u(xs):
        return (xs - root) ** 2

    def floor(xs):  # a touch flatter than the probes see: the dyads' tangency floor
        return np.maximum(u(xs) ** 2, 5.95e-8)

    assert crosses(v, root + 1e-8, 1.0)
    assert not crosses(u, root + 1e-8, 1.0)
    assert not crosses(floor, root + 1e-8, 1.0)
    assert crossing_root(v, root + 1e-8, 1.0) == pytest.approx(root, abs=1e-13)


def test_an_output_that_does_not_move_has_no_time_ratio():
    """A kite folded onto its ground (ground = rocker 0.5, crank = coupler 0.3, B on O2): the
    rocker stands still while the crank turns (its swing rounds to ~1e-12); it had a time
    ratio of 1.27e9 (the ratio of two rounding-level inputs)."""
    report = quantities_report(four_bar(0.5, 0.3, 0.3, 0.5, input=1.0, branch=-1))
    assert report is not None and report['full_turn']
    rocker = report['outputs']['link:rocker']
    assert rocker['stroke'] < 1e-9
    assert rocker['time_ratio'] is None


def test_the_drawn_mode_past_a_change_point_is_only_where_the_limits_let_it_go():
    """Limits -1 .. 2.5 around the change point at crank 0, drawn at 1.745 on the left side:
    the right side is reached only for crank in [-1, 0]. At crank 1.0 the drawing's circuit
    holds the left side alone (it held both, through the stretch's other turn); at -0.5 the
    right side alone. The mode there by the cosine rule: the rocker angle of that side."""
    lengths = (0.5, 0.2, 0.6, 0.3)
    mech = four_bar(*lengths, input=1.745, crank_limits={'min': -1.0, 'max': 2.5})
    circuit = reference_circuit(mech)
    assert circuit is not None
    for crank, side in ((1.0, 1.0), (-0.5, -1.0), (2.4, 1.0), (-0.9, -1.0)):
        on = [signs for signs in ((1,), (-1,)) if circuit.holds(signs, crank)]
        assert len(on) == 1, (crank, on)
        r = Solver(mech, branch='+' if on[0] == (1,) else '-').solve({'crank': crank})
        assert r.links['rocker'] == pytest.approx(_rocker(*lengths, crank, side), abs=1e-12)


@pytest.mark.parametrize('drawn_at', [-0.3, -1.2])
def test_moving_up_through_a_change_point_inside_the_limits(drawn_at):
    """The documented example mirrored: drawn below the change point at crank 0 on the right
    side, limits -1.5 .. 0.5. Moving up, the motion crosses at 0 onto the left side. The
    stretch past the change point spans a turn, and the same change point a turn below is not
    reached: the node had refused crank 0.1 .. 0.5 ("reachable only on the other loop"), and
    check had put the rocker's maximum at crank -7.78 (outside the limits)."""
    lengths = (0.5, 0.2, 0.6, 0.3)
    mech = four_bar(*lengths, input=drawn_at, branch=-1, crank_limits={'min': -1.5, 'max': 0.5})
    e = Engine(mech, EngineSettings())
    for crank in np.linspace(drawn_at, 0.5, 41):
        r = e.command({'crank': float(crank)})
        assert r.success, (crank, r.reason)
        side = -1.0 if crank < -1e-9 else 1.0
        if abs(crank) > 1e-6:
            assert r.links['rocker'] == pytest.approx(_rocker(*lengths, crank, side), abs=1e-12)
    report = quantities_report(mech)
    assert report is not None
    rocker = report['outputs']['link:rocker']
    top, bottom = _rocker(*lengths, 0.5, 1.0), _rocker(*lengths, -1.5, -1.0)
    assert (rocker['min'], rocker['max']) == pytest.approx((bottom, top), abs=1e-12)
    assert (rocker['input_at_min'], rocker['input_at_max']) == pytest.approx((-1.5, 0.5))
    assert oscillation_range(mech, 'rocker') == pytest.approx((bottom, top), abs=1e-12)


def test_a_scott_russell_through_both_change_points_inside_its_limits():
    """Limits -2 .. 2 rad, drawn at 0.5: the slider follows B = 2 a cos(theta) over the whole
    range, through +-pi/2 (the node had refused crank 2: the stretch past pi/2 was taken for
    the one past -pi/2, a turn away)."""
    a = 0.1
    mech = scott_russell(a, 0.5).mechanism
    mech = dataclasses.replace(
        mech, actuators={'crank': dataclasses.replace(mech.actuators['crank'], min=-2.0, max=2.0)}
    )
    e = Engine(mech, EngineSettings())
    for crank in [*np.linspace(0.5, 2.0, 31), *np.linspace(2.0, -2.0, 81)]:
        r = e.command({'crank': float(crank)})
        assert r.success, (crank, r.reason)
        assert r.points['B'][0] == pytest.approx(2 * a * math.cos(crank), abs=1e-15)
    s = quantities_report(mech)['outputs']['joint:s']
    assert (s['min'], s['max']) == pytest.approx((2 * a * math.cos(2.0), 2 * a), abs=1e-15)


def _gripper(halves: str = 'LR') -> Scene:
    """A parallel gripper (a new user's): a pusher P sliding on the y axis drives each finger's
    parallelogram (upper link G1-F1, lower G2-F2, jaw F1-F2) through a drive link P-F1; the two
    fingers are mirror images in the y axis. Each parallelogram has change points, both at one
    push (the halves' are the same), and the drive dyads reach their toggles at one push too."""
    pts: dict[str, list[float]] = {'P': [0.0, 0.06]}
    links: dict[str, list[str]] = {'pusher': ['P']}
    ground: list[str] = []
    for h in halves:
        s = -1.0 if h == 'L' else 1.0
        pts |= {
            f'G1{h}': [0.02 * s, 0.0],
            f'G2{h}': [0.02 * s, -0.03],
            f'F1{h}': [0.045 * s, 0.04330127],
            f'F2{h}': [0.045 * s, 0.01330127],
        }
        ground += [f'G1{h}', f'G2{h}']
        links |= {
            f'upper{h}': [f'G1{h}', f'F1{h}'],
            f'lower{h}': [f'G2{h}', f'F2{h}'],
            f'jaw{h}': [f'F1{h}', f'F2{h}'],
            f'drive{h}': ['P', f'F1{h}'],
        }
    data = {
        'name': 'gripper',
        'points': pts,
        'links': {'ground': ground, **links},
        'sliders': [
            {
                'name': 'push',
                'guide': 'ground',
                'slider': 'pusher',
                'point': 'P',
                'direction': [0, 1],
                'origin': [0, 0],
            }
        ],  # fmt: skip
        'actuators': {'push': {'type': 'slide', 'joint': 'push'}},
    }
    return Scene.from_dict(data)


def test_a_symmetric_grippers_halves_move_as_mirror_images():
    """Both parallelograms cross their change points at one push, and both drive dyads reach
    their toggles at one push: the motion carries both on together. The scan had flipped one
    dyad at each (the one it met first), so the right finger was taken onto its
    anti-parallelogram: upperR swung 3.53 rad against upperL's 4.33, a transmission angle's
    least 11.8 deg against 0. Oracles: mirror symmetry (a right angle is pi minus the left
    one's, at the same push) and each finger alone, as the same scan sees it."""
    both = quantities_report(_gripper().mechanism)
    left = quantities_report(_gripper('L').mechanism)
    for link in ('upper', 'lower'):
        lo_l, lo_r = both['outputs'][f'link:{link}L'], both['outputs'][f'link:{link}R']
        alone = left['outputs'][f'link:{link}L']
        assert lo_r['stroke'] == pytest.approx(lo_l['stroke'], abs=1e-9)
        assert lo_l['stroke'] == pytest.approx(alone['stroke'], abs=1e-9)
        assert lo_r['min'] == pytest.approx(math.pi - lo_l['max'], abs=1e-9)
        assert lo_r['max'] == pytest.approx(math.pi - lo_l['min'], abs=1e-9)
        assert lo_r['input_at_min'] == pytest.approx(lo_l['input_at_max'], abs=1e-9)
    angles = both['transmission_angle']
    for name in ('G1L-F1L-P', 'G2L-F2L-F1L'):
        mirror = name.replace('L', 'R')
        for key in ('min', 'max'):
            assert angles[mirror][key] == pytest.approx(angles[name][key], abs=1e-9), name


def test_a_double_parallelograms_couplers_stay_level():
    """Two parallelograms in series (O2-A-B-O4, then B-C-O6 driven by the first's rocker)
    reach their change points together at crank 0 and pi. The scan flipped one dyad there (or
    missed pi: flipped alone, the other's circles part), and the least of the two margins,
    whose V is lopsided, put the crossing 2.3e-5 rad off pi: range --links swung the first
    coupler 78 deg (an outside adversary). Oracle: a parallelogram's coupler keeps its drawn
    direction (level) at every crank."""
    mech = double_parallelogram()
    for link in ('coupler', 'coupler2'):
        lo, hi = oscillation_range(mech, link)
        assert lo is not None and hi is not None
        assert max(abs(lo), abs(hi)) < 1e-7, (link, lo, hi)
    # the rockers turn fully with the crank
    assert set(quantities_report(mech)['turns_fully']) == {'link:rocker', 'link:rocker2'}
