"""Closed-form position analysis of the planar 4R four-bar and the offset slider-crank.

Conventions (lengths in any consistent unit, angles in radians, counter-clockwise from +x):

* Four-bar O2-A-B-O4: ground pivot O2 at the origin, O4 at (l1, 0).  Crank l2 = |O2A| at
  ``theta2``, coupler l3 = |AB| at ``theta3``, rocker l4 = |O4B| at ``theta4``.
* Slider-crank: crank r = |O2A| at ``theta2``, rod l = |AB| at ``theta3``; the slider pin B moves
  on the line y = e (offset ``e``, sliding along +x); the slider position is x = B_x.

Every function is vectorised (numpy broadcasting over all arguments) and never returns NaN or
inf: where a configuration cannot be assembled ``ok`` is False and finite placeholders are
returned (angles 0).  Scalar inputs give 0-d numpy scalars.

Why the formulation looks the way it does:

* Positions come from intersecting two circles with the triangle height taken from Kahan's
  sorted-sides area formula, which stays accurate for needle-like triangles (near toggle /
  tangency) where the textbook ``sqrt(r1**2 - a**2)`` loses half of its digits.
* Angles come from ``atan2`` of position differences, never from the tan-half-angle quotient of
  the Freudenstein equation, which divides by zero when an angle reaches pi.
* Tangency is accepted within a tolerance *relative to the length scale of the triangle*, so
  results do not change when every length is multiplied by the same factor.
* Batches run block by block through fast kernels (see "fast block kernels" below) that keep
  their work arrays in cache; elements with a length or centre distance outside 2**+-200 or
  non-finite input (and calls with a negative or NaN tolerance) take the general whole-array
  formulas instead.  Both give the same results to rounding.  The general formulas first divide
  every length by a power of four (exact, per element) that brings the longest to [1, 4), so
  lengths near 1e308 or 5e-324 are solved like any other scale; a result that is itself beyond
  the float range (a slider position x > 1.8e308) is refused (ok False).  Angles of exactly
  -pi (signed zeros) are returned as +pi.  The kernels measure the closure
  residual along the solved link directions (unit vectors of B - A and B - O4) instead of
  through cos/sin of the returned angles, and take |sin(mu)| of the four-bar from the Kahan
  triangle area (2 * area / (l3 * l4)).
"""

from __future__ import annotations

from .common import (
    FourBarInverseSolution,
    FourBarSolution,
    SliderCrankInverseSolution,
    SliderCrankSolution,
    angle_opposite,
    circle_intersection,
    triangle_area,
)
from .four_r import (
    fourbar_forward,
    fourbar_inverse,
)
from .slider import (
    slider_crank_forward,
    slider_crank_inverse,
    slider_crank_stroke,
)

__all__ = [
    'angle_opposite',
    'circle_intersection',
    'fourbar_forward',
    'fourbar_inverse',
    'FourBarInverseSolution',
    'FourBarSolution',
    'slider_crank_forward',
    'slider_crank_inverse',
    'slider_crank_stroke',
    'SliderCrankInverseSolution',
    'SliderCrankSolution',
    'triangle_area',
]
