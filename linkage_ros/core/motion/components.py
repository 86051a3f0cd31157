"""Independent parts of a mechanism: the links an actuator can move, as a mechanism of their own.

With the ground fixed, two moving links influence each other only through a point they share
off the ground, a slider between them or an angle actuator measured from one to the other.
Splitting a scene into those parts lets a range analysis compile and scan only what one
actuator moves (a scene of 300 independent four-bars costs 300 small scans, not 300 scans of
the whole scene); each part keeps the whole scene's length scale, so tolerances are unchanged.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..disjoint import DisjointSets
from ..model import Actuator, AngleActuator, Link, Mechanism, PrismaticJoint, RevoluteJoint


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


def _parts(mech: Mechanism, members: dict[str, set[str]]) -> dict[str, Mechanism]:
    """{root: the mechanism of the ground and the links of ``members[root]``} (the independent
    parts), each element of the scene looked at once: linear in a scene of many parts. What
    joins the ground to itself goes into every part."""
    ground_name = mech.ground
    root_of = {l: root for root, links in members.items() for l in links}

    def roots(*links: str) -> list[str]:
        """The parts an element on ``links`` belongs to: the one part of its moving links (none
        if they are in no part, or in two), every part where all are the ground."""
        moving = {root_of.get(l) for l in links if l != ground_name}
        if not moving:
            return list(members)
        return [r for r in moving if r is not None] if len(moving) == 1 else []

    ground = mech.links[ground_name]
    # the ground keeps its axis points, first and in order (its axis, when not named, is its
    # first two points), and the pivots of the part
    axis = set(ground.axis or ground.points[:2])
    ground_at = {p: k for k, p in enumerate(ground.points)}
    used: dict[str, set[str]] = {root: set() for root in members}
    for root, links in members.items():
        for l in links:
            used[root].update(mech.links[l].points)
    points_of = {root: used[root] | {p for p in axis if p in ground_at} for root in members}
    ground_parts = {
        root: Link(
            ground.name,
            tuple(
                sorted((p for p in points_of[root] if p in ground_at), key=ground_at.__getitem__)
            ),
            ground.angle_ref,
            ground.axis,
        )
        for root in members
    }
    point_parts: dict[str, list[str]] = {}
    for root, pts in points_of.items():
        for p in pts:
            point_parts.setdefault(p, []).append(root)
    kept_links: dict[str, dict[str, Link]] = {root: {} for root in members}
    for n, body in mech.links.items():
        for root in roots(n):
            kept_links[root][n] = ground_parts[root] if n == ground_name else body
    revolutes: dict[str, list[RevoluteJoint]] = {root: [] for root in members}
    for j in mech.revolutes:
        for root in roots(j.parent, j.child):
            revolutes[root].append(j)
    prismatics: dict[str, dict[str, PrismaticJoint]] = {root: {} for root in members}
    for n, pj in mech.prismatics.items():
        for root in roots(pj.guide, pj.slider):
            prismatics[root][n] = pj
    actuators: dict[str, dict[str, Actuator]] = {root: {} for root in members}
    for n, a in mech.actuators.items():
        if isinstance(a, AngleActuator):
            if a.link in root_of:
                actuators[root_of[a.link]][n] = a
        else:
            for root in roots(mech.prismatics[a.joint].guide, mech.prismatics[a.joint].slider):
                if a.joint in prismatics[root]:
                    actuators[root][n] = a
    point_values: dict[str, dict[str, np.ndarray]] = {root: {} for root in members}
    for p, xy in mech.points.items():
        for root in point_parts.get(p, ()):
            point_values[root][p] = xy
    outputs: dict[str, list[str]] = {root: [] for root in members}
    for o in mech.outputs:
        for root in point_parts.get(o, ()):
            outputs[root].append(o)
    dimensions: dict[str, dict[tuple[str, str, str], float]] = {root: {} for root in members}
    for k, v in mech.dimensions.items():
        for root in roots(k[0]):
            dimensions[root][k] = v
    return {
        root: dataclasses.replace(
            mech,
            name=mech.name,
            points=point_values[root],
            links=kept_links[root],
            revolutes=revolutes[root],
            prismatics=prismatics[root],
            actuators=actuators[root],
            outputs=tuple(outputs[root]),
            dimensions=dimensions[root],
            joint_coordinates=None,
        )
        for root in members
    }


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
    driven = {a: groups[_driven_link(mech, a)] for a in mech.actuators}
    parts = _parts(mech, {root: members[root] for root in dict.fromkeys(driven.values())})
    return {a: parts[root] for a, root in driven.items()}
