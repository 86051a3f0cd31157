"""Independent 50-digit oracles for the position kinematics tests.

Nothing here calls linkage_ros: every answer is worked out from the geometry with mpmath at
``DPS`` significant digits, taking the float inputs *exactly* (``mp.mpf(float)`` is exact), so
the oracle is the true answer for the very numbers the code under test received. Differences
between the code and an oracle are therefore the code's own rounding (or bugs), never the
oracle's.

Conventions (the ones linkage_ros documents, restated so the tests can check them):

* circle-circle (RRR dyad): ``sign`` +1 puts X to the left of c1 -> c2, -1 to the right;
* circle-line (RRP dyad): ``sign`` +1 takes the intersection further along +u;
* line through a point (RPR dyad): the line through x keeps the signed offset
  ``cross(dir, x - p) = offset`` from the pivot p; ``sign`` +1 has x ahead of p's foot
  (``dot(dir, x - p) > 0``);
* four-bar (ground O2 -> O4 along ``ground_angle``): theta2 = direction O2->A, theta3 =
  direction A->B, theta4 = direction O4->B; branch +1 puts B left of A -> O4;
* slider-crank: O2 at the origin, slide direction d = (cos dir, sin dir), n = perp(d); the
  line of stroke is {e n + x d}; the slider value is x; branch +1 puts B ahead of A along d.

All functions accept floats (or mpf) and return mpf values (points as (x, y) tuples of mpf);
convert with ``float`` for comparisons, or use the helpers ``angle_error`` / ``point_error``
which do the subtraction at 50 digits.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import mpmath as mp

DPS = 50
EPS = 2.0**-52  # double precision machine epsilon


def _m(x):
    """Exact conversion of a float (or pass-through of an mpf) to mpf."""
    return x if isinstance(x, mp.mpf) else mp.mpf(float(x))


def _pt(p):
    return (_m(p[0]), _m(p[1]))


# ---- small helpers ---------------------------------------------------------------------------


def wrap(a):
    """Angle wrapped to (-pi, pi] at 50 digits."""
    with mp.workdps(DPS):
        a = _m(a)
        return mp.atan2(mp.sin(a), mp.cos(a))


def reduce_angle(x: float):
    """The exact reduction of the float x (radians) to (-pi, pi]: cos/sin of the float itself."""
    return wrap(x)


def angle_error(got, want) -> float:
    """|got - want| wrapped to [0, pi], computed at 50 digits (got, want: float or mpf)."""
    with mp.workdps(DPS):
        return float(abs(wrap(_m(got) - _m(want))))


def point_error(got, want) -> float:
    """Euclidean distance between two points, computed at 50 digits."""
    with mp.workdps(DPS):
        return float(mp.hypot(_m(got[0]) - _m(want[0]), _m(got[1]) - _m(want[1])))


def direction(p, q):
    """Direction angle of the vector p -> q."""
    with mp.workdps(DPS):
        return mp.atan2(_m(q[1]) - _m(p[1]), _m(q[0]) - _m(p[0]))


def cross(u, v):
    with mp.workdps(DPS):
        return _m(u[0]) * _m(v[1]) - _m(u[1]) * _m(v[0])


# ---- dyads -----------------------------------------------------------------------------------


@dataclass
class Dyad:
    """An oracle dyad answer: ``point`` (None when the dyad does not close), the distance of the
    solution from the centre line ``height``, the amount by which the constraint misses
    ``miss`` (> 0: no solution; <= 0: closes) and the transmission margin (|sin| of the angle at
    X, 0 at the singularity)."""

    point: tuple | None
    height: object
    miss: object
    margin: object = field(default=None)


def circle_circle(c1, r1, c2, r2, sign) -> Dyad:
    """Intersection of circle (c1, r1) and circle (c2, r2) on the side ``sign`` of c1 -> c2."""
    with mp.workdps(DPS):
        c1, c2 = _pt(c1), _pt(c2)
        r1, r2 = _m(r1), _m(r2)
        dx, dy = c2[0] - c1[0], c2[1] - c1[1]
        d = mp.hypot(dx, dy)
        miss = max(d - (r1 + r2), abs(r1 - r2) - d)
        if d == 0 or miss > 0:
            return Dyad(None, mp.mpf(0), miss, mp.mpf(0))
        a = (d * d + r1 * r1 - r2 * r2) / (2 * d)
        h2 = r1 * r1 - a * a
        h = mp.sqrt(h2) if h2 > 0 else mp.mpf(0)
        ux, uy = dx / d, dy / d
        s = 1 if sign > 0 else -1
        x = (c1[0] + a * ux - s * h * uy, c1[1] + a * uy + s * h * ux)
        return Dyad(x, h, miss, h * d / (r1 * r2))


def circle_line(c, r, p0, u, sign) -> Dyad:
    """Intersection of circle (c, r) with the line p0 + s u (u normalised here), the one further
    along +u for sign +1. margin = half chord / r."""
    with mp.workdps(DPS):
        c, p0, u = _pt(c), _pt(p0), _pt(u)
        r = _m(r)
        n = mp.hypot(*u)
        u = (u[0] / n, u[1] / n)
        w = (c[0] - p0[0], c[1] - p0[1])
        s0 = w[0] * u[0] + w[1] * u[1]
        dist = abs(u[0] * w[1] - u[1] * w[0])
        miss = dist - r
        if miss > 0:
            return Dyad(None, mp.mpf(0), miss, mp.mpf(0))
        k = mp.sqrt(r * r - dist * dist)
        s = s0 + (1 if sign > 0 else -1) * k
        return Dyad((p0[0] + s * u[0], p0[1] + s * u[1]), k, miss, k / r)


def line_through_point(p, x, offset, sign):
    """Direction psi of the line through x whose signed offset from p is ``offset``
    (cross(dir, x - p) = offset), with dot(dir, x - p) of the sign ``sign``; None if |offset|
    exceeds |x - p|."""
    with mp.workdps(DPS):
        p, x = _pt(p), _pt(x)
        e = _m(offset)
        wx, wy = x[0] - p[0], x[1] - p[1]
        rho = mp.hypot(wx, wy)
        if abs(e) > rho:
            return None
        along = (1 if sign > 0 else -1) * mp.sqrt(rho * rho - e * e)
        # dir = (along * w - e * perp(w)) / rho^2 satisfies dot(dir, w) = along and
        # cross(dir, w) = e
        dx = (along * wx + e * wy) / (rho * rho)
        dy = (along * wy - e * wx) / (rho * rho)
        return mp.atan2(dy, dx)


# ---- four-bar --------------------------------------------------------------------------------


def _ground(l1, ground_angle):
    g = _m(ground_angle)
    return (mp.mpf(0), mp.mpf(0)), (_m(l1) * mp.cos(g), _m(l1) * mp.sin(g))


def fourbar(l1, l2, l3, l4, theta2, branch=1, ground_angle=0.0, coupler_point=None):
    """Four-bar position at crank angle theta2 (float, taken exactly).

    Returns a dict with points O2, A, B, O4 (and P when ``coupler_point`` = (distance, angle
    from A->B) is given), the angles theta2/theta3/theta4, the RRR height ``h``, its margin
    (|sin| of the transmission angle) and ``miss`` (> 0 when the linkage cannot be assembled);
    ``ok`` says whether it closes.
    """
    with mp.workdps(DPS):
        o2, o4 = _ground(l1, ground_angle)
        t2 = _m(theta2)
        a = (_m(l2) * mp.cos(t2), _m(l2) * mp.sin(t2))
        dy = circle_circle(a, l3, o4, l4, branch)
        out = {
            'O2': o2,
            'O4': o4,
            'A': a,
            'theta2': t2,
            'miss': dy.miss,
            'ok': dy.point is not None,
            'h': dy.height,
            'margin': dy.margin,
        }
        if dy.point is None:
            return out
        b = dy.point
        out['B'] = b
        out['theta3'] = direction(a, b)
        out['theta4'] = direction(o4, b)
        if coupler_point is not None:
            dist, ang = _m(coupler_point[0]), _m(coupler_point[1])
            t = out['theta3'] + ang
            out['P'] = (a[0] + dist * mp.cos(t), a[1] + dist * mp.sin(t))
        return out


def fourbar_inverse(l1, l2, l3, l4, theta4, branch=1, ground_angle=0.0):
    """Four-bar with the rocker angle theta4 known: A from circles about O2 (l2) and B (l3),
    ``branch`` +1 putting A left of O2 -> B."""
    with mp.workdps(DPS):
        o2, o4 = _ground(l1, ground_angle)
        t4 = _m(theta4)
        b = (o4[0] + _m(l4) * mp.cos(t4), o4[1] + _m(l4) * mp.sin(t4))
        dy = circle_circle(o2, l2, b, l3, branch)
        out = {
            'O2': o2,
            'O4': o4,
            'B': b,
            'theta4': t4,
            'miss': dy.miss,
            'ok': dy.point is not None,
            'margin': dy.margin,
        }
        if dy.point is None:
            return out
        a = dy.point
        out['A'] = a
        out['theta2'] = direction(o2, a)
        out['theta3'] = direction(a, b)
        return out


def fourbar_toggles(l1, l2, l3, l4, ground_angle=0.0):
    """Exact crank angles (mpf, in (-pi, pi]) at which the coupler and rocker are collinear.

    By the cosine rule in triangle O2 A O4, |A - O4|^2 = l1^2 + l2^2 - 2 l1 l2 cos(theta2 - g);
    the toggles are where |A - O4| = l3 + l4 (extended) or |l3 - l4| (folded). Returns a list
    of (angle, kind) with kind 'extended' or 'folded'.
    """
    out = []
    with mp.workdps(DPS):
        a, b, c, d = _m(l1), _m(l2), _m(l3), _m(l4)
        g = _m(ground_angle)
        for reach, kind in ((c + d, 'extended'), (abs(c - d), 'folded')):
            cos_t = (a * a + b * b - reach * reach) / (2 * a * b)
            if -1 < cos_t < 1:
                t = mp.acos(cos_t)
                out += [(wrap(g + t), kind), (wrap(g - t), kind)]
            elif cos_t in (-1, 1):
                out.append((wrap(g + mp.acos(cos_t)), kind))
    return out


def fourbar_output_toggles(l1, l2, l3, l4, ground_angle=0.0):
    """Exact rocker angles (mpf, (-pi, pi]) at which the crank and coupler are collinear
    (|O2 - B| = l3 + l2 or |l3 - l2|): the rocker's extremes. Cosine rule in triangle O2 O4 B:
    |B - O2|^2 = l1^2 + l4^2 + 2 l1 l4 cos(theta4 - g). Returns (angle, kind) pairs."""
    out = []
    with mp.workdps(DPS):
        a, b, c, d = _m(l1), _m(l2), _m(l3), _m(l4)
        g = _m(ground_angle)
        for reach, kind in ((c + b, 'extended'), (abs(c - b), 'folded')):
            cos_t = (reach * reach - a * a - d * d) / (2 * a * d)
            if -1 <= cos_t <= 1:
                t = mp.acos(cos_t)
                out += [(wrap(g + t), kind), (wrap(g - t), kind)]
    return out


# ---- slider-crank ----------------------------------------------------------------------------


def _slide_frame(direction_angle):
    dang = _m(direction_angle)
    d = (mp.cos(dang), mp.sin(dang))
    return d, (-d[1], d[0])


def slider_crank(r, rod, e, direction_angle, theta2, branch=1):
    """Slider-crank at crank angle theta2: A, B, theta3 (A->B), the slider value x and ``miss``
    (> 0 when the rod cannot reach the line of stroke)."""
    with mp.workdps(DPS):
        d, n = _slide_frame(direction_angle)
        r, rod, e, t2 = _m(r), _m(rod), _m(e), _m(theta2)
        a = (r * mp.cos(t2), r * mp.sin(t2))
        foot = (e * n[0], e * n[1])
        dy = circle_line(a, rod, foot, d, branch)
        out = {
            'O2': (mp.mpf(0), mp.mpf(0)),
            'A': a,
            'theta2': t2,
            'miss': dy.miss,
            'ok': dy.point is not None,
            'margin': dy.margin,
        }
        if dy.point is None:
            return out
        b = dy.point
        out['B'] = b
        out['theta3'] = direction(a, b)
        out['x'] = (b[0] - foot[0]) * d[0] + (b[1] - foot[1]) * d[1]
        return out


def slider_crank_inverse(r, rod, e, direction_angle, x, branch=1):
    """Slider-crank with the slider value x known: A from circles about O2 (r) and B (rod),
    ``branch`` +1 putting A left of O2 -> B."""
    with mp.workdps(DPS):
        d, n = _slide_frame(direction_angle)
        e, x = _m(e), _m(x)
        b = (e * n[0] + x * d[0], e * n[1] + x * d[1])
        dy = circle_circle((0, 0), r, b, rod, branch)
        out = {
            'O2': (mp.mpf(0), mp.mpf(0)),
            'B': b,
            'x': x,
            'miss': dy.miss,
            'ok': dy.point is not None,
            'margin': dy.margin,
        }
        if dy.point is None:
            return out
        a = dy.point
        out['A'] = a
        out['theta2'] = direction(out['O2'], a)
        out['theta3'] = direction(a, b)
        return out


# ---- five-bar (2 DOF) ------------------------------------------------------------------------


def five_bar(o1, o5, l_left, l_right, l_ac, l_bc, q1, q2, branch=1):
    """Five-bar: cranks O1->A (angle q1) and O5->B (angle q2); C from circles about A (l_ac) and
    B (l_bc), ``branch`` +1 putting C left of A -> B."""
    with mp.workdps(DPS):
        o1, o5 = _pt(o1), _pt(o5)
        q1, q2 = _m(q1), _m(q2)
        a = (o1[0] + _m(l_left) * mp.cos(q1), o1[1] + _m(l_left) * mp.sin(q1))
        b = (o5[0] + _m(l_right) * mp.cos(q2), o5[1] + _m(l_right) * mp.sin(q2))
        dy = circle_circle(a, l_ac, b, l_bc, branch)
        return {'A': a, 'B': b, 'C': dy.point, 'ok': dy.point is not None, 'miss': dy.miss}


def to_float_point(p):
    return (float(p[0]), float(p[1]))


def sqrt_law_bound(distance: float, rho: float, c: float = 8.0) -> float:
    """Error bound for a configuration at ``distance`` (a dimensionless measure, e.g. radians of
    input) from a tangency (toggle), when the data carry a relative error ``rho``.

    Near a tangency the dyad height behaves like h ~ sqrt(distance), so a perturbation rho of the
    inputs moves the solution by dh ~ rho / sqrt(distance); at the tangency itself the
    perturbation can only open the square root to sqrt(rho). Both regimes are captured by
    rho / sqrt(distance + rho). ``c`` absorbs the geometry's O(1) factors.
    """
    return c * rho / math.sqrt(distance + rho)


# ---- 3-D frames of robot descriptions (URDF / SDFormat), written apart from the core -------------


def rpy_matrix(r: float, p: float, y: float):
    """URDF / SDFormat rpy: fixed-axis roll about x, then pitch about y, then yaw about z."""
    import numpy as np

    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def homogeneous(rot, xyz):
    """The 4x4 transform of a rotation matrix and a translation."""
    import numpy as np

    out = np.eye(4)
    out[:3, :3], out[:3, 3] = rot, xyz
    return out


def central_difference_rates(solver, values, rates, h):
    """(joint rates, point velocities) by central differences of two position solves."""
    plus = solver.solve({a: values[a] + h * rates[a] for a in values}, commit=False)
    minus = solver.solve({a: values[a] - h * rates[a] for a in values}, commit=False)
    assert plus.success and minus.success
    joints = {
        j: math.remainder(plus.joints[j] - minus.joints[j], 2 * math.pi) / (2 * h)
        if j in {r.name for r in solver.mech.revolutes}
        else (plus.joints[j] - minus.joints[j]) / (2 * h)
        for j in plus.joints
    }
    points = {
        p: (
            (plus.points[p][0] - minus.points[p][0]) / (2 * h),
            (plus.points[p][1] - minus.points[p][1]) / (2 * h),
        )
        for p in plus.points
    }
    return joints, points


@functools.cache
def _numpy_trig_is_libm() -> bool:
    """Whether numpy's sin, cos, arctan2 and arccos round as libm's on this machine at all: on
    a fixed sample of 4000 arguments. Where numpy dispatches to its own SIMD kernels (AVX-512
    machines: arctan2 and arccos differ from libm in the last bit on 7-9% of arguments, sin
    and cos agree) the steps inside a solve that the inputs do not show differ too."""
    import numpy as np

    rng = np.random.default_rng(20261127)
    a, b = rng.uniform(-4.0, 4.0, 4000), rng.uniform(-4.0, 4.0, 4000)
    c = a / 4.0
    return (
        np.sin(a).tolist() == [math.sin(x) for x in a.tolist()]
        and np.cos(a).tolist() == [math.cos(x) for x in a.tolist()]
        and np.arctan2(a, b).tolist() == [math.atan2(x, y) for x, y in zip(a.tolist(), b.tolist())]
        and np.arccos(c).tolist() == [math.acos(x) for x in c.tolist()]
    )


def trig_is_libm(angles) -> bool:
    """numpy's sin, cos and arctan2 round as Python's math (libm) does on these angles, and on
    this machine's sample (_numpy_trig_is_libm): where they do, a batch and a one-command solve
    can be compared float for float."""
    import numpy as np

    if not _numpy_trig_is_libm():
        return False
    a = np.asarray(angles, float).reshape(-1)
    b = a[::-1].copy()
    return all(
        float(s) == math.sin(x) and float(c) == math.cos(x) and float(t) == math.atan2(x, y)
        for s, c, t, x, y in zip(np.sin(a), np.cos(a), np.arctan2(a, b), a.tolist(), b.tolist())
    )


# ---- a Stephenson six-bar driven at its output link ------------------------------------------
def _circles_meet(c1, r1, c2, r2, side: int):
    """Where circles (c1, r1) and (c2, r2) meet, left (+1) or right (-1) of c1 -> c2."""
    import numpy as np

    d = c2 - c1
    L = float(np.hypot(*d))
    x = (r1 * r1 - r2 * r2 + L * L) / (2 * L)
    h = math.sqrt(max(r1 * r1 - x * x, 0.0))
    u = d / L
    return c1 + x * u + side * h * np.array([-u[1], u[0]])


def _left_of(a, b, x) -> int:
    return 1 if (b - a)[0] * (x - a)[1] - (b - a)[1] * (x - a)[0] > 0 else -1


def stephenson_drive(points: dict):
    """The drive angle (rad, at O6, unwrapped about the drawing's) of a Stephenson six-bar
    drawn with ``points`` (O2, A, B, O4 its four-bar; C on the coupler A-B-C; D where link5
    C-D meets the output O6-D) as a function of the crank O2-A's angle: B and D each on its
    drawn side, by circle intersections written here."""
    import numpy as np

    P = {k: np.array(v, float) for k, v in points.items()}
    a, b, c = (np.linalg.norm(P[q] - P[p]) for p, q in (('O2', 'A'), ('A', 'B'), ('O4', 'B')))
    cd, out = np.linalg.norm(P['D'] - P['C']), np.linalg.norm(P['D'] - P['O6'])
    sb, sd = _left_of(P['A'], P['O4'], P['B']), _left_of(P['C'], P['O6'], P['D'])
    ab0, ac0 = P['B'] - P['A'], P['C'] - P['A']
    drawn = math.atan2(*(P['D'] - P['O6'])[::-1])

    def drive(t: float) -> float:
        A = P['O2'] + a * np.array([math.cos(t), math.sin(t)])
        B = _circles_meet(A, b, P['O4'], c, sb)
        rot = math.atan2(*(B - A)[::-1]) - math.atan2(*ab0[::-1])
        cs, sn = math.cos(rot), math.sin(rot)
        C = A + np.array([ac0[0] * cs - ac0[1] * sn, ac0[0] * sn + ac0[1] * cs])
        D = _circles_meet(C, cd, P['O6'], out, sd)
        return drawn + math.remainder(math.atan2(*(D - P['O6'])[::-1]) - drawn, 2 * math.pi)

    return drive


def extreme_near_samples(f, grid, sense: int, width: float, xatol: float = 1e-11):
    """(x, f(x)) at the least (``sense`` 1) or greatest (-1) of ``f``: its best sample on
    ``grid`` refined by a bounded scalar search within ``width`` of it (f flat there: the
    value's error is the search's squared)."""
    from scipy.optimize import minimize_scalar

    k = min(range(len(grid)), key=lambda i: sense * f(grid[i]))
    got = minimize_scalar(
        lambda t: sense * f(t),
        bounds=(grid[k] - width, grid[k] + width),
        method='bounded',
        options={'xatol': xatol},
    )
    return float(got.x), sense * float(got.fun)
