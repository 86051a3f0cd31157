"""Helpers the `linkage` command-line tests share (test_cli_*.py, conftest.py).

The four-bar lengths of the scenes the ``scenes`` fixture writes, main(argv) run in-process with
its output captured, a JSON reader that refuses NaN, and the independent geometry (Freudenstein's
equation, the toggle angles by the cosine rule) written here, never taken from the core.
"""

import json
import math

from linkage_ros.cli.parser import main

# four-bar lengths (m): ground l1, crank l2, coupler l3, rocker l4
CR = dict(l1=0.4, l2=0.1, l3=0.35, l4=0.3)  # Grashof crank-rocker (crank shortest)
DR = dict(l1=0.4, l2=0.35, l3=0.1, l4=0.3)  # Grashof double-rocker (coupler shortest)
CP = dict(distance=0.2, angle=0.5)  # coupler point P of the crank-rocker


def _no_nan(text):
    raise ValueError(f'non-finite number {text} in JSON output')


def loads(text):
    """json.loads that refuses NaN / Infinity."""
    return json.loads(text, parse_constant=_no_nan)


def run(capsys, *argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def freudenstein_residual(theta2, theta4, l1, l2, l3, l4):
    """K1 cos t4 - K2 cos t2 + K3 - cos(t2 - t4) = 0 for an assembled four-bar."""
    k1, k2 = l1 / l2, l1 / l4
    k3 = (l2**2 - l3**2 + l4**2 + l1**2) / (2 * l2 * l4)
    return k1 * math.cos(theta4) - k2 * math.cos(theta2) + k3 - math.cos(theta2 - theta4)


def toggles(l1, l2, l3, l4):
    """Input angles (upper half-plane) at which coupler and rocker are folded / extended."""

    def opposite(d):
        return math.acos((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2))

    return opposite(abs(l3 - l4)), opposite(l3 + l4)
