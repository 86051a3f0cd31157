"""Shared by the general solver tests (test_solver_core.py, test_solver_refusals.py,
test_solver_batch.py): the tolerances, the crank-rocker and triple-rocker four-bars, the lever
driven by a hydraulic cylinder and the 2-DOF five-bar.
"""

from linkage_ros.core.model import Scene

EPS = 2.0**-52

TIGHT = 1e-12  # loop closure, fraction of the length scale

AGREE = 1e-9  # closed form vs Newton, fraction of the length scale

CRANK_ROCKER = (4.0, 1.5, 4.5, 3.0)  # (ground, crank, coupler, rocker), Grashof

TRIPLE_ROCKER = (4.0, 3.0, 5.0, 2.5)  # non-Grashof, input range symmetric about pi


# A lever pivoting on the ground at O, driven by a hydraulic cylinder from the ground pin C to the
# lever pin P; T is a tool point on the lever. |OP| = 0.6, |OC| = sqrt(0.85) ~ 0.922, so the
# cylinder can span 0.322 .. 1.522 m (it is limited to 0.5 .. 1.4 m).
LEVER = {
    'name': 'lever',
    'points': {'O': [0.0, 0.0], 'C': [0.2, -0.9], 'P': [0.6, 0.0], 'T': [1.2, 0.3]},
    'links': {'ground': ['O', 'C'], 'lever': ['O', 'P', 'T']},
    'cylinders': {'cyl': {'from': 'C', 'to': 'P', 'min': 0.5, 'max': 1.4}},
}

# A 2-DOF five-bar: cranks O1-A and O5-B, coupler links A-C(-P) and C-B.
FIVE_BAR = {
    'name': 'five_bar',
    'points': {
        'O1': [0.0, 0.0],
        'O5': [1.0, 0.0],
        'A': [0.0, 0.6],
        'B': [1.0, 0.6],
        'C': [0.5, 1.2],
        'P': [0.25, 1.2],
    },
    'links': {
        'ground': ['O1', 'O5'],
        'left': ['O1', 'A'],
        'upper_l': ['A', 'C', 'P'],
        'upper_r': ['C', 'B'],
        'right': ['O5', 'B'],
    },
    'actuators': {
        'q1': {'type': 'angle', 'link': 'left', 'pivot': 'O1'},
        'q2': {'type': 'angle', 'link': 'right', 'pivot': 'O5'},
    },
}


def lever():
    return Scene.from_dict(LEVER).mechanism


def five_bar():
    return Scene.from_dict(FIVE_BAR).mechanism
