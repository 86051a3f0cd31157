"""Shared by the tests of linkage_ros.core.fourbar (test_fourbar*.py): the mpmath precision of
the oracles and the angle wrap to [-pi, pi).
"""

import numpy as np

DPS = 50


def wrap(a):
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(a, float) + np.pi) % (2 * np.pi) - np.pi
