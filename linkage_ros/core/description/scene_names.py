"""Scene names for a description's links, joints and points (letters, digits and _)."""

from __future__ import annotations

import re

NAME_BAD = re.compile(r'[^A-Za-z0-9_]')


class SceneNames:
    """Scene names for description names (letters, digits, _; starting with a letter)."""

    def __init__(self) -> None:
        self.used: set[str] = set()
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
        while name in self.used:
            k += 1
            name = f'{base}_{k}'
        self.used.add(name)
        self.of[key] = name
        return name


__all__ = ['SceneNames']
