"""The one limit rule (core.model.limits): limit_violation judges a value, angle_limit_arc is the
same rule as the arc the motion analyses clip input ranges to. The oracle is the rule of
docs/SCENES.md written out here (an angle with both limits is brought into [min, min + 2 pi))."""

from __future__ import annotations

import math

import pytest
import scenes
from hypothesis import given, settings
from hypothesis import strategies as st

from linkage_ros.core.model.limits import angle_limit_arc, limit_interval, limit_violation
from linkage_ros.core.motion import actuator_range

angles = st.floats(-2 * math.pi, 2 * math.pi, allow_nan=False)


def inside_documented(value: float, lo: float | None, hi: float | None) -> bool:
    if lo is not None and hi is not None:
        return lo + (value - lo) % (2 * math.pi) <= hi
    reported = math.atan2(math.sin(value), math.cos(value))  # in [-pi, pi]
    return (lo is None or reported >= lo) and (hi is None or reported <= hi)


def inside_arc(value: float, arc: tuple[float, float] | None) -> bool:
    if arc is None:
        return True
    a, b = arc
    return a + (value - a) % (2 * math.pi) <= b


def clear_of(value: float, *bounds: float | None) -> bool:
    """Not within rounding of a bound (the rule's slack is 1e-12 there)."""
    return all(b is None or abs(math.remainder(value - b, 2 * math.pi)) > 1e-9 for b in bounds)


@settings(max_examples=400, deadline=None)
@given(lo=angles, width=st.floats(1e-3, 7.0), value=angles, sides=st.sampled_from('lhb'))
def test_the_arc_allows_exactly_the_angles_the_check_allows(lo, width, value, sides):
    hi = lo + width
    lo_, hi_ = (lo, None) if sides == 'l' else (None, hi) if sides == 'h' else (lo, hi)
    # a one-sided arc ends at +-pi, one angle on the circle (the reported angle is pi)
    if not clear_of(value, lo_, hi_, math.pi if sides != 'b' else None):
        return
    allowed = limit_violation('a', value, lo_, hi_, 'rad', periodic=True) is None
    assert allowed == inside_documented(value, lo_, hi_)
    assert allowed == inside_arc(value, angle_limit_arc(lo_, hi_))


lengths = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=400, deadline=None)
@given(
    lo=st.none() | lengths,
    width=st.floats(0.0, 2e6),
    value=st.floats(-2e6, 2e6, allow_nan=False) | st.sampled_from([0.0, 1.0, 1.5]),
    upper=st.booleans(),
    periodic=st.booleans(),
)
def test_the_interval_allows_exactly_the_values_the_check_allows(lo, width, value, upper, periodic):
    """limit_interval (the closed-form path's two comparisons) is the rule itself for a value
    that is not an angle, limits at the values' own floats included; an angle's limits are
    no interval (they compare on the circle)."""
    hi = (1.5 if lo is None else lo + width) if upper else None
    for v in (value, lo, hi):  # on each limit, exactly
        if v is None:
            continue
        interval = limit_interval(lo, hi, periodic)
        if periodic:
            assert interval is None
            continue
        assert interval is not None
        allowed = limit_violation('z', v, lo, hi, 'm', periodic=False) is None
        assert allowed == (interval[0] <= v <= interval[1]), (lo, hi, v)


def test_limits_a_full_turn_apart_allow_every_angle():
    assert angle_limit_arc(0.0, 2 * math.pi) is None
    assert angle_limit_arc(None, None) is None
    for v in (-3.0, 0.0, 1.0, 3.1, 7.0):
        assert limit_violation('a', v, 0.0, 2 * math.pi, 'rad', periodic=True) is None


def test_an_input_range_ends_where_the_check_starts_refusing():
    """The motion analyses clip an angle input's range to the arc: the shipped oscillating
    inverted slider-crank assembles over [0.4027, 5.8805] rad and is limited to 0.4127 .. 5.8704
    (an arc through pi): its range ends at the limits, which pass the check, and a step beyond
    each is refused."""
    mech = scenes.load('inverted_slider_crank_oscillating')
    ((name, act),) = mech.actuators.items()
    info = actuator_range(mech, name)
    assert (info['min_source'], info['max_source']) == ('limit', 'limit')
    for end in (info['min'], info['max']):
        assert limit_violation(name, end, act.min, act.max, 'rad', periodic=True) is None
        assert inside_arc(end, angle_limit_arc(act.min, act.max))
    for outside in (info['min'] - 1e-3, info['max'] + 1e-3):
        assert limit_violation(name, outside, act.min, act.max, 'rad', periodic=True)
        assert not inside_arc(outside, angle_limit_arc(act.min, act.max))


@pytest.mark.parametrize('value', [-1.0, 0.3, 2.1])
def test_a_refused_angle_names_the_nearer_limit(value):
    """docs/SCENES.md's example: with min 0.4, max 2.0, -1.0 is below its minimum by 1.4."""
    why = limit_violation('crank', value, 0.4, 2.0, 'rad', periodic=True)
    if value == 0.3:
        assert why is not None and 'below its minimum 0.4 by 0.1 rad' in why
    elif value == -1.0:
        assert why is not None and 'below its minimum 0.4 by 1.4 rad' in why
    else:
        assert why is not None and 'beyond its maximum 2 by 0.1 rad' in why


def test_an_angle_with_one_limit_is_judged_as_reported_by_the_solve_and_the_range():
    """A crank limited by a minimum of -1 rad alone: ``linkage range`` gives [-1, pi]; the solve
    refuses 4 rad (the angle -2.28 rad) as it refuses -2.28, and takes 2 rad and 2 + 2 pi. The
    solve compared the command as written and took 4 rad."""
    import dataclasses

    from linkage_ros.core.solver import Solver

    mech = scenes.four_bar(0.30, 0.10, 0.25, 0.20)  # a Grashof crank: it turns fully
    (name,) = mech.actuators
    mech.actuators = {name: dataclasses.replace(mech.actuators[name], min=-1.0)}
    info = actuator_range(mech, name)
    assert (info['min'], info['max']) == (-1.0, math.pi)
    solver = Solver(mech)
    for refused in (4.0, 4.0 - 2 * math.pi):
        r = solver.solve({name: refused})
        assert not r.success and 'below its minimum -1 by 1.28' in r.reason, r.reason
    for taken in (2.0, 2.0 + 2 * math.pi):
        assert solver.solve({name: taken}).success


def test_a_value_a_hair_beyond_its_limit_reads_apart_from_it():
    """1.12 - 7.55e-14 m against a minimum of 1.12 m read 'Z3 = 1.12 m is below its minimum
    1.12': the two are written whole where nine digits read alike. (Within LIMIT_SLACK, the
    rounding of a value's own arithmetic, it is inside: an inverse answer at the limit.)"""
    from linkage_ros.core.model.limits import limit_violation

    assert limit_violation('Z3', 1.12 - 7.55e-14, 1.12, 2.0, 'm', False) is None
    below = 1.12 - 5e-12
    why = limit_violation('Z3', below, 1.12, 2.0, 'm', False)
    assert why == f'Z3 = {below!r} m is below its minimum 1.12 by 5e-12 m', why
    why = limit_violation('Z3', 2.0 + 5e-12, 1.12, 2.0, 'm', False)
    assert why is not None and f'{2.0 + 5e-12!r} m is beyond its maximum 2.0 by' in why, why
    assert limit_violation('Z3', 1.0, 1.12, 2.0, 'm', False) == (
        'Z3 = 1 m is below its minimum 1.12 by 0.12 m'
    )


@pytest.mark.parametrize('periodic', [False, True])
@pytest.mark.parametrize(('lo', 'hi'), [(0.7, 2.0), (-2.5, -0.3), (0.3, 0.5), (-40.0, 30.0)])
def test_the_slack_is_the_same_on_both_sides(lo, hi, periodic):
    """A value within LIMIT_SLACK of either limit is inside, one past it is refused naming that
    limit and a distance that is not 0 (an angle just below its minimum had been refused "by
    0 rad" while one as far past its maximum was taken). Oracle: the rule's own words, value
    against limit +- LIMIT_SLACK * max(1, |limit|)."""
    from linkage_ros.core.model.limits import LIMIT_SLACK, limit_violation

    if periodic and hi - lo >= 2 * math.pi:
        pytest.skip('a full turn: every angle')
    for limit, side in ((lo, -1.0), (hi, 1.0)):
        s = LIMIT_SLACK * max(1.0, abs(limit))
        assert limit_violation('a', limit + side * 0.5 * s, lo, hi, 'u', periodic) is None
        assert limit_violation('a', limit - side * 0.5 * s, lo, hi, 'u', periodic) is None
        why = limit_violation('a', limit + side * 3 * s, lo, hi, 'u', periodic)
        assert why is not None, (limit, side)
        assert ('below its minimum' if side < 0 else 'beyond its maximum') in why, why
        assert not why.endswith(' by 0 u'), why


def test_an_inverse_answer_at_a_limit_is_taken():
    """The crank-rocker limited to crank [0.7, 2]: the rocker angle the forward solve gives at
    crank 0.7 (and at 2), asked as a target, needs the crank at its limit to rounding; it was
    refused "crank = 0.7 rad is below its minimum 0.7 by 1.78e-15 rad"."""
    from linkage_ros.core.solver import Solver

    mech = scenes.four_bar(0.3, 0.1, 0.25, 0.2, input=1.35, crank_limits={'min': 0.7, 'max': 2.0})
    fwd = Solver(mech)
    inv = Solver(mech, knowns=['rocker'])
    for crank in (0.7, 2.0):
        rocker = fwd.solve({'crank': crank}).links['rocker']
        r = inv.solve({'rocker': rocker})
        assert r.success, r.reason
        assert r.inputs['crank'] == pytest.approx(crank, abs=1e-12)


@pytest.mark.parametrize(
    ('value', 'lo', 'hi', 'shown', 'by'),
    [
        (4.5, 0.460493, 1.508256, 4.5 - 2 * math.pi, 0.460493 - (4.5 - 2 * math.pi)),
        (7.9, 0.460493, 1.508256, 7.9 - 2 * math.pi, 7.9 - 2 * math.pi - 1.508256),
        (4.0, -1.0, None, 4.0 - 2 * math.pi, -1.0 - (4.0 - 2 * math.pi)),
    ],
)
def test_a_refused_angle_written_a_turn_away_shows_the_angle_it_was_judged_as(
    value, lo, hi, shown, by
):
    """'crank = 4.5 rad is below its minimum 0.460493 by 2.24 rad' read as wrong arithmetic (a
    new user's find): the angle on the circle it was compared as is shown beside it, and the
    distance is that angle's from the limit."""
    why = limit_violation('crank', value, lo, hi, 'rad', True)
    assert why is not None
    assert f'crank = {value:g} rad ({shown:.9g} rad on the circle)' in why, why
    assert why.endswith(f'by {by:.3g} rad'), why
    # written on the circle already: as before, no second value
    plain = limit_violation('crank', shown, lo, hi, 'rad', True)
    assert plain is not None and 'on the circle' not in plain


@settings(max_examples=300, deadline=None)
@given(
    turns=st.integers(-(10**15), 10**15),
    at=st.floats(-math.pi, math.pi, allow_nan=False),
    limits=st.sampled_from([(-1.45, 1.45), (0.4, 5.9), (-1.0, None), (None, 2.0)]),
)
def test_a_large_angle_is_judged_as_the_solve_turns_it(turns, at, limits):
    """An angle of many turns (a crank commanded by its accumulated angle) is judged at its
    exact place on the circle, as the solve's exactly reduced sin and cos place it: float % 2 pi
    of 1e8 rad is off by ~4e-9 rad (past the 1e-12 slack), of 1e16 rad by radians, so in-limit
    commands were refused and out-of-limit ones let through. Oracle: the double's exact
    remainder at 400 digits (values within 1e-9 of a limit are skipped: either answer is
    rounding)."""
    import mpmath as mp

    lo, hi = limits
    value = float(mp.mpf(at) + turns * 2 * mp.pi)
    with mp.workdps(400):
        exact = float(mp.mpf(value) - 2 * mp.pi * mp.nint(mp.mpf(value) / (2 * mp.pi)))
    if lo is not None and hi is not None:
        on = lo + (exact - lo) % (2 * math.pi)
        inside, gap = on <= hi, min(abs(on - hi), abs(on - lo), abs(on - lo - 2 * math.pi))
    else:
        inside = (lo is None or exact >= lo) and (hi is None or exact <= hi)
        gap = min(abs(exact - b) for b in (lo, hi) if b is not None)
    if gap < 1e-9 or abs(abs(exact) - math.pi) < 1e-9:
        return
    got = limit_violation('crank', value, lo, hi, 'rad', True)
    assert (got is None) == inside, (value, exact, got)


def test_a_value_beyond_its_limits_that_is_in_them_read_in_mm_or_deg_says_so():
    """`--set Z1=1600` on the excavator (a cylinder of 1.1 .. 1.8 m) read 'beyond its maximum
    1.8 by 1.6e+03 m' with no word of the unit, where an angle's --set warns of degrees (a new
    user's find). The refusal names the likely mistake where the value in mm (an angle's in
    degrees, beyond a turn) lies within the limits; not where it would not."""
    from linkage_ros.core.model.limits import limit_violation

    why = limit_violation('Z1', 1600.0, 1.1, 1.8, 'm', False)
    assert (
        why
        == 'Z1 = 1600 m is beyond its maximum 1.8 by 1.6e+03 m (lengths are in m: 1600 mm is 1.6 m)'
    )
    assert 'mm' not in limit_violation('Z1', 5.0, 1.1, 1.8, 'm', False)  # 0.005 m: not in them
    why = limit_violation('crank', 60.0, 0.46, 1.51, 'rad', True)
    assert why.endswith(f'(angles are in rad: 60 deg is {math.radians(60):.6g} rad)'), why
    assert 'deg' not in limit_violation('crank', 2.0, 0.46, 1.51, 'rad', True)  # within a turn
    assert 'deg' not in limit_violation('crank', 170.0, 0.46, 1.51, 'rad', True)  # 2.97 rad
    # an adversary's: 0.4 m past a +-0.25 m stroke is no unit mistake, though 0.4 mm is
    # within it; nor 6.3 rad for a [0, 0.8] knuckle (a turn's wrap, not 6.3 deg)
    assert 'mm' not in limit_violation('push', 0.4, -0.25, 0.25, 'm', False)
    assert 'mm' not in limit_violation('push', -0.3, -0.25, None, 'm', False)
    assert 'deg' not in limit_violation('knuckle', 6.3, 0.0, 0.8, 'rad', False)


def test_limits_written_in_mm_that_hold_the_value_read_so_say_so():
    """A scene's cylinder limits written as bare millimetres (min: 2020, max: 3300 for a
    cylinder drawn 2.88 m long) were refused at load as 'below its minimum 2020 by 2.02e+03 m'
    with no word of the unit (a hydraulics engineer); the hint names the limits read in mm where
    they hold the value, and nothing where they would not."""
    why = limit_violation('Z1', 2.8828345, 2020.0, 3300.0, 'm', False)
    assert why.endswith('(lengths are in m: limits 2020 .. 3300 read in mm are 2.02 .. 3.3 m)')
    assert 'mm' not in limit_violation('Z1', 3.5, 2020.0, 3300.0, 'm', False)  # 3500 mm: beyond
    assert 'mm' not in limit_violation('Z1', 1.0, 2.0, 3.0, 'm', False)  # no unit mistake
