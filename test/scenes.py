"""Scene helpers shared by the tests (imported as ``scenes``; conftest.py makes the same
available as fixtures): where the repository and its scenes are, loading a shipped scene, and
building the shortcut mechanisms from lengths."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import yaml

from linkage_ros.core.model import Mechanism, Scene

REPO = Path(__file__).resolve().parent.parent
CONFIG = REPO / 'config'
#: the file stems of the shipped scenes (config/*.yaml), sorted
SHIPPED = sorted(p.stem for p in CONFIG.glob('*.yaml'))


def knowns_sets(mech: Mechanism) -> list[list[str] | None]:
    """The knowns sets a scene admits to try: forward (None), every set of dof joint/actuator
    names, and (2-DOF scenes) one point target each."""
    names = list(mech.actuators) + [j for j in mech.joint_names if j not in mech.actuators]
    sets: list[list[str] | None] = [None]
    sets += [list(c) for c in itertools.combinations(names, mech.dof)]
    if mech.dof == 2:
        sets += [[f'point:{p}'] for p in mech.points]
    return sets


def load(stem: str) -> Mechanism:
    """The mechanism of a shipped scene (config/<stem>.yaml)."""
    return Scene.from_yaml(CONFIG / f'{stem}.yaml').mechanism


def raw(stem: str) -> Any:
    """A shipped scene file's YAML, as data."""
    with open(CONFIG / f'{stem}.yaml', encoding='utf-8') as fh:
        return yaml.safe_load(fh)


def four_bar(*lengths: Any, **extra: Any) -> Mechanism:
    """The four_bar shortcut from (ground, crank, coupler, rocker): four numbers or one tuple of
    them; ``extra`` keys go into the shortcut (coupler_point, ground_angle, branch, ...)."""
    if len(lengths) == 1:
        lengths = tuple(lengths[0])
    spec = dict(zip(('ground', 'crank', 'coupler', 'rocker'), lengths))
    spec.update(extra)
    return Scene.from_dict({'four_bar': spec}).mechanism


def double_parallelogram() -> Mechanism:
    """Two parallelograms in series (O2-A-B-O4, then B-C-O6 driven by the first's rocker),
    crank O2A: both reach their change points at crank 0 and pi together."""
    c = 0.1 * math.sqrt(0.5)
    return Scene.from_dict(
        {
            'name': 'double_parallelogram',
            'points': {
                'O2': [0.0, 0.0],
                'O4': [0.3, 0.0],
                'O6': [0.6, 0.0],
                'A': [c, c],
                'B': [0.3 + c, c],
                'C': [0.6 + c, c],
            },  # fmt: skip
            'links': {
                'ground': ['O2', 'O4', 'O6'],
                'crank': ['O2', 'A'],
                'coupler': ['A', 'B'],
                'rocker': ['O4', 'B'],
                'coupler2': ['B', 'C'],
                'rocker2': ['O6', 'C'],
            },
            'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
        }
    ).mechanism


def slider_crank(r: float, rod: float, e: float = 0.0, direction: float = 0.0, **extra: Any):
    """The slider_crank shortcut from crank, rod, offset and stroke direction."""
    spec = {'crank': r, 'rod': rod, 'offset': e, 'direction': direction}
    spec.update(extra)
    return Scene.from_dict({'slider_crank': spec}).mechanism


# ---- loop systems (the Newton solver's equations) -------------------------------------------
def newton_system(stem: str) -> Any:
    """The LoopSystem of a shipped scene's Newton solver."""
    from linkage_ros.core.solver import Solver

    return Solver(load(stem), method='newton').system


def around_reference(sy: Any, rng: Any, N: int) -> tuple[Any, list[Any]]:
    """N configurations of loop system ``sy`` spread around its reference pose (x, (N, n)) and
    the reference values as batch columns: where the Jacobian tests evaluate."""
    import numpy as np

    from linkage_ros.core.solver import Solver

    X = sy.reference_x() + rng.normal(size=(N, sy.n)) * 0.5 * sy.step_scale
    ref = Solver(sy.mech, method='newton').compiled.ref_values
    cols = [np.broadcast_to(np.asarray(v, float), (N, *np.shape(v))) for v in ref]
    return X, cols


# ---- a roller on a flat face: the nut-cracker (issue 27) ------------------------------------

NUT_RADIUS = 0.01
NUT_JAW = 0.06  # |O6 F|
NUT_DRAWN = {
    'O2': (0.0, 0.0),
    'A': (0.03, 0.05),
    'B': (0.09, 0.06),
    'O4': (0.10, 0.0),
    'R': (0.13, 0.03),
    'O6': (0.16, -0.02),
}


def nut_cracker_jaw_point(radius: float = NUT_RADIUS) -> tuple[float, float]:
    """F drawn with the jaw's face (through O6 along O6 -> F) tangent to the roller, the centre
    R on the face's left (drawn to rounding: the stated radius is then a no-op redraw)."""
    (ox, oy), (rx, ry) = NUT_DRAWN['O6'], NUT_DRAWN['R']
    # the face's direction: that of O6 -> R turned right by the angle R subtends at O6
    psi = math.atan2(ry - oy, rx - ox) - math.asin(radius / math.hypot(rx - ox, ry - oy))
    return (ox + NUT_JAW * math.cos(psi), oy + NUT_JAW * math.sin(psi))


def nut_cracker(radius: float = NUT_RADIUS) -> dict:
    """The nut-cracker of issue 27 (test/core/solver/test_roller_side.py describes it): a handle
    driving a lever through an arm, the lever's roller (NUT_RADIUS about R) on the flat face of
    a jaw pivoted at O6; drawn with the roller on the face's left."""
    points = {**NUT_DRAWN, 'F': nut_cracker_jaw_point(radius)}
    return {
        'name': 'nut_cracker',
        'points': {k: list(v) for k, v in points.items()},
        'links': {
            'ground': ['O2', 'O4', 'O6'],
            'handle': ['O2', 'A'],
            'arm': ['A', 'B'],
            'lever': ['O4', 'B', 'R'],
            'jaw': ['O6', 'F'],
        },
        'slots': [
            {'name': 'face', 'point': 'R', 'link': 'jaw', 'through': 'O6', 'angle': 0,
             'radius': radius}
        ],
        'actuators': {'handle': {'type': 'angle', 'link': 'handle', 'pivot': 'O2'}},
    }  # fmt: skip


def roller_crank(side: int) -> dict:
    """A crank O2-A and a rod A-R whose roller (radius 0.02 about R) rides on the ground's
    flat face through G along +x, drawn on ``side`` of it."""
    r = 0.02
    ax, ay = 0.1 * math.cos(1.0), 0.1 * math.sin(1.0)
    ry = side * r
    rx = ax + math.sqrt(0.3**2 - (ay - ry) ** 2)
    return {
        'name': 'roller_crank',
        'points': {'O2': [0.0, 0.0], 'G': [0.5, 0.0], 'A': [ax, ay], 'R': [rx, ry]},
        'links': {'ground': ['O2', 'G'], 'crank': ['O2', 'A'], 'rod': ['A', 'R']},
        'slots': [
            {'name': 'floor', 'point': 'R', 'link': 'ground', 'through': 'G', 'angle': 0,
             'radius': r}
        ],
        'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
    }  # fmt: skip


#: a knuckle-boom crane (an outside reviewer's): a boom about O lifted by a cylinder from G1,
#: a jib about the boom's tip T1 folded by a cylinder from B2 on the boom to J1 on the jib,
#: whose dead centre (B2, T1, J1 in line: 1.6549569 m) lies inside its limits 1.30 .. 1.95 m
KNUCKLE_BOOM = {
    'name': 'knuckle_boom',
    'points': {
        'O': [0, 1.2],
        'G1': [0.35, 0.2],
        'T1': [2.897777478867, 1.976457135308],
        'B1': [1.030630587565, 1.21733758853],
        'B2': [1.757613356418, 1.981533933582],
        'J1': [3.378543014006, 1.792434038326],
        'T2': [4.440467742115, 0.137950471822],
    },
    'links': {'ground': ['O', 'G1'], 'boom': ['O', 'T1', 'B1', 'B2'], 'jib': ['T1', 'T2', 'J1']},
    'cylinders': {
        'lift': {'from': 'G1', 'to': 'B1', 'min': 1.00, 'max': 1.60},
        'fold': {'from': 'B2', 'to': 'J1', 'min': 1.30, 'max': 1.95},
    },
}


#: a Stephenson six-bar driven at its output link: Newton places crank, coupler, rocker and
#: link5 (a hybrid plan); its crank turns fully over the drive's circuit
STEPHENSON_DRIVEN_AT_ITS_OUTPUT = {
    'name': 'stephenson',
    'points': {
        'O2': [0, 0], 'A': [0.04, 0.06], 'B': [0.25, 0.15], 'O4': [0.28, 0],
        'C': [0.15, 0.25], 'D': [0.35, 0.30], 'O6': [0.45, 0.10],
    },
    'links': {
        'ground': ['O2', 'O4', 'O6'], 'crank': ['O2', 'A'], 'coupler': ['A', 'B', 'C'],
        'rocker': ['O4', 'B'], 'link5': ['C', 'D'], 'out': ['O6', 'D'],
    },
    'actuators': {'drive': {'type': 'angle', 'link': 'out', 'pivot': 'O6'}},
}  # fmt: skip


#: a Stephenson-III six-bar driven at its output rocker (an outside reviewer's): Newton places
#: the four-bar O2-A-B-O4 and link5; the drive's circuit from the drawing ends at two toggles
STEPHENSON_III_DRIVEN_AT_ITS_OUTPUT = {
    'name': 'steph3_outdrive',
    'points': {
        'O2': [0.0, 0.0], 'O4': [0.3, 0.0], 'O6': [0.1, 0.45],
        'A': [0.05000000000000002, 0.08660254037844387],
        'B': [0.27367945446743275, 0.19826050762284472],
        'C': [0.13955902658184458, 0.26542977755922814],
        'D': [-0.07234842787424921, 0.3980767931530158],
    },
    'links': {
        'ground': ['O2', 'O4', 'O6'], 'crank': ['O2', 'A'], 'coupler': ['A', 'B', 'C'],
        'rocker': ['O4', 'B'], 'link5': ['C', 'D'], 'output': ['O6', 'D'],
    },
    'actuators': {'drive': {'type': 'angle', 'link': 'output', 'pivot': 'O6'}},
}  # fmt: skip


#: a triad driven by a cylinder P-C on its coupler (Newton places it: no closed-form dyad for
#: the cylinder's length), without limits
CYLINDER_DRIVEN_TRIAD_POINTS = {
    'O2': (0.0, 0.0), 'O4': (1.0, 0.0), 'P': (0.5, -0.6), 'A': (0.1, 0.5),
    'B': (0.9, 0.6), 'C': (0.5, 0.9), 'T': (0.6, 1.3),
}  # fmt: skip
CYLINDER_DRIVEN_TRIAD = {
    'name': 'triad',
    'points': {k: list(v) for k, v in CYLINDER_DRIVEN_TRIAD_POINTS.items()},
    'links': {
        'ground': ['O2', 'O4', 'P'],
        'crank': ['O2', 'A'],
        'coupler': ['A', 'B', 'C', 'T'],
        'rocker': ['O4', 'B'],
    },
    'cylinders': {'Z': {'from': 'P', 'to': 'C'}},
}


#: a main landing gear (an outside integrator's, imported from their URDF+ <loop>): a strut
#: pivoting on the airframe at O, a drag brace of two links (U-K, K-S) with its knee K, and a
#: retraction cylinder M-R on a slide. A strut-angle target is placed by a hybrid plan: the
#: knee by a closed-form dyad, the cylinder by Newton
LANDING_GEAR = {
    'name': 'landing_gear',
    'points': {
        'O': [0.5384141654631727, -0.3], 'U': [1.7384141654631726, -0.1],
        'M': [-0.061585834536827325, 0.0], 'K': [0.9728933994519491, -0.4694292311195603],
        'Q': [0.6412118680307896, -0.6539689513009617],
        'S': [0.6182151838746806, -1.096009922966175],
        'R': [0.677815915039558, -0.6880298341812208],
        'Ma': [0.390214639692743, -0.4204104271396111],
        'Qa': [0.9485935705556712, -1.1891185422703279],
    },
    'links': {
        'airframe': ['O', 'U', 'M'], 'strut': ['O', 'S', 'R'], 'upper_brace': ['U', 'K'],
        'cylinder': ['M', 'Ma'], 'lower_brace': ['K', 'S'], 'rod': ['Q', 'Qa', 'R'],
    },
    'ground': 'airframe',
    'sliders': [{
        'name': 'stroke', 'guide': 'cylinder', 'slider': 'rod', 'point': 'Q',
        'direction': [0.7320809401743009, -0.6812176576054909],
        'origin': [0.6412118680307896, -0.6539689513009617],
    }],
    'actuators': {'stroke': {'type': 'slide', 'joint': 'stroke', 'min': -0.1, 'max': 0.06}},
}  # fmt: skip
