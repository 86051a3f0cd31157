"""No import circles anywhere in the package, counting every import: module level, inside
functions and under TYPE_CHECKING (grimp reads them all from the source)."""

from __future__ import annotations

import grimp


def test_no_module_imports_itself_back():
    graph = grimp.build_graph('linkage_ros', include_external_packages=False)
    circles = []
    for module in sorted(graph.modules):
        for imported in sorted(graph.find_modules_directly_imported_by(module)):
            back = graph.find_shortest_chain(importer=imported, imported=module)
            if back is not None:
                circles.append(' -> '.join((module, *back)))
    assert not circles, 'import circles:\n' + '\n'.join(circles)


def test_the_circle_check_sees_imports_inside_functions_and_type_checking(tmp_path, monkeypatch):
    """The check above would miss a circle closed by an import inside a function or under
    TYPE_CHECKING if grimp ignored those: build a tiny package that has only such circles."""
    pkg = tmp_path / 'circles_probe'
    pkg.mkdir()
    (pkg / '__init__.py').write_text('')
    (pkg / 'a.py').write_text('from . import b\n')
    (pkg / 'b.py').write_text('def f():\n    from . import a\n    return a\n')
    (pkg / 'c.py').write_text(
        'from typing import TYPE_CHECKING\nfrom . import d\nif TYPE_CHECKING:\n    pass\n'
    )
    (pkg / 'd.py').write_text(
        'from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from . import c\n'
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    graph = grimp.build_graph('circles_probe', cache_dir=None)
    assert graph.find_shortest_chain(importer='circles_probe.b', imported='circles_probe.a')
    assert graph.find_shortest_chain(importer='circles_probe.d', imported='circles_probe.c')
