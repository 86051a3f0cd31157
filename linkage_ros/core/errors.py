"""Small exception hierarchy. Messages name the file, the key and the offending value."""

from __future__ import annotations

#: The most characters of a value any message quotes (scene errors, request refusals, bag
#: errors): a message never grows with the input it echoes.
ECHO_CHARS = 80


def echo(value: object, limit: int = ECHO_CHARS) -> str:
    """``repr(value)`` for a message, cut to ``limit`` characters with '...' at the end."""
    if isinstance(value, str | bytes) and len(value) > 4 * limit:
        value = value[: 4 * limit]  # repr of a 1 MB string only to cut it: cut first
        text = repr(value)[:-1]  # the closing quote goes: the value does not end there
    else:
        text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + '...'


def not_finite(name: str, value: object) -> str:
    """The refusal of a commanded value that is NaN or infinite: a single solve's, and a batch
    row's (its first such value)."""
    return f'{name}: value must be finite (got {echo(value)})'


class LinkageError(Exception):
    """Base class of every error raised by linkage_ros."""


class SceneError(LinkageError):
    """A scene file (or scene dictionary) is malformed or describes an impossible mechanism."""

    def __init__(
        self,
        message: str,
        *,
        file: str | None = None,
        key: str | None = None,
        value: object = None,
        has_value: bool = False,
    ):
        self.file, self.key, self.value = file, key, value
        # kept apart so a compiled key can be told as the file's (a slot's slider: slots.NAME)
        self.message, self.has_value = message, has_value
        parts = []
        if file:
            parts.append(str(file))
        if key:
            parts.append(key)
        head = ': '.join(parts)
        text = f'{head}: {message}' if head else message
        if has_value or value is not None:
            text += f' (got {echo(value)})'
        super().__init__(text)


class PlanError(LinkageError):
    """The requested set of known quantities cannot be solved the way that was asked."""


class CommandError(LinkageError):
    """A command (names and values to solve for) is malformed: unknown names, NaN, wrong lengths."""
