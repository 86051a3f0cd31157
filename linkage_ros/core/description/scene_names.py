"""Scene names for a description's links, joints and points (letters, digits and _)."""

from __future__ import annotations

import re
from collections.abc import Iterable

NAME_BAD = re.compile(r'[^A-Za-z0-9_]')


class SceneNames:
    """Scene names for description names (letters, digits, _; starting with a letter). A
    name that is one already keeps it; a renamed one never takes a name some description
    name has as its own (``reserved``): `left-crank` beside a link `left_crank` is
    left_crank_2, where the first come took left_crank and a target meant for the link
    named so moved the other (an integrator)."""

    def __init__(self, reserved: Iterable[str] = ()) -> None:
        self.used: set[str] = set()
        self.reserved = {n for n in reserved if _valid(n)}
        #: (kind, description name) -> scene name, for the names that changed
        self.renamed: dict[tuple[str, str], str] = {}
        self.of: dict[tuple[str, str], str] = {}
        #: a point merged into another at the same place (a compound hinge)
        self.alias: dict[str, str] = {}
        #: each scene point's depth along the chain's normal (m)
        self.depths: dict[str, float] = {}

    def point(self, raw: str) -> str:
        """The scene point of a joint or closure (after merging coincident pins)."""
        name = self.of[('point', raw)]
        while name in self.alias:
            name = self.alias[name]
        return name

    def __call__(self, kind: str, raw: str) -> str:
        key = (kind, raw)
        if key in self.of:
            return self.of[key]
        name = NAME_BAD.sub('_', raw)
        if not name[:1].isalpha():
            name = 'n_' + name
        base, k = name, 1
        while name in self.used or (name != raw and name in self.reserved):
            k += 1
            name = f'{base}_{k}'
        self.used.add(name)
        self.of[key] = name
        if name != raw:
            self.renamed[key] = name
        return name


def _valid(name: str) -> bool:
    """Whether ``name`` is a scene name as it stands."""
    return name[:1].isalpha() and NAME_BAD.search(name) is None


__all__ = ['SceneNames']
