"""Command-line values argparse would misread: an option that takes one value given twice
(argparse keeps the last silently), and a --branch of signs alone that starts with '-' (read as
another option; '--' dropped even in --branch=--)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence


class OnceAction(argparse.Action):
    """An option taken once: given twice it is a usage error, not the last one kept silently
    (two --target-topic options read the second topic only, the first's requests dropped)."""

    def __call__(self, parser, namespace, values, option_string=None):
        seen: set[str] = getattr(namespace, '_given_once', set())
        if self.dest in seen:
            parser.error(f'{option_string} given more than once (it takes one value)')
        namespace._given_once = seen | {self.dest}
        setattr(namespace, self.dest, values)


#: marks a --branch value of signs alone on its way through argparse (signs_as_values)
_SIGNS = '='


def signs_as_values(argv: Sequence[str]) -> list[str]:
    """``argv`` with each --branch value made of signs alone ('-+', '--') passed as a value:
    argparse reads '-+' after an option as another option ("expected one argument") and drops
    a value '--' even in '--branch=--' (it ends the options), so the modes of a scene whose
    first sign is '-' could not be asked for; branch_value takes the mark off."""
    out: list[str] = []
    it = iter(argv)
    for a in it:
        if a == '--':  # (the options end: what follows is positional)
            out += [a, *it]
            break
        value = a.removeprefix('--branch=') if a.startswith('--branch=') else None
        if a == '--branch':
            value = next(it, None)
            if value is None:
                out.append(a)
                break
        if value is not None and value and set(value) <= {'+', '-'}:
            out.append(f'--branch={_SIGNS}{value}')
        elif value is not None and a == '--branch':
            out += [a, value]
        else:
            out.append(a)
    return out


def branch_value(text: str) -> str:
    """A --branch value as given (signs_as_values' mark taken off)."""
    body = text.removeprefix(_SIGNS)
    return body if text.startswith(_SIGNS) and set(body) <= {'+', '-'} else text
