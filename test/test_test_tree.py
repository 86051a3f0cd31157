"""The test tree's modules have names of their own: pytest's default import mode puts each test
folder on sys.path and imports a module by its bare name, so two helper modules of one name in
two folders would hand one folder's tests the other's helpers (the first imported wins)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

TESTS = Path(__file__).resolve().parent


def test_every_test_module_name_is_unique():
    where: dict[str, list[str]] = defaultdict(list)
    for path in TESTS.rglob('*.py'):
        if path.name not in ('conftest.py', '__init__.py'):
            where[path.stem].append(str(path.relative_to(TESTS)))
    clashes = {name: paths for name, paths in where.items() if len(paths) > 1}
    assert not clashes, f'modules of one name in several folders: {clashes}'
