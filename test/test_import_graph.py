"""No import circles anywhere in the package, counting every import: module level, inside
functions and under TYPE_CHECKING (grimp reads them all from the source), the ``linkage``
parser's plug-in modules (imported by name), and the packages an import runs on its way
(importing ``a.b.c`` runs ``a/__init__`` and ``a/b/__init__`` first: a circle closed through a
package's ``__init__`` is as real as one through a module)."""

from __future__ import annotations

import grimp


def _parents(module: str) -> list[str]:
    parts = module.split('.')
    return ['.'.join(parts[:i]) for i in range(1, len(parts))]


def import_edges(graph: grimp.ImportGraph) -> dict[str, set[str]]:
    """Each module's imports, with the packages each import runs first (other than the
    importer's own packages, which run before the importer itself)."""
    edges = {}
    for module in graph.modules:
        direct = set(graph.find_modules_directly_imported_by(module))
        own = set(_parents(module))
        edges[module] = direct | {p for m in direct for p in _parents(m) if p not in own} - {module}
    return edges


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iteratively)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in sorted(edges):
        if root in index:
            continue
        work = [(root, iter(sorted(edges[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    m = stack.pop()
                    on_stack.discard(m)
                    component.append(m)
                    if m == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def _with_plugins(edges: dict[str, set[str]]) -> dict[str, set[str]]:
    """The ``linkage`` parser imports its subcommand modules by name (importlib, from its
    plug-in table): imports all the same, which grimp cannot read from the source."""
    from linkage_ros.cli.parser import EXTERNAL_COMMANDS

    parser = 'linkage_ros.cli.parser'
    plugins = {m for m in EXTERNAL_COMMANDS.values() if m in edges}
    assert plugins, 'the plug-in table names no module of the package'
    edges[parser] = (
        edges[parser]
        | plugins
        | {p for m in plugins for p in _parents(m)}
        - {
            'linkage_ros',
            'linkage_ros.cli',
        }
    )
    return edges


def test_no_module_imports_itself_back():
    graph = grimp.build_graph('linkage_ros', include_external_packages=False)
    found = circles(_with_plugins(import_edges(graph)))
    assert not found, 'import circles:\n' + '\n'.join(' <-> '.join(c) for c in found)


def _probe(tmp_path, monkeypatch, files: dict[str, str]) -> grimp.ImportGraph:
    pkg = tmp_path / 'circles_probe'
    for name, text in files.items():
        path = pkg / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    monkeypatch.syspath_prepend(str(tmp_path))
    return grimp.build_graph('circles_probe', cache_dir=None)


def test_the_circle_check_sees_imports_inside_functions_and_type_checking(tmp_path, monkeypatch):
    """The check above would miss a circle closed by an import inside a function or under
    TYPE_CHECKING if grimp ignored those: build a tiny package that has only such circles."""
    graph = _probe(
        tmp_path,
        monkeypatch,
        {
            '__init__.py': '',
            'a.py': 'from . import b\n',
            'b.py': 'def f():\n    from . import a\n    return a\n',
            'c.py': (
                'from typing import TYPE_CHECKING\nfrom . import d\nif TYPE_CHECKING:\n    pass\n'
            ),
            'd.py': 'from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from . import c\n',
        },
    )
    found = circles(import_edges(graph))
    assert ['circles_probe.a', 'circles_probe.b'] in found
    assert ['circles_probe.c', 'circles_probe.d'] in found


def test_the_circle_check_sees_a_circle_through_a_package_init(tmp_path, monkeypatch):
    """``p.tables`` imports only ``q.types``, but that runs ``q/__init__``, which imports
    ``q.build``, which imports ``p.tables``: a circle no direct import closes (core.model's
    builder and core.newton had one). A sibling import inside one package is none."""
    graph = _probe(
        tmp_path,
        monkeypatch,
        {
            '__init__.py': '',
            'p/__init__.py': '',
            'p/tables.py': 'from ..q.types import T\n',
            'q/__init__.py': 'from .build import build\n',
            'q/types.py': 'T = int\n',
            'q/build.py': 'from .types import T\n\ndef build():\n    from ..p import tables\n',
        },
    )
    found = circles(import_edges(graph))
    assert found == [['circles_probe.p.tables', 'circles_probe.q', 'circles_probe.q.build']]
