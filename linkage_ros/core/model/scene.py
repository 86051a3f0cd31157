"""Scene files: bounded YAML reading and the Scene that holds a Mechanism."""

from __future__ import annotations

import codecs
import dataclasses
import os
import re
import stat
from collections.abc import Hashable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import yaml

from ..errors import SceneError, echo
from ..mechanism import Mechanism
from .checks import TOP_KEYS, SceneContext
from .general import build_mechanism
from .joint_map_io import joint_map_from_dict


@dataclass
class Scene:
    """A scene file: one mechanism plus the frame it is published in and the default solver."""

    mechanism: Mechanism
    path: str | None = None
    #: what loading did that a user should hear (a robot description assembled, its mimics
    #: superseded): the node logs it at start-up, the CLI's check prints it
    notes: tuple[str, ...] = ()
    #: what loads but is likely wrong (a bare angle beyond a full turn: degrees read as
    #: radians): the node logs it as a warning at start-up, the CLI prints it on stderr
    warnings: tuple[str, ...] = ()

    @property
    def frame_id(self) -> str:
        return self.mechanism.frame_id

    @classmethod
    def from_yaml(cls, path: str | Path, dimensions: Mapping[str, float] | None = None) -> Scene:
        """Load a scene file; ``dimensions`` (e.g. ``{'crank.O2-A': 0.016}``, m) override the
        file's stated dimensions by name and are used exactly (see docs/SCENES.md)."""
        path = str(path)
        text = read_text(path)
        try:
            data = yaml.load(text, Loader=UniqueKeyLoader)
        except _RefusedScalarOrDepth as exc:
            raise SceneError(str(exc), file=path, key=exc.key) from None
        except yaml.YAMLError as exc:
            mark = getattr(exc, 'problem_mark', None)
            where = f' at line {mark.line + 1}, column {mark.column + 1}' if mark else ''
            key = getattr(exc, 'key', None)
            raise SceneError(
                f'invalid YAML{where}: {getattr(exc, "problem", exc)}', file=path, key=key
            ) from None
        warnings: list[str] = []
        return cls(_build(data, path, dimensions, warnings), path, warnings=tuple(warnings))

    @classmethod
    def from_dict(
        cls,
        data: Mapping[str, Any],
        source: str = '<scene>',
        dimensions: Mapping[str, float] | None = None,
    ) -> Scene:
        warnings: list[str] = []
        return cls(_build(data, source, dimensions, warnings), None, warnings=tuple(warnings))


#: the keys of a scene file: the mechanism's (build_mechanism reads them) and joint_coordinates
SCENE_KEYS = TOP_KEYS | {'joint_coordinates'}


def _build(
    data: Any, source: str, dimensions: Mapping[str, float] | None, warnings: list[str]
) -> Mechanism:
    """build_mechanism, then the ``joint_coordinates`` key (a robot description's own joint
    names and values, as ``linkage import`` writes them) applied to the mechanism built."""
    if isinstance(data, Mapping):  # a misspelt key is told every key a scene file may have
        SceneContext(source).only('', data, SCENE_KEYS)
    if not isinstance(data, Mapping) or 'joint_coordinates' not in data:
        return build_mechanism(data, source, dimensions, warnings)
    rest = {k: v for k, v in data.items() if k != 'joint_coordinates'}
    mech = build_mechanism(rest, source, dimensions, warnings)

    def fail(key: str, message: str, value: Any = None, has_value: bool = True) -> NoReturn:
        raise SceneError(message, file=source, key=key, value=value, has_value=has_value)

    jmap = joint_map_from_dict(
        data['joint_coordinates'], mech.joint_names, [*mech.actuators, *mech.joint_names], fail
    )
    return dataclasses.replace(mech, joint_coordinates=jmap)


#: The largest scene file read (bytes): the largest shipped scene is a few kB; a file this big
#: parses in well under a second, and anything larger is refused before it is parsed.
MAX_SCENE_BYTES = 1 << 20
#: The deepest nesting of mappings and lists a scene may use (the shipped ones use 4).
MAX_SCENE_DEPTH = 32
#: The most characters a number may have (a 10^5-digit integer takes seconds to convert).
MAX_NUMBER_CHARS = 100

_KINDS = (
    (stat.S_ISDIR, 'a directory'),
    (stat.S_ISFIFO, 'a FIFO (named pipe)'),
    (stat.S_ISCHR, 'a character device'),
    (stat.S_ISBLK, 'a block device'),
    (stat.S_ISSOCK, 'a socket'),
)


def read_text(path: str, limit: int | None = None, kind: str = 'scene file') -> str:
    """A scene file's text, bounded: a regular file only (opened without blocking, so a FIFO or
    a device is refused at once), at most ``limit`` bytes (MAX_SCENE_BYTES), UTF-8. Robot
    descriptions and their side files are read with it too (``kind`` names the file in the
    refusals: 'robot description', 'closure file')."""
    limit = MAX_SCENE_BYTES if limit is None else limit
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, 'O_NONBLOCK', 0) | getattr(os, 'O_NOCTTY', 0))
    except FileNotFoundError:
        raise SceneError(f'{kind} not found', file=path) from None
    except OSError as exc:
        raise SceneError(f'cannot read {kind}: {exc.strerror or exc}', file=path) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            what = next((what for test, what in _KINDS if test(mode)), 'not a regular file')
            raise SceneError(f'is {what}, not a {kind} (a regular file)', file=path)
        chunks, size = [], 0
        while size <= limit:
            chunk = os.read(fd, limit + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        raise SceneError(f'cannot read {kind}: {exc.strerror or exc}', file=path) from None
    finally:
        os.close(fd)
    if size > limit:
        what = (
            'a scene file (the shipped scenes are a few kB)'
            if limit == MAX_SCENE_BYTES
            else ('this file')
        )
        raise SceneError(f'larger than {limit} bytes, the limit for {what}', file=path)
    raw = b''.join(chunks)
    try:
        return raw.decode(_xml_encoding(raw))
    except UnicodeDecodeError as exc:
        line = raw.count(b'\n', 0, exc.start) + 1
        bad = raw[exc.start : exc.start + 1]
        raise SceneError(
            f'not UTF-8 text (byte {bad!r} on line {line} cannot be decoded); save it as UTF-8',
            file=path,
        ) from None


#: an XML declaration's encoding (a legal XML file in ISO-8859-1, as older CAD exporters write
#: descriptions, was refused as not UTF-8: an integrator)
_XML_ENCODING = re.compile(
    rb'\A(?:\xef\xbb\xbf)?<\?xml[^>]*?encoding\s*=\s*["\']([A-Za-z0-9._-]+)["\']'
)


def _xml_encoding(raw: bytes) -> str:
    """The codec of a file's text: its XML declaration's encoding where it names one Python
    knows that reads ASCII as ASCII (the declaration itself must read back), else UTF-8."""
    m = _XML_ENCODING.match(raw)
    if m is None:
        return 'utf-8'
    name = m.group(1).decode('ascii')
    try:
        ok = codecs.lookup(name).decode(b'<?xml')[0] == '<?xml'
    except (LookupError, UnicodeDecodeError):
        ok = False
    return name if ok else 'utf-8'


class _RefusedScalarOrDepth(yaml.YAMLError):
    """A scene beyond a structural bound (nesting deeper than MAX_SCENE_DEPTH, raised before
    the composer recurses; a number longer than MAX_NUMBER_CHARS) or a number written in a
    YAML 1.1 form that reads as another value, with the key it is under."""

    def __init__(self, message: str, key: str):
        super().__init__(message)
        self.key = key


def _key_label(index: object) -> str | None:
    """The key a composed node sits under: a mapping key's text, or [i] in a list."""
    if isinstance(index, yaml.ScalarNode):
        return str(index.value)
    if isinstance(index, int):
        return f'[{index}]'
    return None


_INT_TAG = 'tag:yaml.org,2002:int'
_FLOAT_TAG = 'tag:yaml.org,2002:float'
#: An int with a leading 0 and more after it: octal (010 = 8), hex (0x1), binary (0b1).
_PREFIXED_INT = re.compile(r'[-+]?0[0-9a-zA-Z]')
#: Leading zeros and octal digits only: octal that reads as the digits show where it is 0..7
#: (00, 007), and as another value from 010 on.
_OCTAL_DIGITS = re.compile(r'[-+]?0[0-7]+')


def is_yaml11_number_form(tag: str, text: str) -> bool:
    """Whether a number's text is one of YAML 1.1's forms that read as another value than the
    digits show (0_05 = 5, 010 = 8, 0x1 = 1, 1:30 = 90); plain ints, floats, exponents and
    .inf/.nan are not. Only the characters of a number are looked at: it stays cheap."""
    if tag == _INT_TAG:
        if '_' in text or ':' in text:
            return True
        if _OCTAL_DIGITS.fullmatch(text):  # (00, 007 read as they show; 010 is 8)
            return int(text, 8) != int(text, 10)
        return _PREFIXED_INT.match(text) is not None
    if tag == _FLOAT_TAG:
        return '_' in text or ':' in text
    return False


class UniqueKeyLoader(yaml.SafeLoader):
    """safe_load that refuses a key given twice in one mapping (YAML's last-one-wins would build
    a different mechanism than the file shows), reads 1e-3 as a number (YAML 1.2), not as the
    string YAML 1.1 makes of an exponent without a dot, and refuses YAML 1.1's number forms
    that read as another value than the digits show (0_05, 010, 0x1, 1:30)."""

    def __init__(self, stream: Any):
        super().__init__(stream)
        self._path: list[str] = []
        self._depth = 0

    def _where(self) -> str:
        key = ''
        for part in self._path:
            key += part if part.startswith('[') or not key else f'.{part}'
        return key

    def compose_node(self, parent: Any, index: Any) -> Any:
        """Compose with the key path known: refuse an alias (its expansion is unbounded: a
        billion-laughs file of a few hundred bytes), nesting deeper than MAX_SCENE_DEPTH (the
        composer recurses) and a number longer than MAX_NUMBER_CHARS, naming the key."""
        label = _key_label(index)
        if label is not None:
            self._path.append(label)
        self._depth += 1
        try:
            if self.check_event(yaml.AliasEvent):
                # types-PyYAML leaves Parser.peek_event unannotated (here: the AliasEvent
                # check_event saw); the same below
                event = self.peek_event()  # type: ignore[no-untyped-call]
                err = yaml.composer.ComposerError(
                    None,
                    None,
                    f'aliases (*{event.anchor}) are not allowed in a scene file; '
                    'write the value out',
                    event.start_mark,
                )
                err.key = self._where() or None  # type: ignore[attr-defined]
                raise err
            if self._depth > MAX_SCENE_DEPTH + 1:  # + 1: the document's top node
                raise _RefusedScalarOrDepth(
                    f'nested deeper than {MAX_SCENE_DEPTH} levels (line '
                    f'{self.peek_event().start_mark.line + 1})',  # type: ignore[no-untyped-call]
                    self._where(),
                )
            node = super().compose_node(parent, index)
            if (
                isinstance(node, yaml.ScalarNode)
                and len(node.value) > MAX_NUMBER_CHARS
                and node.tag.endswith((':int', ':float'))
            ):
                raise _RefusedScalarOrDepth(
                    f'a number of {len(node.value)} characters is out of range '
                    f'(at most {MAX_NUMBER_CHARS}; line {node.start_mark.line + 1})',
                    self._where(),
                )
            if isinstance(node, yaml.ScalarNode) and is_yaml11_number_form(node.tag, node.value):
                raise _RefusedScalarOrDepth(self._yaml11_refusal(node), self._where())
            return node
        finally:
            self._depth -= 1
            if label is not None:
                self._path.pop()

    def _yaml11_refusal(self, node: yaml.ScalarNode) -> str:
        reads_as = self.yaml_constructors[node.tag](self, node)
        return (
            f'{echo(node.value)} is a YAML 1.1 number form (underscores, octal, hex, binary, '
            f'base 60) that reads as {reads_as!r}: write the number plainly '
            f'(line {node.start_mark.line + 1})'
        )

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Hashable, Any]:
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
                    f'a mapping key must be a name or number, not {echo(key)}',
                    key_node.start_mark,
                ) from None
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f'duplicate key {echo(key)} (first at line {seen[key] + 1})',
                    key_node.start_mark,
                )
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


# YAML 1.1 floats need a dot and a signed exponent (1.0e+3); also take 1e-3, 1E5, 2.5e3, .5e3.
UniqueKeyLoader.add_implicit_resolver(
    _FLOAT_TAG,
    re.compile(r'^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$'),
    list('-+0123456789.'),
)
