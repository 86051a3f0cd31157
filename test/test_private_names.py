"""No module of the package or its tests imports another module's private name (a leading
underscore): what one module uses of another is that module's public interface, named so.
Modules keep their own helpers private; a helper two modules share is public where it is
defined (issue 25: no private reach-ins across modules)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the package, and the tests (their shared helper modules are imported by name)
TREES = (ROOT / 'linkage_ros', ROOT / 'test')


def private_imports(source: str) -> list[tuple[str, str]]:
    """(module as written, name) of every ``from M import _name`` in ``source``, at any depth
    (inside functions and TYPE_CHECKING blocks too); dunder names are not private."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module != '__future__':
            module = '.' * node.level + (node.module or '')
            for alias in node.names:
                name = alias.name
                if name.startswith('_') and not (name.startswith('__') and name.endswith('__')):
                    found.append((module, name))
    return found


def test_no_module_imports_a_private_name_of_another():
    offenders = [
        f'{path.relative_to(ROOT)}: from {module} import {name}'
        for tree in TREES
        for path in sorted(tree.rglob('*.py'))
        for module, name in private_imports(path.read_text())
    ]
    assert not offenders, 'private names imported across modules:\n' + '\n'.join(offenders)


def test_the_check_sees_every_form_of_import():
    source = (
        'from __future__ import annotations\n'
        'from typing import TYPE_CHECKING\n'
        'from .a import public, _private\n'
        'from ..b import (\n    _one,\n    two,\n)\n'
        'from c.d import __version__\n'
        'if TYPE_CHECKING:\n    from .e import _Typed\n'
        'def f():\n    from .g import _late as late\n'
    )
    assert private_imports(source) == [
        ('.a', '_private'),
        ('..b', '_one'),
        ('.e', '_Typed'),
        ('.g', '_late'),
    ]
