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

The CLI only parses, calls the core and prints: no kinematics lives here. More subcommands plug in
through :data:`EXTERNAL_COMMANDS` (modules with ``add_arguments(parser)`` and
``run(args) -> int``).
"""

from __future__ import annotations

from .check import (  # noqa: F401
    check_report,
    cmd_check,
    format_check,
    input_ranges,
)
from .common import (  # noqa: F401
    INTERRUPTED,
    OK,
    REFUSED,
    USAGE_ERROR,
    UsageError,
    _angle,
    _count,
    _f,
    _grid,
    _Known,
    _Linspace,
    _linspace,
    _number,
    _Parser,
    _point,
    _unit_of,
    _value,
    add_description_arguments,
    add_scene_argument,
    build_solve,
    clean,
    dumps,
    format_result,
    load_mechanism,
    load_scene_file,
    parse_known,
    print_notes,
)
from .parser import (  # noqa: F401
    CHECK_EPILOG,
    EXTERNAL_COMMANDS,
    KNOWN_HELP,
    MAIN_EPILOG,
    SOLVE_EPILOG,
    SWEEP_EPILOG,
    _add_solve_options,
    _load_external,
    build_parser,
    main,
    standalone_main,
)
from .solve import (  # noqa: F401
    cmd_solve,
)
from .sweep import (  # noqa: F401
    _cell,
    cmd_sweep,
)
