"""Plane geometry shared by the seed lecture tests (test_seed_coverage*.py): points as complex
numbers, cross products, the distance of two angles on the circle and the seeds' compass
construction (circle intersections), written out independently of the solver.
"""

import math

TWO_PI = 2.0 * math.pi

EXACT = 1e-12  # closed-form geometry, fraction of the length scale


def c(p):
    return complex(float(p[0]), float(p[1]))


def cross(u, v):
    return u.real * v.imag - u.imag * v.real


def circ(a, b):
    """Distance of two angles on the circle."""
    return abs(math.remainder(a - b, TWO_PI))


def meet(c1, r1, c2, r2, side):
    """Intersection of the circles (c1, r1) and (c2, r2) on the given side (+1: left of c1->c2).
    The compass construction of the seeds, written out."""
    d = abs(c2 - c1)
    a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    h = math.sqrt(max(r1 * r1 - a * a, 0.0))
    u = (c2 - c1) / d
    return c1 + u * complex(a, side * h)
