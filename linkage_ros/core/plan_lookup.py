"""What running a plan looks up by name, resolved once per plan: shared by the batch executor
(:mod:`linkage_ros.core.execute`) and the one-command program
(:mod:`linkage_ros.core.scalar_plan`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class PlanLookup:
    """A plan's reference geometry as complex numbers (m): ``ref[point]`` each point's reference
    position, ``direction[joint]`` each slide's direction, ``single[body]`` whether a body is one
    link (no welds: its frame is the link's), ``carrier[(body, point)]`` the member link whose
    frame carries a point."""

    ref: dict[str, complex]
    direction: dict[str, complex]
    single: list[bool]
    carrier: dict[tuple[int, str], str]


def plan_lookup(plan: Any) -> PlanLookup:
    """The lookups of ``plan`` (made on first use and kept on the plan)."""
    got: PlanLookup | None = plan.derived.get(PlanLookup)
    if got is not None:
        return got
    mech = plan.mech
    carrier: dict[tuple[int, str], str] = {}
    for b in plan.bodies:
        for link in b.links:
            for p in mech.links[link].points:
                carrier.setdefault((b.index, p), link)
    got = plan.derived[PlanLookup] = PlanLookup(
        {p: complex(float(v[0]), float(v[1])) for p, v in mech.points.items()},
        {
            j: complex(float(pj.direction[0]), float(pj.direction[1]))
            for j, pj in mech.prismatics.items()
        },
        [not b.welds for b in plan.bodies],
        carrier,
    )
    return got
