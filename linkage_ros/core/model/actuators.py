"""The general form's actuators: angle (a link relative to another) or slide (a prismatic
joint), and the limits every input may carry."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..mechanism import Actuator, AngleActuator, Link, PrismaticJoint, SlideActuator
from ..units import Quantity, degrees_warning, span_warning
from .checks import SceneContext


def read_actuators(
    ctx: SceneContext,
    data: Mapping[str, Any],
    ground: str,
    links: Mapping[str, Link],
    prismatics: Mapping[str, PrismaticJoint],
    actuators: dict[str, Actuator],
) -> None:
    """actuators: angle (a link relative to another) or slide (a prismatic joint)."""
    turns = _AngleGraph()  # which links the angle actuators already turn relative to another
    act_raw = data.get('actuators') or {}
    ctx.mapping('actuators', act_raw)
    for aname, spec in act_raw.items():
        key = f'actuators.{aname}'
        ctx.name(key, aname)
        if aname in actuators:
            ctx.fail(key, 'duplicate actuator name (a cylinder already has it)', aname)
        spec = ctx.mapping(key, spec)
        kind = spec.get('type')
        if kind == 'angle':
            lo, hi = read_limits(ctx, key, spec, Quantity.ANGLE)
            ctx.only(key, spec, {'type', 'link', 'pivot', 'toward', 'relative_to', 'min', 'max'})
            link = spec.get('link')
            if not ctx.known(link, links) or link == ground:
                ctx.fail(f'{key}.link', 'must name a moving link', link)
            ref = spec.get('relative_to', ground)
            if not ctx.known(ref, links) or ref == link:
                ctx.fail(f'{key}.relative_to', 'must name another link', ref)
            link, ref = str(link), str(ref)  # checked names
            chain = turns.path(link, ref)
            if chain is not None:
                ctx.fail(
                    f'{key}.relative_to',
                    f'closes a cycle of angle actuators ({", ".join([*chain, aname])}): the '
                    f'angle of {link!r} relative to {ref!r} is already fixed by the others',
                    ref,
                )
            turns.join(link, ref, aname)
            pivot = spec.get('pivot')
            if not ctx.known(pivot, links[link].points):
                ctx.fail(f'{key}.pivot', f'must be a point of link {link!r}', pivot)
            toward = spec.get('toward')
            if toward is None:
                others = [p for p in links[link].points if p != pivot]
                if not others:
                    ctx.fail(f'{key}.toward', f'link {link!r} has one point: name `toward`', None)
                toward = others[0]
            if not ctx.known(toward, links[link].points) or toward == pivot:
                ctx.fail(f'{key}.toward', f'must be another point of link {link!r}', toward)
            actuators[aname] = AngleActuator(
                aname,
                link=link,
                reference=ref,
                pivot=str(pivot),
                toward=str(toward),
                min=lo,
                max=hi,
            )
        elif kind == 'slide':
            ctx.only(key, spec, {'type', 'joint', 'min', 'max'})
            lo, hi = read_limits(ctx, key, spec, Quantity.LENGTH)
            joint = spec.get('joint')
            if not ctx.known(joint, prismatics):
                ctx.fail(f'{key}.joint', 'must name a prismatic joint (sliders)', joint)
            actuators[aname] = SlideActuator(aname, joint=str(joint), min=lo, max=hi)
        else:
            ctx.fail(f'{key}.type', "must be 'angle' or 'slide'", kind)


class _AngleGraph:
    """Links joined by angle actuators (each fixes one link's angle relative to another): a
    new actuator between links already joined would over-constrain them."""

    def __init__(self) -> None:
        self.edges: dict[str, list[tuple[str, str]]] = {}  # link -> [(other link, actuator)]

    def join(self, a: str, b: str, actuator: str) -> None:
        self.edges.setdefault(a, []).append((b, actuator))
        self.edges.setdefault(b, []).append((a, actuator))

    def path(self, a: str, b: str) -> list[str] | None:
        """The actuators joining a to b (breadth first), or None if they are not joined."""
        seen: dict[str, tuple[str, str] | None] = {a: None}
        todo = [a]
        while todo:
            here = todo.pop(0)
            if here == b:
                chain: list[str] = []
                while seen[here] is not None:
                    prev, act = seen[here]  # type: ignore[misc]
                    chain.append(act)
                    here = prev
                return chain[::-1]
            for other, act in self.edges.get(here, []):
                if other not in seen:
                    seen[other] = (here, act)
                    todo.append(other)
        return None


def read_limits(
    ctx: SceneContext, key: str, spec: Mapping[str, Any], quantity: Quantity
) -> tuple[float | None, float | None]:
    """``min`` and ``max`` of ``spec`` (rad or m, by ``quantity``; either may be absent).
    Angle limits of bare numbers spanning more than a full turn, or beyond one, are read with
    one warning (likely degrees)."""
    lo_raw, hi_raw = spec.get('min'), spec.get('max')
    lo = None if lo_raw is None else ctx.reading(f'{key}.min', lo_raw, quantity)
    hi = None if hi_raw is None else ctx.reading(f'{key}.max', hi_raw, quantity)
    if lo is not None and hi is not None and not lo.value < hi.value:
        ctx.fail(
            f'{key}.max', f'must be greater than min ({lo.value:g} {quantity.si_unit})', hi_raw
        )
    if quantity is Quantity.ANGLE:
        span = None if lo is None or hi is None else span_warning(f'{key}.min/max', lo, hi)
        ctx.warn(span)
        if span is None:
            for name, reading in (('min', lo), ('max', hi)):
                if reading is not None:
                    ctx.warn(degrees_warning(f'{key}.{name}', reading))
    return (None if lo is None else lo.value), (None if hi is None else hi.value)
