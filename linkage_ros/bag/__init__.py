"""Offline analysis of recorded commands: solve every command of a rosbag2 as the node would.

    linkage bag INPUT --scene SCENE [--closures FILE] [--actuated NAME ...]
                      --command-topic TOPIC [--target-topic TOPIC]
                      [--target-any-mode-topic TOPIC]
                      --out OUTPUT [--out OUTPUT2] [--out-format mcap|sqlite3]
                      [--solver S] [--branch B] [--tol T] [--max-iter N]
                      [--plot out.png] [--no-progress]

(``--plot`` alone, without ``--out``, writes the plot only.)

INPUT is a rosbag2 folder (sqlite3 or MCAP storage) or a single ``.mcap`` / ``.db3`` file, read
with the pure-Python ``rosbags`` library (no ROS installation needed). The command topic carries
``sensor_msgs/msg/JointState`` naming the scene's actuators, exactly like the node's ``~/command``;
the optional target topic carries ``JointState`` naming joints, links or actuators, exactly like
the node's ``~/target`` (inverse kinematics), and the optional any-mode topic like the node's
``~/target_any_mode`` (a target that may change the assembly mode). The topics are merged in
bag time order and solved in that order with the node's semantics (linkage_ros.engine.Engine):
the reference pose is the first good state, continuity (default branch ``continuous``) carries
on from the last good state, a refused request changes nothing, and a target solver adopts the
last good state.

Outputs (``--out`` may be given twice):

* ``*.csv``: one row per command, refused ones included (status ``error`` and the reason).
  Columns: ``time`` (header stamp, s), ``receive_time`` (bag time, s), ``topic``,
  ``input.<actuator>`` ..., ``joint.<joint>`` ..., ``velocity.<joint>`` ..., ``<point>.x``,
  ``<point>.y`` (every point), ``residual``, ``margin``, ``branch``, ``status``, ``reason``.
  The ``velocity.<joint>`` columns (rad/s, m/s; in the published joints' names and order) are
  there only when some command gave velocities (one per name, as the node reads
  ``~/command``'s ``velocity``): each such row has every joint's velocity as the node answers
  it (core.velocity: exact, from the loop-closure Jacobian at the row's solution; a held
  actuator moves at 0), empty on the other rows and where there is none (a toggle).
* anything else: a new rosbag2 folder (MCAP unless ``--out-format sqlite3``) with the node's
  topics (``--remap FROM:=TO`` renames one): ``/joint_states`` (JointState, every joint),
  ``/linkage_node/points/<name>`` (PointStamped, per output point) and
  ``/linkage_node/status`` (DiagnosticStatus, one per command: OK with residual, branch, margin,
  solver, iterations, and ``velocity`` (``ok (cond C)`` or why there is none) for a command
  that gave velocities; ERROR with the reason). A command's joint_states then carry every
  joint's velocity, as the node's do. Header stamps are the commands' (a zero stamp
  becomes the bag receive time), frame_id is the scene's (or ``--frame-id``, the node's
  parameter of that name), and each message is logged at its
  command's bag time.

Speed: a closed-form scene is solved in vectorised chunks (``Solver.solve_batch`` with the branch
signs then current). A row is taken from the batch only when the node's continuity rule provably
picks the same assembly mode for it, at every branching dyad (bag/easy_rows.py, on the core's
statement of the rule: core.solver.continuity keeps_sign, nearer_for_every_ratio): either the
dyad is clear of its singularity now and in the previous good configuration (margin above
CONTINUITY_MARGIN, so the node keeps the sign), or the batch's solution is nearer than the other
one to the node's prediction for every extrapolation ratio it may use (0 ... MAX_STEP_RATIO:
the squared distance difference is linear in it) by a clear margin. The first row where neither
holds (a branch change near a toggle) and a stretch after it are solved one by one by a
continuous Solver whose history is made identical to the node's, then the batch resumes.
Refused rows get the reason a single solve gives (the node's exact text); the answers go into
the core's results table (core.solver.table.ResultTable: refused rows NaN), which every output
reads. Newton and hybrid solvers go one command at a time.
Velocities do not change the path: the positions are solved as above, then each command that
gave velocities gets its rates from its own solution (core.velocity, one linear solve a row,
as the node computes them); a command with a velocity that is not finite, or not one per
name, is refused before solving, as the node refuses it.
JointState messages are decoded with numpy, many at a time (messages of one layout share one
parse); both rosbags' and rclpy's (recorded bags') CDR variants are read.

Bad input (missing, not a bag, missing topic, wrong type, truncated or corrupt) is one clear
message on stderr and exit status 2.

Recorded trajectories and paths (``--trajectory-topic``, ``--path-topic``) are placed in a first
read without being decoded, then decoded one at a time when their turn comes and written to the
outputs as soon as they are answered (bag/run_outputs.py): memory holds one plan at a time.

Many bags: ``linkage bag INPUT... --out-dir DIR [--format F ...] [--jobs N | --scheduler ADDRESS]
[--resume]`` (fleet_inputs: which bags and their output names; fleet_task: one bag, its outputs
and manifest; fleet_run: local processes or Dask, the summary; parquet_out: the Parquet table).
See docs/FLEET.md.
"""

from __future__ import annotations

from . import fleet_task  # noqa: F401
from .bag_out import (  # noqa: F401
    write_bag,
)
from .command import (  # noqa: F401
    BAG_EPILOG,
    OK,
    USAGE_ERROR,
    add_arguments,
    main,
    run,
)
from .common import (  # noqa: F401
    DIAGNOSTIC_STATUS,
    JOINT_STATE,
    NODE_NAME,
    POINT_STAMPED,
    BagError,
)
from .csv_out import (  # noqa: F401
    FLOAT_WIDTH,
    csv_header,
    format_floats,
    format_ints,
    stamp_text,
    write_csv,
)
from .easy_rows import (  # noqa: F401
    EASY_MARGIN,
    easy_prefix,
)
from .plot import (  # noqa: F401
    isolated_rows,
    plot_figure,
    plot_format,
    plot_formats,
    write_plot,
)
from .progress import (  # noqa: F401
    Progress,
    summary_text,
)
from .reading import (  # noqa: F401
    STORAGE_SUFFIXES,
    Commands,
    decode_joint_states,
    exc_text,
    open_reader,
    read_commands,
)
from .replay import (  # noqa: F401
    CHUNK_MAX,
    CHUNK_MIN,
    CHUNK_START,
    MIN_BATCH,
    NEAR_TANGENT,
    SEQUENTIAL_STRETCH,
    HistoryEntry,
    ReplayEngine,
    SolverContext,
    solve_commands,
)
from .results import (  # noqa: F401
    Results,
)
from .rows import command_row, finite_rows  # noqa: F401
