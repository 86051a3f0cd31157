"""The checks of ``linkage bag``'s options that need no bag, and the options as plain data:
shared by one bag's run (command.py) and a fleet's (fleet_run.py)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..cli.common import load_scene_file, print_notes
from ..core.tolerances import NEWTON_TOL_MAX
from .common import DEFAULT_OUT_FORMAT, BagError, output_topics, parse_remaps
from .plans import path_point
from .replay import ReplayEngine


def check_options(args: argparse.Namespace) -> Any:
    """The scene, loaded, after every check of the options that needs no bag (notes on
    stderr); BagError / LinkageError / UsageError otherwise."""
    # as every command loads it: a packaged scene's name, a file, a description (an unknown
    # name said as solve says it, listing the packaged scenes)
    scene = load_scene_file(args.scene, args.dimension, args.closures, args.actuated)
    print_notes(scene.notes)
    given = (
        ('--command-topic', args.command_topic),
        ('--target-topic', args.target_topic),
        ('--target-any-mode-topic', args.target_any_mode_topic),
    )
    for opt, topic in given:
        if topic is not None and not topic.strip():
            raise BagError(
                f'{opt}: empty topic name (leave the option out for no such topic)'
                if opt != '--command-topic'
                else f'{opt}: empty topic name'
            )
    for (opt_a, a), (opt_b, b) in ((given[0], given[2]), (given[1], given[2])):
        if a is not None and a == b:
            raise BagError(f'{opt_a} and {opt_b} must be different topics')
    frame = args.frame_id
    if any(c.isspace() for c in frame) or frame.startswith('/'):
        raise BagError(
            f"--frame-id {frame!r}: a tf2 frame name, without whitespace or a leading '/' (as "
            "the node's frame_id parameter)"
        )
    if args.command_topic == args.target_topic:
        raise BagError('--command-topic and --target-topic must be different topics')
    if args.publish_inputs and not args.state_completion:
        raise BagError(
            '--publish-inputs goes with --state-completion (without it joint_states carry '
            'every joint already)'
        )
    if not (isinstance(args.tol, float) and math.isfinite(args.tol) and args.tol > 0):
        raise BagError(f'--tol must be a positive number (got {args.tol!r})')
    if args.tol > NEWTON_TOL_MAX:  # (the solver's own bound: core.tolerances)
        raise BagError(f'--tol must be at most {NEWTON_TOL_MAX:g} (got {args.tol!r})')
    if args.max_iter < 1:
        raise BagError(f'--max-iter must be >= 1 (got {args.max_iter})')
    for topic in args.path_topic:
        if path_point(topic) not in scene.mechanism.points:
            raise BagError(
                f'--path-topic {topic}: its last name {path_point(topic)!r} is not a point '
                f'of {scene.mechanism.name!r} (a path topic is .../target_path/<point>)'
            )
    parse_remaps(args.remap, output_topics(list(scene.mechanism.outputs), True))
    # PlanError / ConfigError (a bad --solver, --branch) before any bag is read
    ReplayEngine(
        scene.mechanism, args.solver, args.tol, args.max_iter, args.branch, args.target_point_hold
    )
    return scene


def bag_options(args: argparse.Namespace, formats: Sequence[str] = (), out_dir: str = '') -> Any:
    """The options every bag is solved with, as plain data (fleet_task.BagOptions)."""
    from .fleet_task import BagOptions

    # a scene file goes to the workers by its absolute path; a packaged scene by its name,
    # which each worker finds in its own installation (FLEET.md)
    given = Path(args.scene)
    return BagOptions(
        scene=str(given.resolve()) if given.exists() else args.scene,
        dimensions=tuple(args.dimension),
        closures=str(Path(args.closures).resolve()) if args.closures else None,
        actuated=tuple(args.actuated),
        command_topic=args.command_topic,
        target_topic=args.target_topic,
        any_mode_topic=args.target_any_mode_topic,
        trajectory_topics=tuple(args.trajectory_topic),
        path_topics=tuple(args.path_topic),
        hold=tuple(args.target_point_hold),
        solver=args.solver,
        branch=args.branch,
        tol=args.tol,
        max_iter=args.max_iter,
        accept_missing=args.accept_missing,
        state_completion=args.state_completion,
        publish_inputs=args.publish_inputs,
        formats=tuple(formats),
        out_format=args.out_format or DEFAULT_OUT_FORMAT,
        out_dir=out_dir,
        remap=tuple((old, new) for old, _, new in (a.partition(':=') for a in args.remap)),
        frame_id=args.frame_id,
    )
