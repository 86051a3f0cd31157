"""Disjoint sets of names (union-find with path halving): which links a plan welds into one
body, which links move together. scipy's DisjointSet would do, but importing scipy.cluster
costs half a second of every command's start-up."""

from __future__ import annotations

from collections.abc import Iterable


class DisjointSets:
    """Names in sets; :meth:`union` joins two sets, :meth:`find` names a set's representative."""

    def __init__(self, names: Iterable[str]):
        self._parent = {n: n for n in names}

    def find(self, a: str) -> str:
        parent = self._parent
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    def union(self, a: str, b: str) -> bool:
        """Join the sets of a and b (b's under a's representative); False if already one."""
        ra, rb = self.find(a), self.find(b)
        if ra == rb:
            return False
        self._parent[rb] = ra
        return True
