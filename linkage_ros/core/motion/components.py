"""Independent parts of a mechanism: the links an actuator can move, as a mechanism of their own.

With the ground fixed, two moving links influence each other only through a point they share
off the ground, a slider between them or an angle actuator measured from one to the other.
Splitting a scene into those parts lets a range analysis compile and scan only what one
actuator moves (a scene of 300 independent four-bars costs 300 small scans, not 300 scans of
the whole scene); each part keeps the whole scene's length scale, so tolerances are unchanged.
"""

from __future__ import annotations

import dataclasses

from ..disjoint import DisjointSets
from ..model import AngleActuator, Link, Mechanism


def _driven_link(mech: Mechanism, actuator: str) -> str:
    """A moving link the actuator acts on."""
    act = mech.actuators[actuator]
    if isinstance(act, AngleActuator):
        return act.link
    pj = mech.prismatics[act.joint]
    return pj.slider if pj.slider != mech.ground else pj.guide


def _link_groups(mech: Mechanism) -> dict[str, str]:
    """{moving link: representative of its independent part} (union-find)."""
    sets = DisjointSets(mech.moving_links)
    find = sets.find

    def join(a: str, b: str) -> None:
        if a != mech.ground and b != mech.ground:
            sets.union(b, a)

    ground_points = set(mech.links[mech.ground].points)
    holder: dict[str, str] = {}  # point off the ground -> first moving link carrying it
    for name, link in mech.links.items():
        if name == mech.ground:
            continue
        for p in link.points:
            if p in ground_points:
                continue
            if p in holder:
                join(holder[p], name)
            else:
                holder[p] = name
    for j in mech.revolutes:
        join(j.parent, j.child)
    for pj in mech.prismatics.values():
        join(pj.guide, pj.slider)
    for act in mech.actuators.values():
        if isinstance(act, AngleActuator):
            join(act.link, act.reference)
    return {l: find(l) for l in mech.moving_links}


def _part(mech: Mechanism, links: set[str]) -> Mechanism:
    """The mechanism of the ground and ``links`` (one independent part)."""
    ground = mech.links[mech.ground]
    used = {p for l in links for p in mech.links[l].points}
    # the ground keeps its axis points, first and in order (its axis, when not named, is its
    # first two points), and the pivots of this part
    keep_ground = set(ground.axis or ground.points[:2]) | used
    ground_part = Link(
        ground.name,
        tuple(p for p in ground.points if p in keep_ground),
        ground.angle_ref,
        ground.axis,
    )
    kept = links | {mech.ground}
    points = used | set(ground_part.points)
    prismatics = {
        n: pj for n, pj in mech.prismatics.items() if pj.guide in kept and pj.slider in kept
    }
    actuators = {
        n: a
        for n, a in mech.actuators.items()
        if (a.link in links if isinstance(a, AngleActuator) else a.joint in prismatics)
    }
    return dataclasses.replace(
        mech,
        name=mech.name,
        points={p: v for p, v in mech.points.items() if p in points},
        links={
            n: (ground_part if n == mech.ground else l) for n, l in mech.links.items() if n in kept
        },
        revolutes=[j for j in mech.revolutes if j.parent in kept and j.child in kept],
        prismatics=prismatics,
        actuators=actuators,
        outputs=tuple(o for o in mech.outputs if o in points),
        dimensions={k: v for k, v in mech.dimensions.items() if k[0] in kept},
        joint_coordinates=None,
    )


def actuator_parts(mech: Mechanism) -> dict[str, Mechanism]:
    """{actuator: the mechanism of the independent part it moves}; ``mech`` itself for every
    actuator when the scene is one part (the usual case)."""
    groups = _link_groups(mech)
    roots = set(groups.values())
    if len(roots) <= 1:
        return {a: mech for a in mech.actuators}
    members: dict[str, set[str]] = {}
    for link, root in groups.items():
        members.setdefault(root, set()).add(link)
    parts: dict[str, Mechanism] = {}
    out = {}
    for a in mech.actuators:
        root = groups[_driven_link(mech, a)]
        if root not in parts:
            parts[root] = _part(mech, members[root])
        out[a] = parts[root]
    return out
