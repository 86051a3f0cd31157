"""A description in the encoding its XML declaration names (ISO-8859-1, as older CAD exporters
write them, with CRLF line ends) reads as the same description in UTF-8 (it was refused as
not UTF-8: an integrator); an encoding that cannot be what it says is refused as before."""

from __future__ import annotations

import pytest
from description_consumers_helpers import FOUR_BAR

from linkage_ros.core.description import import_description
from linkage_ros.core.errors import SceneError


def _body() -> str:
    text = FOUR_BAR.read_text()
    return text[text.index('<robot') :]


def test_a_declared_latin1_description_reads_as_its_utf8_twin(tmp_path):
    head = '<?xml version="1.0" encoding="ISO-8859-1"?>\r\n<!-- \u00a9 a CAD exporter -->\r\n'
    latin = tmp_path / 'latin1.urdf'
    latin.write_bytes((head + _body().replace('\n', '\r\n')).encode('latin-1'))
    assert b'\xa9' in latin.read_bytes()  # (not UTF-8: a lone 0xa9)
    got = import_description(str(latin)).mechanism
    want = import_description(str(FOUR_BAR)).mechanism
    assert {p: tuple(v) for p, v in got.points.items()} == {
        p: tuple(v) for p, v in want.points.items()
    }


def test_undeclared_bytes_that_are_not_utf8_are_refused(tmp_path):
    bad = tmp_path / 'bad.urdf'
    bad.write_bytes(('<!-- \u00a9 -->\n' + _body()).encode('latin-1'))
    with pytest.raises(SceneError, match='not UTF-8 text'):
        import_description(str(bad))
