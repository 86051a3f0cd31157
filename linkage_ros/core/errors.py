"""Small exception hierarchy. Messages name the file, the key and the offending value."""

from __future__ import annotations


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
        parts = []
        if file:
            parts.append(str(file))
        if key:
            parts.append(key)
        head = ': '.join(parts)
        text = f'{head}: {message}' if head else message
        if has_value or value is not None:
            text += f' (got {value!r})'
        super().__init__(text)


class PlanError(LinkageError):
    """The requested set of known quantities cannot be solved the way that was asked."""


class CommandError(LinkageError):
    """A command (names and values to solve for) is malformed: unknown names, NaN, wrong lengths."""
