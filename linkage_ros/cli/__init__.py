"""The ``linkage`` command: one-shot solves, sweeps and scene checks from the shell.

    linkage solve SCENE --set NAME=VALUE ... [--target NAME=VALUE] [--target-point NAME=X,Y]
                        [--branch B] [--solver S] [--tol T] [--max-iter N] [--all-branches] [--json]
    linkage sweep SCENE --set NAME=START:STOP:COUNT ... [--set NAME=VALUE] [--target ...]
                        [--branch B] [--solver S] [--tol T] [--max-iter N] [--strict] [--json]
    linkage check SCENE [--solver S] [--json]
    linkage import DESCRIPTION [--closures FILE] [--actuated NAME ...] [-o scene.yaml]

SCENE is a scene file, the name of a packaged scene (``four_bar``) or a robot description
(``.urdf``, ``.sdf``, ``.xml``) with ``--closures FILE`` (its closure side file) and
``--actuated NAME`` (its inputs, where it does not mark them); a description's requests and
answers use its own joint names and values (linkage_ros.cli.described). Angles are radians, lengths
metres, unless a value says its unit (core.units: ``--set crank=30deg``, ``16mm``).

Exit status: 0 ok; 1 a solve was refused (the answer has status "error" and a reason; with
``--all-branches`` only when no assembly mode closes; ``sweep --strict`` when any line is an
error); 2 a usage error (bad syntax, unknown name, missing scene, SceneError, PlanError), reported
as one line on stderr; 130 interrupted by Ctrl-C (one line, no traceback).

The CLI only parses, calls the core and prints: no kinematics lives here. The parser and entry
point are cli.parser (``main``); more subcommands plug in through its
:data:`~linkage_ros.cli.parser.EXTERNAL_COMMANDS` (modules with ``add_arguments(parser)`` and
``run(args) -> int``, run on their own by cli.standalone). This package imports nothing: a
subcommand module imports its neighbours (cli.common, ...) without the parser that loads it.
"""
