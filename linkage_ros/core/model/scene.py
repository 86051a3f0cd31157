"""Scene files: bounded YAML reading and the Scene that holds a Mechanism."""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ..errors import SceneError
from .general import build_mechanism
from .mechanism import Mechanism


@dataclass
class Scene:
    """A scene file: one mechanism plus the frame it is published in and the default solver."""

    mechanism: Mechanism
    path: str | None = None

    @property
    def frame_id(self) -> str:
        return self.mechanism.frame_id

    @classmethod
    def from_yaml(cls, path: str | Path) -> Scene:
        path = str(path)
        try:
            with open(path, encoding='utf-8') as fh:
                data = yaml.load(fh, Loader=_UniqueKeyLoader)
        except FileNotFoundError:
            raise SceneError('scene file not found', file=path) from None
        except UnicodeDecodeError:
            raise SceneError(
                f'not UTF-8 text ({_first_bad_utf8(path)}); save it as UTF-8', file=path
            ) from None
        except OSError as exc:
            raise SceneError(f'cannot read scene file: {exc.strerror}', file=path) from None
        except yaml.YAMLError as exc:
            mark = getattr(exc, 'problem_mark', None)
            where = f' at line {mark.line + 1}, column {mark.column + 1}' if mark else ''
            raise SceneError(
                f'invalid YAML{where}: {getattr(exc, "problem", exc)}', file=path
            ) from None
        return cls(mechanism=build_mechanism(data, source=path), path=path)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = '<scene>') -> Scene:
        return cls(mechanism=build_mechanism(data, source=source), path=None)


def _first_bad_utf8(path: str) -> str:
    """Where a file stops being UTF-8: the reader's error counts from the start of its buffer,
    not of the file."""
    try:
        raw = Path(path).read_bytes()
        raw.decode('utf-8')
    except UnicodeDecodeError as exc:
        line = raw.count(b'\n', 0, exc.start) + 1
        return f'byte {raw[exc.start : exc.start + 1]!r} on line {line} cannot be decoded'
    except OSError:
        pass
    return 'it cannot be decoded'


class _UniqueKeyLoader(yaml.SafeLoader):
    """safe_load that refuses a key given twice in one mapping (YAML's last-one-wins would build
    a different mechanism than the file shows) and reads 1e-3 as a number (YAML 1.2), not as the
    string YAML 1.1 makes of an exponent without a dot."""

    def construct_mapping(self, node, deep=False):
        seen: dict[Any, Any] = {}
        for key_node, _ in node.value:
            # deep: a list key is filled in only later otherwise, and the message shows it
            key = self.construct_object(key_node, deep=True)
            try:
                hash(key)
            except TypeError:  # `? [a, b]` or `? {a: 1}`: a list or mapping as a key
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f'a mapping key must be a name or number, not {key!r}',
                    key_node.start_mark,
                ) from None
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f'duplicate key {key!r} (first at line {seen[key] + 1})',
                    key_node.start_mark,
                )
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


# YAML 1.1 floats need a dot and a signed exponent (1.0e+3); also take 1e-3, 1E5, 2.5e3, .5e3.
_UniqueKeyLoader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$'),
    list('-+0123456789.'),
)
