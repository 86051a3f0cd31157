"""Brent's bounded minimisation of a function of one variable (the crossing test's search
for the bottom of a dyad's margin between two commands; a region's extreme between the samples
of its boundary arc)."""

from __future__ import annotations

import math
from collections.abc import Callable

#: the golden section's shorter part, (3 - sqrt 5) / 2
_GOLD = 0.5 * (3.0 - math.sqrt(5.0))
_SQRT_EPS = math.sqrt(2.2e-16)  # (fminbound's)


def brent_minimum(
    f: Callable[[float], float], a: float, b: float, xatol: float, max_calls: int = 100
) -> tuple[float, float]:
    """(x, f(x)) at a minimum of ``f`` on [a, b], to ``xatol`` in x: Brent's method, parabolic
    steps through the three best points with golden sections where they do not shrink the
    bracket, as scipy.optimize.fminbound takes them (its tolerances too). Written out: the
    crossing test runs on a live node's command path, and importing scipy.optimize there
    would stall the first command that moves a sign for ~0.4 s."""
    x = w = v = a + _GOLD * (b - a)
    fx = fw = fv = f(x)
    d = e = 0.0
    for _ in range(max_calls - 1):
        mid = 0.5 * (a + b)
        tol1 = _SQRT_EPS * abs(x) + xatol / 3.0
        tol2 = 2.0 * tol1
        if abs(x - mid) <= tol2 - 0.5 * (b - a):
            break
        golden = True
        if abs(e) > tol1:  # a parabola through x, w and v
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            p = -p if q > 0.0 else p
            q = abs(q)
            r, e = e, d
            if abs(p) < abs(0.5 * q * r) and q * (a - x) < p < q * (b - x):
                d = p / q
                if (x + d) - a < tol2 or b - (x + d) < tol2:
                    d = tol1 if x <= mid else -tol1
                golden = False
        if golden:
            e = (b - x) if x < mid else (a - x)
            d = _GOLD * e
        u = x + (d if abs(d) >= tol1 else math.copysign(tol1, d))
        fu = f(u)
        if fu <= fx:
            a, b = (a, x) if u < x else (x, b)
            v, fv, w, fw, x, fx = w, fw, x, fx, u, fu
        else:
            a, b = (u, b) if u < x else (a, u)
            if fu <= fw or w == x:
                v, fv, w, fw = w, fw, u, fu
            elif fu <= fv or v in (x, w):
                v, fv = u, fu
    return x, fx
