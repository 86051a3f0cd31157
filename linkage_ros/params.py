"""The node's parameters: declared once (name, default, description, constraints), validated
and frozen into a NodeConfig; ROS-free, so the checks are testable without a graph."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

from .core.errors import PlanError
from .core.loading import load_scene
from .core.model import Scene
from .core.model.dimensions import overrides, parse_assignment
from .core.solver import METHODS
from .core.steps import read_branch
from .core.tolerances import NEWTON_TOL, NEWTON_TOL_MAX
from .core.urdf import PREFIX_RULE, prefix_error
from .engine import Engine, EngineSettings
from .resources import scene_path
from .setting_checks import ConfigError, fail_setting

NODE_NAME = 'linkage_node'
#: the executors the node can run on (parameter ``executor``)
EXECUTORS = ('events', 'single_threaded')
#: demo_rate bounds (Hz): the timer period must be a positive whole number of nanoseconds that
#: rclpy accepts, and a faster demo would only busy-loop the executor (1e300 Hz is a 0 ns timer)
DEMO_RATE_MIN, DEMO_RATE_MAX = 1e-3, 1000.0
#: publish_rate / marker_rate bounds (Hz) when not 0 (off)
OUTPUT_RATE_MIN, OUTPUT_RATE_MAX = 1e-3, 1000.0
#: the largest QoS history depth rclpy accepts (a larger one fails inside rclpy's QoS profile)
QUEUE_DEPTH_MAX = 2**31 - 1


# ---- configuration -----------------------------------------------------------------------------


class ParamType(Enum):
    """A parameter type no default value can say: rclpy reads an empty list as bytes."""

    STRING_ARRAY = 'string_array'


#: the default of a string-array parameter: an empty array of strings
STRING_ARRAY = ParamType.STRING_ARRAY


@dataclass(frozen=True)
class ParamSpec:
    name: str
    default: Any  # a value, or STRING_ARRAY: an empty array of strings
    description: str
    read_only: bool = True
    constraints: str = ''


PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec(
        'scene',
        'four_bar',
        'Scene file: a path to a YAML scene, or the name of a packaged scene '
        '(four_bar, slider_crank, ...; see docs/SCENES.md), or a robot description '
        '(.urdf, .sdf, .xml) whose closed chain the node solves in its own joint names.',
    ),
    ParamSpec(
        'closures',
        '',
        'A closure side file for a robot description (a linkage_ros closure file or '
        "Gepetto's YAML): the loops, cut joints and actuated joints the description does not "
        "state. '' = none.",
    ),
    ParamSpec(
        'actuated',
        STRING_ARRAY,
        "The robot description's actuated joints, where neither it nor `closures` marks them. "
        "[] (or ['']) = the description's own.",
    ),
    ParamSpec(
        'robot_description',
        '',
        "A robot description's URDF or SDF text (what robot_state_publisher's "
        "robot_description holds): when not '', the mechanism's source instead of `scene`.",
    ),
    ParamSpec(
        'robot_description_topic',
        '',
        "A std_msgs/String topic (e.g. '/robot_description') the robot description is read "
        'from (reliable, transient local, keep last 1, as robot_state_publisher publishes it) '
        'instead of `scene`: requests are refused until one arrives, a later one replaces the '
        "mechanism (a description that does not load is refused). '' = off.",
        constraints="'' | a topic name",
    ),
    ParamSpec(
        'dimensions',
        STRING_ARRAY,
        "Dimensions used exactly instead of the scene's drawing, as NAME=VALUE (m): "
        'LINK.P-Q (the distance between two points of a link) or SLIDER.offset, e.g. '
        "['crank.O2-A=0.016']; they override the scene's own `dimensions` (docs/SCENES.md).",
    ),
    ParamSpec(
        'solver',
        '',
        "Solve method: auto, closed_form or newton; '' = the scene's `solver` key.",
        constraints="'' | auto | closed_form | newton",
    ),
    ParamSpec(
        'tolerance',
        NEWTON_TOL,
        'Newton tolerance on the loop-closure residual, as a fraction '
        'of the mechanism length scale.',
        constraints='> 0 and <= 1e-3',
    ),
    ParamSpec('max_iterations', 50, 'Newton iteration cap per solve.', constraints='> 0'),
    ParamSpec(
        'branch',
        'continuous',
        "Assembly mode: 'continuous' (start in the reference pose's mode, then stay nearest "
        "the previous configuration), 'reference' (always the reference pose's signs) or "
        "explicit signs such as '+-' (one per branching dyad of the forward plan); for a scene "
        "Newton places, 'J+' or 'J-' (the sign of its loop Jacobian's determinant).",
        constraints='continuous | reference | [+-]+ | J+ | J-',
    ),
    ParamSpec(
        'frame_id',
        '',
        "frame_id stamped on every output; '' = the scene's frame_id.",
        constraints="a tf2 frame name: no whitespace, no leading '/'",
    ),
    ParamSpec(
        'prefix',
        '',
        'Prepended to every joint name in joint_states (as robot_state_publisher prepends '
        "frame_prefix to frames), so two mechanisms share one /joint_states: 'left_' gives "
        'left_O2, left_A, ... Give `linkage urdf --prefix` the same. Requests keep naming the '
        "scene's own names.",
        constraints="ASCII letters, digits and _ . - / only, no '--', no leading '/'",
    ),
    ParamSpec(
        'demo_sweep',
        False,
        'Sweep the first actuator on a timer (through the command '
        'path) so joint states flow without any command.',
        read_only=False,
    ),
    ParamSpec(
        'demo_rate',
        20.0,
        'Demo sweep rate (Hz).',
        read_only=False,
        constraints=f'{DEMO_RATE_MIN:g} <= demo_rate <= {DEMO_RATE_MAX:g}',
    ),
    ParamSpec(
        'target_point_hold',
        STRING_ARRAY,
        'Names (actuators, joints, links or points) held at their current value when a '
        '~/target_point/<point> request arrives on a mechanism with more than 2 degrees of '
        "freedom, e.g. ['bucket'] for an excavator (point + held values = DOF).",
    ),
    ParamSpec(
        'publish_rate',
        10.0,
        'Republish the last good state on joint_states at this rate (Hz), stamped now, like '
        'joint_state_publisher: from start-up (the reference pose) and between answers, so a '
        'late subscriber (robot_state_publisher, RViz) sees the mechanism. 0 = answers only.',
        constraints=f'0 or {OUTPUT_RATE_MIN:g} <= publish_rate <= {OUTPUT_RATE_MAX:g}',
    ),
    ParamSpec(
        'marker_rate',
        10.0,
        'Most ~/markers messages per second (Hz): markers are for displays, published from a '
        'timer (the latest state, transient-local so a late RViz gets it), never from the '
        'command path. 0 = no markers.',
        constraints=f'0 or {OUTPUT_RATE_MIN:g} <= marker_rate <= {OUTPUT_RATE_MAX:g}',
    ),
    ParamSpec(
        'executor',
        'events',
        "The rclpy executor that runs the node: 'events' (rclpy.experimental.EventsExecutor: "
        "about a third less CPU per command than 'single_threaded', see docs/BENCHMARKS.md; "
        "falls back to 'single_threaded' with a warning where rclpy lacks it) or "
        "'single_threaded' (rclpy's SingleThreadedExecutor).",
        constraints='events | single_threaded',
    ),
    ParamSpec(
        'queue_depth',
        10,
        'History depth N of every topic the node subscribes, and of ~/solved_trajectory '
        '(reliable, keep last N, volatile; joint_states, ~/points/<p> and ~/status: '
        'output_depth). A stall of the node longer than N / command rate drops '
        'commands: raise it for command streams of several hundred Hz and more.',
        constraints=f'integer, 1 <= queue_depth <= {QUEUE_DEPTH_MAX}',
    ),
    ParamSpec(
        'output_depth',
        100,
        'History depth of joint_states, ~/points/<p> and ~/status (reliable, keep last N): '
        'a subscriber held up for less than N / command rate (100 ms at 1 kHz) still gets '
        'every answer; a writer keeps only the last N for a reader that has not taken them.',
        constraints=f'integer, 1 <= output_depth <= {QUEUE_DEPTH_MAX}',
    ),
    ParamSpec(
        'joint_states_in',
        '',
        "State completion: a sensor_msgs/JointState topic (e.g. '/joint_states' of "
        "joint_state_broadcaster) whose values of the mechanism's inputs (actuated joints, or "
        'actuators) command the node; joint_states then leaves those joints out (the hardware '
        "publishes them) and carries the passive ones. '' = off.",
        constraints="'' | a topic name",
    ),
    ParamSpec(
        'publish_inputs',
        False,
        'State completion: joint_states carries the inputs taken from joint_states_in too '
        '(every joint of the chain), for a robot_state_publisher that reads the node alone '
        '(a description whose chain is faked by <mimic>: the hardware stream goes to the '
        'node only). joint_states_in must then be another topic than joint_states.',
    ),
)


@dataclass(frozen=True)
class NodeConfig:
    """Validated node parameters (frozen; demo_sweep / demo_rate are replaced, not mutated)."""

    scene: str = 'four_bar'
    scene_path: str = ''
    dimensions: tuple[tuple[str, float], ...] = ()
    solver: str | None = None
    tolerance: float = NEWTON_TOL
    max_iterations: int = 50
    branch: str = 'continuous'
    frame_id: str = ''
    prefix: str = ''
    demo_sweep: bool = False
    demo_rate: float = 20.0
    target_point_hold: tuple[str, ...] = ()
    publish_rate: float = 10.0
    marker_rate: float = 10.0
    executor: str = 'events'
    queue_depth: int = 10
    output_depth: int = 100
    closures: str = ''
    actuated: tuple[str, ...] = ()
    robot_description: str = ''
    robot_description_topic: str = ''
    joint_states_in: str = ''
    publish_inputs: bool = False

    @property
    def source(self) -> str:
        """Where the mechanism comes from, in words (logs, /diagnostics' scene_file)."""
        if self.robot_description_topic:
            return f'robot_description_topic {self.robot_description_topic}'
        if self.robot_description:
            return 'the robot_description parameter'
        return self.scene_path

    def engine_settings(self) -> EngineSettings:
        return EngineSettings(
            self.solver,
            self.tolerance,
            self.max_iterations,
            self.branch,
            self.target_point_hold,
            compile_rate=TARGET_COMPILE_RATE,
        )


#: new sets of target names the node compiles a solver for per second, at most (~3 ms each on
#: the excavator): a flood of ever new sets cannot starve ~/command
TARGET_COMPILE_RATE = 20.0


def check_demo_rate(value: Any) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not DEMO_RATE_MIN <= value <= DEMO_RATE_MAX
    ):  # also refuses nan
        fail_setting(
            'demo_rate',
            f'must be a number of Hz from {DEMO_RATE_MIN:g} to {DEMO_RATE_MAX:g}',
            value,
        )
    return float(value)


def check_output_rate(name: str, value: Any) -> float:
    """publish_rate / marker_rate: 0 (off) or a number of Hz within the bounds."""
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not (value == 0 or OUTPUT_RATE_MIN <= value <= OUTPUT_RATE_MAX)
    ):  # also refuses nan
        fail_setting(
            name,
            f'must be 0 (off) or a number of Hz from {OUTPUT_RATE_MIN:g} to {OUTPUT_RATE_MAX:g}',
            value,
        )
    return float(value)


def check_depth(name: str, depth: Any) -> int:
    """A history depth: an integer from 1 to the largest rclpy takes."""
    if isinstance(depth, bool) or not isinstance(depth, int) or not 1 <= depth <= QUEUE_DEPTH_MAX:
        fail_setting(
            name,
            f'must be an integer from 1 to {QUEUE_DEPTH_MAX} (the largest '
            'history depth rclpy takes)',
            depth,
        )
    return int(depth)


def make_config(values: Mapping[str, Any]) -> NodeConfig:
    """Validate raw parameter values (defaults for missing ones) into a :class:`NodeConfig`.

    Pure: checks types and ranges and resolves the scene name to a path; it does not load the
    scene (see :class:`Engine` for the checks that need the mechanism).
    """
    v = {p.name: ([] if p.default is STRING_ARRAY else p.default) for p in PARAMETERS}
    unknown = sorted(set(values) - set(v))
    if unknown:
        raise ConfigError(f'unknown parameter(s) {unknown}; expected {sorted(v)}')
    v.update({k: x for k, x in values.items() if x is not None})
    scene = v['scene']
    if not isinstance(scene, str) or not scene.strip():
        fail_setting('scene', 'must be a scene file path or a packaged scene name', scene)
    solver = v['solver']
    if solver not in ('',) + METHODS:
        fail_setting('solver', f"must be '' (the scene's) or one of {list(METHODS)}", solver)
    tol = v['tolerance']
    if (
        isinstance(tol, bool)
        or not isinstance(tol, (int, float))
        or not math.isfinite(tol)
        or not tol > 0
    ):
        fail_setting('tolerance', 'must be a finite number > 0', tol)
    if tol > NEWTON_TOL_MAX:  # (the solver's own check, named as the parameter at start-up)
        fail_setting('tolerance', f'must be at most {NEWTON_TOL_MAX:g} (default 1e-12)', tol)
    it = v['max_iterations']
    if isinstance(it, bool) or not isinstance(it, int) or it <= 0:
        fail_setting('max_iterations', 'must be an integer > 0', it)
    branch = v['branch']
    if not isinstance(branch, str) or not branch or read_branch(branch) is None:
        fail_setting(
            'branch',
            "must be 'continuous', 'reference', a string of + and - signs, or J+ / J- (a "
            'scene Newton places)',
            branch,
        )
    frame_id = v['frame_id']
    if (
        not isinstance(frame_id, str)
        or any(c.isspace() for c in frame_id)
        or frame_id.startswith('/')
    ):
        fail_setting(
            'frame_id',
            "must be a tf2 frame name, without whitespace or a leading '/' ('' = the scene's)",
            frame_id,
        )
    prefix = v['prefix']
    if prefix_error(prefix):  # the rule of `linkage urdf --prefix`, whose frames it must name
        fail_setting('prefix', PREFIX_RULE, prefix)
    demo = v['demo_sweep']
    if not isinstance(demo, bool):
        fail_setting('demo_sweep', 'must be true or false', demo)
    rate = check_demo_rate(v['demo_rate'])
    hold = v['target_point_hold']
    if isinstance(hold, str) or not all(isinstance(h, str) and h for h in hold):
        fail_setting('target_point_hold', 'must be a list of names', hold)
    if len(set(hold)) != len(hold):
        fail_setting('target_point_hold', 'names something twice', list(hold))
    publish_rate = check_output_rate('publish_rate', v['publish_rate'])
    marker_rate = check_output_rate('marker_rate', v['marker_rate'])
    executor = v['executor']
    if executor not in EXECUTORS:
        fail_setting('executor', f'must be one of {list(EXECUTORS)}', executor)
    depth = check_depth('queue_depth', v['queue_depth'])
    output_depth = check_depth('output_depth', v['output_depth'])
    dims = v['dimensions']
    if isinstance(dims, str) or not isinstance(dims, (list, tuple)):
        fail_setting('dimensions', 'must be a list of NAME=VALUE strings', dims)
    parsed = []
    for item in dims:
        if not isinstance(item, str):
            fail_setting('dimensions', 'must be a list of NAME=VALUE strings', item)
        try:
            parsed.append(parse_assignment(item))
        except ValueError as exc:
            fail_setting('dimensions', str(exc), item)
    try:
        overrides(parsed)
    except ValueError as exc:
        fail_setting('dimensions', str(exc), list(dims))
    closures, actuated, description, description_topic = _description_settings(v)
    joint_states_in = check_topic('joint_states_in', v['joint_states_in'])
    publish_inputs = v['publish_inputs']
    if not isinstance(publish_inputs, bool):
        fail_setting('publish_inputs', 'must be true or false', publish_inputs)
    if publish_inputs and not joint_states_in:
        fail_setting(
            'publish_inputs', 'it applies to state completion: set joint_states_in too', True
        )
    path = scene_path(scene)
    if not (description or description_topic) and not path.exists():
        from .resources import config_dir

        packaged = sorted(f.stem for f in config_dir().glob('*.yaml'))
        fail_setting(
            'scene',
            f'no such scene file, and no packaged scene of that name (packaged: '
            f'{", ".join(packaged) or "none"})',
            scene,
        )
    return NodeConfig(
        scene=scene,
        scene_path=str(path),
        dimensions=tuple(parsed),
        solver=solver or None,
        tolerance=float(tol),
        max_iterations=it,
        branch=branch,
        frame_id=frame_id,
        prefix=prefix,
        demo_sweep=demo,
        demo_rate=rate,
        target_point_hold=tuple(hold),
        publish_rate=publish_rate,
        marker_rate=marker_rate,
        executor=executor,
        queue_depth=depth,
        output_depth=output_depth,
        closures=closures,
        actuated=actuated,
        robot_description=description,
        robot_description_topic=description_topic,
        joint_states_in=joint_states_in,
        publish_inputs=publish_inputs,
    )


#: a ROS topic name: tokens of letters, digits and _ (not starting with a digit) joined by '/',
#: optionally absolute ('/') or private ('~/')
_TOPIC = re.compile(r'(~/|/)?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*')


def check_topic(name: str, value: Any) -> str:
    """'' (off) or a valid ROS topic name."""
    if not isinstance(value, str) or (value and not _TOPIC.fullmatch(value)):
        fail_setting(
            name,
            "must be '' (off) or a topic name (letters, digits and _ in tokens joined by '/', "
            "none starting with a digit; '/...' absolute, '~/...' private)",
            value,
        )
    return str(value)


def _description_settings(v: Mapping[str, Any]) -> tuple[str, tuple[str, ...], str, str]:
    """closures, actuated, robot_description and robot_description_topic, checked."""
    closures = v['closures']
    if not isinstance(closures, str):
        fail_setting('closures', "must be a closure file path ('' = none)", closures)
    if closures and not Path(closures).is_file():
        fail_setting('closures', 'no such file', closures)
    actuated = v['actuated']
    if isinstance(actuated, str) or not isinstance(actuated, (list, tuple)):
        fail_setting('actuated', 'must be a list of joint names', actuated)
    if list(actuated) == ['']:  # what `-p "actuated:=['']"` gives for none
        actuated = []
    if not all(isinstance(a, str) and a for a in actuated):
        fail_setting('actuated', 'must be a list of joint names', list(actuated))
    if len(set(actuated)) != len(actuated):
        fail_setting('actuated', 'names a joint twice', list(actuated))
    description = v['robot_description']
    if not isinstance(description, str):
        fail_setting('robot_description', "must be URDF or SDF text ('' = none)", description)
    topic = check_topic('robot_description_topic', v['robot_description_topic'])
    if description.strip() and topic:
        fail_setting(
            'robot_description_topic',
            'and robot_description both give the robot description: set one of them',
            topic,
        )
    return closures, tuple(actuated), description if description.strip() else '', topic


def load_engine(config: NodeConfig, description: str | None = None) -> tuple[Scene, Engine]:
    """Load the mechanism and compile the forward solver; SceneError / ConfigError on failure.

    The mechanism comes from ``description`` (URDF or SDF text, e.g. a message of
    robot_description_topic) if given, else the robot_description parameter, else the scene
    file (a scene YAML or a description path); a description takes ``closures`` and
    ``actuated``."""
    text = description if description is not None else config.robot_description
    dimensions = dict(config.dimensions) or None
    closures, actuated = config.closures or None, config.actuated or None
    if text:
        scene = load_scene(text, dimensions, closures, actuated, text=True)
    else:
        scene = load_scene(config.scene_path, dimensions, closures, actuated)
    mech = scene.mechanism
    try:
        return scene, Engine(mech, config.engine_settings())
    except PlanError as exc:
        name = 'branch' if 'branch' in str(exc) else 'solver'
        raise ConfigError(f'parameter {name!r} does not fit scene {mech.name!r}: {exc}') from None
