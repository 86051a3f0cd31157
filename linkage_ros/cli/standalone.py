"""A subcommand module run on its own (``python -m linkage_ros.bag ...``): its own parser and
run(args). Apart from the ``linkage`` parser (cli.parser), which loads the subcommand modules:
they import this, never the parser back (no import circle)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence

from .arguments import signs_as_values
from .common import OneLineErrorParser
from .process import run_command


def standalone_main(
    prog: str,
    add_arguments: Callable[[argparse.ArgumentParser], object],
    run: Callable[[argparse.Namespace], int],
    argv: Sequence[str] | None = None,
) -> int:
    """Run one subcommand module on its own (``python -m linkage_ros.bag ...``): its parser,
    then run(args); argparse's usage errors become exit status 2 instead of SystemExit."""
    parser = OneLineErrorParser(prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(parser)
    try:
        args = parser.parse_args(signs_as_values(list(sys.argv[1:] if argv is None else argv)))
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 2
    return run_command(prog, run, args)  # (as `linkage X` ends: its errors, its stdout)
