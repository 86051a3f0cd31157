"""Reading a solved configuration back: adopting it for continuity, and its assembly mode."""

from __future__ import annotations

import cmath
import math
from typing import Any

import numpy as np

from ..dyads import wrap_angle
from ..plan import ScalarPoses, branch_geometry_one, spec_value_one
from ..quantities import PointSpec
from .result import Result


class ConfigurationReading:
    """Solver's reading of results (a mixin: it uses the solver's mechanism, specs and plans)."""

    mech: Any
    specs: Any
    plan: Any
    closure_limit: float
    _history: Any

    def _state(self, *args: Any, **kwargs: Any) -> Any:  # Solver's
        raise NotImplementedError

    def adopt(self, result: Result) -> bool:
        """Make a solved configuration (from any solver of this mechanism) the 'previous
        configuration' for continuity and warm starts. Returns False, changing nothing, if the
        result is unusable: failed, missing a link or point, non-finite, or its points not where
        its link angles put them (not a rigid configuration of this mechanism)."""
        got = self.configuration_of(result)
        if got is None:
            return False
        pts, poses = got
        vals = []
        for s in self.specs:
            v = spec_value_one(self.mech, s, poses)
            vals.append(np.asarray(v, float) if isinstance(s, PointSpec) else float(v))
        if self.plan.complete:
            signs, margins = branch_geometry_one(self.plan, pts, poses)
        else:
            signs, margins = self.plan.reference_signs, ()
        self._history = [self._state(vals, poses, pts, signs, margins=margins)]
        return True

    def mode_of(self, result: Result) -> tuple[tuple[int, ...], list[float]] | None:
        """The assembly mode of a solved configuration (from any solver of this mechanism) as
        this solver's plan reads it: the branch sign and dyad margin of each branching step
        (a sign is undefined where its margin is ~0, at that dyad's toggle). None if the result
        is unusable (see :meth:`adopt`) or the plan is not complete."""
        plan = self.plan if self.plan.complete else getattr(self, 'full_plan', None)
        if plan is None or not plan.complete:
            return None
        got = self.configuration_of(result)
        if got is None:
            return None
        signs, margins = branch_geometry_one(plan, *got)
        return tuple(int(s) for s in signs), [float(m) for m in margins]

    def configuration_of(self, result: Result) -> tuple[dict[str, complex], ScalarPoses] | None:
        """(points, poses) of a successful result of this mechanism, or None if unusable."""
        mech = self.mech
        try:
            if not (
                isinstance(result, Result)
                and result.success
                and set(result.links) == set(mech.links)
                and set(result.points) >= set(mech.points)
            ):
                return None
            pts = {
                p: complex(float(result.points[p][0]), float(result.points[p][1]))
                for p in mech.points
            }
            phis = {l: float(result.links[l]) for l in mech.links}
        except (TypeError, ValueError, IndexError, KeyError, AttributeError):
            return None
        if not all(math.isfinite(v) for v in phis.values()) or not all(
            cmath.isfinite(w) for w in pts.values()
        ):
            return None
        poses = ScalarPoses()
        tol = self.closure_limit * mech.length_scale
        for l, link in mech.links.items():
            phi = wrap_angle(phis[l] - link.angle_ref)
            rot = complex(math.cos(phi), math.sin(phi))
            p = link.points[0]
            poses.set(l, phi, pts[p] - rot * complex(*mech.points[p]), rot)
            if any(
                abs(poses.world(l, complex(*mech.points[q])) - pts[q]) > tol
                for q in link.points[1:]
            ):
                return None
        return pts, poses
