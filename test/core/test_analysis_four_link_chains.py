"""Tests of linkage_ros.core.analysis on one-loop four-link scenes: four_link_chain_info reads
the class of any of them (slider-cranks, inverted slider-cranks, four-bars in general form,
driven from either side).

Oracle: does the position solver assemble the scene at every crank angle of a fine grid, and
does the other ground-pivoted link then make a whole turn.
"""

import math

import numpy as np
import pytest
import scenes

from linkage_ros.core.analysis import grashof_info

# ----------------------------------------------------------------------------- four-link chains
# four_link_chain_info reads the class of any one-loop four-link scene (general form included);
# oracle: does the position solver assemble the scene at every crank angle of a fine grid, and
# does the other ground-pivoted link then make a whole turn.


def _inverted_slider_crank(a, b, e, theta_ref=2.0, drive='crank'):
    """General-form 3R-1P (seed 003 example 5): ground O2O4 = a, crank O2A = b, the slide line
    through A at distance e from O4 (F its foot, on the rocker)."""
    from linkage_ros.core.model import Scene

    A = np.array([b * math.cos(theta_ref), b * math.sin(theta_ref)])
    O4 = np.array([a, 0.0])
    d = np.hypot(*(A - O4))
    phi = math.atan2(*(A - O4)[::-1])
    beta = math.acos(e / d)
    F = O4 + e * np.array([math.cos(phi + beta), math.sin(phi + beta)])
    act = (
        {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'A'}
        if drive == 'crank'
        else {'type': 'angle', 'link': 'rocker', 'pivot': 'O4', 'toward': 'F'}
    )
    return Scene.from_dict(
        {
            'name': 'isc',
            'points': {'O2': [0.0, 0.0], 'O4': O4.tolist(), 'A': A.tolist(), 'F': F.tolist()},
            'ground': 'ground',
            'links': {
                'ground': ['O2', 'O4'],
                'crank': ['O2', 'A'],
                'block': ['A'],
                'rocker': ['O4', 'F'],
            },
            'sliders': [
                {
                    'name': 'slide',
                    'guide': 'rocker',
                    'slider': 'block',
                    'point': 'A',
                    'direction': (A - F).tolist(),
                    'origin': 'F',
                }
            ],
            'actuators': {'drive': act},
        }
    ).mechanism


def _turns(mech, n=3601):
    """Does the driven link assemble at every angle of a whole turn from the reference pose
    (the position solver, continuous branch)?"""
    from linkage_ros.core.solver import Solver

    s = Solver(mech, branch='continuous')
    ((name, start),) = s.reference_values().items()
    return all(s.solve({name: start + 2 * math.pi * k / (n - 1)}).success for k in range(n))


@pytest.mark.parametrize(
    'a,b,e,klass',
    [
        (0.30, 0.20, 0.14, 'non-grashof'),  # the seed's example: lmin + e = 0.34 > lmax
        (0.40, 0.10, 0.14, 'grashof'),  # crank turns, slotted link rocks
        (0.15, 0.40, 0.10, 'grashof'),  # ground shortest: both turn (whitworth-like)
        (0.15, 0.40, 0.30, 'non-grashof'),
    ],
)
def test_inverted_slider_crank_class_and_rotation_by_the_solver(a, b, e, klass):
    from linkage_ros.core.analysis import four_link_chain_info

    mech = _inverted_slider_crank(a, b, e)
    info = four_link_chain_info(mech)
    assert info.chain == '3R-1P' and info.klass == klass
    assert info.lengths['e'] == pytest.approx(e, rel=1e-12)
    crank_turns = _turns(mech)
    rocker_turns = _turns(_inverted_slider_crank(a, b, e, drive='rocker'))
    assert (info.input_fully_rotates, info.output_fully_rotates) == (crank_turns, rocker_turns)
    if klass == 'non-grashof':
        assert not crank_turns and not rocker_turns
    # driving the slotted link instead swaps the roles
    info = four_link_chain_info(_inverted_slider_crank(a, b, e, drive='rocker'))
    assert info.klass == klass
    assert (info.input_fully_rotates, info.output_fully_rotates) == (rocker_turns, crank_turns)


@pytest.mark.parametrize(
    'crank,rod,offset',
    [(0.05, 0.18, 0.01), (0.10, 0.12, 0.03), (0.10, 0.12, 0.015), (0.12, 0.10, 0.0)],
)
def test_slider_crank_class_and_crank_rotation_by_the_solver(crank, rod, offset):
    from linkage_ros.core.analysis import four_link_chain_info
    from linkage_ros.core.model import Scene

    mech = Scene.from_dict(
        {'name': 'sc', 'slider_crank': {'crank': crank, 'rod': rod, 'offset': offset, 'input': 0.2}}
    ).mechanism
    info = four_link_chain_info(mech)
    assert info.chain == '3R-1P' and info.output_fully_rotates is None
    lmin, lmax = sorted((crank, rod))
    assert info.klass == ('grashof' if lmin + offset < lmax else 'non-grashof')
    assert info.input_fully_rotates == _turns(mech)


def test_four_link_chain_info_agrees_with_grashof_info_and_skips_other_mechanisms():

    from linkage_ros.core.analysis import four_link_chain_info
    from linkage_ros.core.model import Scene

    config = scenes.CONFIG
    seen = set()
    for f in sorted(config.glob('*.yaml')):
        mech = Scene.from_yaml(f).mechanism
        info = four_link_chain_info(mech)
        if mech.form == 'four_bar':
            sc = mech.shortcut
            g = grashof_info(sc['ground'], sc['crank'], sc['coupler'], sc['rocker'])
            assert (
                info.chain,
                info.klass,
                info.input_fully_rotates,
                info.output_fully_rotates,
            ) == ('4R', g.klass, g.input_fully_rotates, g.output_fully_rotates)
        if len(mech.links) != 4:
            assert info is None, f.name  # multi-loop scenes have no such class
        elif info is not None:
            seen.add(f.stem)
    assert seen >= {'four_bar', 'inverted_slider_crank_oscillating', 'slider_crank'}
    osc = four_link_chain_info(
        Scene.from_yaml(config / 'inverted_slider_crank_oscillating.yaml').mechanism
    )
    assert osc.klass == 'non-grashof' and osc.rule == 'lmin + e = 0.34 > lmax = 0.3'
    assert osc.lengths == pytest.approx({'l_a': 0.3, 'l_b': 0.2, 'e': 0.14}, rel=1e-12)
    assert set(osc.links) == {'ground', 'crank'}


def _slider_crank_general(b, c, e, h, ground_is_slider=False, theta=0.3):
    """General-form slider-crank: crank O2A = b, rod AB = c, B on the line y = e. The slide is
    declared through a point S = B - (0, h) of the block (h != 0: the slide point is not the wrist
    pin), or, with ground_is_slider, as a line fixed in the block through the ground point P."""
    from linkage_ros.core.model import Scene

    A = [b * math.cos(theta), b * math.sin(theta)]
    B = [A[0] + math.sqrt(c * c - (e - A[1]) ** 2), e]
    if ground_is_slider:
        points = {'O2': [0.0, 0.0], 'P': [0.0, e], 'A': A, 'B': B}
        links = {'ground': ['O2', 'P'], 'crank': ['O2', 'A'], 'rod': ['A', 'B'], 'block': ['B']}
        slide = {
            'name': 's',
            'guide': 'block',
            'slider': 'ground',
            'point': 'P',
            'direction': 0.0,
            'origin': 'B',
        }
    else:
        points = {'O2': [0.0, 0.0], 'X': [0.0, 0.2], 'A': A, 'B': B, 'S': [B[0], e - h]}
        links = {
            'ground': ['O2', 'X'],
            'crank': ['O2', 'A'],
            'rod': ['A', 'B'],
            'block': ['B', 'S'],
        }
        slide = {
            'name': 's',
            'guide': 'ground',
            'slider': 'block',
            'point': 'S',
            'direction': 0.0,
            'origin': 'X',
        }
    return Scene.from_dict(
        {
            'name': 'scg',
            'points': points,
            'ground': 'ground',
            'links': links,
            'sliders': [slide],
            'actuators': {
                'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'A'}
            },
        }
    ).mechanism


@pytest.mark.parametrize('ground_is_slider', [False, True])
@pytest.mark.parametrize(
    'b,c,e,turns', [(0.10, 0.12, 0.035, False), (0.10, 0.12, 0.015, True), (0.05, 0.18, 0.02, True)]
)
def test_slider_crank_offset_is_the_wrist_pins_line_not_the_slide_point(
    b, c, e, turns, ground_is_slider
):
    """The offset e is the distance of O2 from the line the wrist pin B moves on, whatever point
    declares the slide (here 0.05 m off B: taking that point's line would give |e - 0.05| and
    the opposite answer in the first two cases), and the ground may be the slide's guide or its
    slider. Oracle: a full turn of the position solver."""
    from linkage_ros.core.analysis import four_link_chain_info

    mech = _slider_crank_general(b, c, e, 0.05, ground_is_slider)
    info = four_link_chain_info(mech)
    assert info.chain == '3R-1P' and info.lengths['e'] == pytest.approx(e, abs=1e-12)
    assert info.input_fully_rotates is _turns(mech) is turns
    assert info.output_fully_rotates is None


def test_four_link_chain_info_is_none_for_two_slides():
    """A Scotch yoke (R-R-P-P) is not a 4R or 3R-1P chain: no class (it used to raise)."""
    from linkage_ros.core.analysis import four_link_chain_info
    from linkage_ros.core.model import Scene

    mech = Scene.from_dict(
        {
            'name': 'yoke',
            'points': {'O2': [0.0, 0.0], 'A': [0.1, 0.0], 'Y': [0.1, 0.3]},
            'ground': 'ground',
            'links': {'ground': ['O2'], 'crank': ['O2', 'A'], 'block': ['A'], 'yoke': ['Y']},
            'sliders': [
                {
                    'name': 's1',
                    'guide': 'yoke',
                    'slider': 'block',
                    'point': 'A',
                    'direction': math.pi / 2,
                    'origin': 'Y',
                },
                {
                    'name': 's2',
                    'guide': 'ground',
                    'slider': 'yoke',
                    'point': 'Y',
                    'direction': 0.0,
                    'origin': 'O2',
                },
            ],
            'actuators': {
                'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'A'}
            },
        }
    ).mechanism
    assert four_link_chain_info(mech) is None


def test_general_form_four_bars_of_every_class_driven_from_either_side():
    """General-form 4R scenes (link names of their own, the crank's toward point off its
    revolutes, either ground-pivoted link driven) against full turns of the position solver;
    random lengths kept 2 % away from the Grashof equality so a 0.5 deg grid resolves them."""
    from linkage_ros.core.analysis import four_link_chain_info
    from linkage_ros.core.model import Scene

    rng = np.random.default_rng(7)
    seen, cases = set(), 0
    while cases < 8:
        l1, l2, l3, l4 = rng.uniform(0.1, 1.0, 4)
        s, p, q, lng = sorted((l1, l2, l3, l4))
        if abs(s + lng - p - q) < 0.02 * (l1 + l2 + l3 + l4):
            continue
        th = rng.uniform(0, 2 * math.pi)
        A = np.array([l2 * math.cos(th), l2 * math.sin(th)])
        O4 = np.array([l1, 0.0])
        d = np.hypot(*(A - O4))
        if not abs(l3 - l4) + 1e-2 < d < l3 + l4 - 1e-2:
            continue
        ang = math.atan2(*(O4 - A)[::-1]) + math.acos((l3 * l3 + d * d - l4 * l4) / (2 * l3 * d))
        B = A + l3 * np.array([math.cos(ang), math.sin(ang)])
        pts = {
            'O2': [0.0, 0.0],
            'O4': O4.tolist(),
            'A': A.tolist(),
            'B': B.tolist(),
            'X': (A + [0.01, 0.02]).tolist(),
            'Y': (B + [0.02, -0.01]).tolist(),
        }

        def scene(drive):
            act = (
                {'type': 'angle', 'link': 'inp', 'pivot': 'A', 'toward': 'X'}
                if drive == 'inp'
                else {'type': 'angle', 'link': 'outp', 'pivot': 'B', 'toward': 'Y'}
            )
            return Scene.from_dict(
                {
                    'name': 'f',
                    'points': pts,
                    'ground': 'g',
                    'links': {
                        'g': ['O4', 'O2'],
                        'inp': ['A', 'X', 'O2'],
                        'cp': ['B', 'A'],
                        'outp': ['Y', 'B', 'O4'],
                    },
                    'actuators': {'d': act},
                }
            ).mechanism

        m_in, m_out = scene('inp'), scene('outp')
        cases += 1
        t_in, t_out = _turns(m_in, 721), _turns(m_out, 721)
        i, o = four_link_chain_info(m_in), four_link_chain_info(m_out)
        assert (i.input_fully_rotates, i.output_fully_rotates) == (t_in, t_out)
        assert (o.input_fully_rotates, o.output_fully_rotates) == (t_out, t_in)
        assert i.lengths == pytest.approx({'l1': l1, 'l2': l2, 'l3': l3, 'l4': l4}, rel=1e-9)
        seen.add(i.klass)
    assert len(seen) >= 2
