"""Benchmark the solvers: speed against accuracy, throughput, scipy and node latency.

    linkage bench [--quick] [--write docs/BENCHMARKS.md] [--plot PNG] [--no-node] [--json FILE]

One module per measurement: ``tradeoff`` (speed vs accuracy of each solver setting against the
50-digit ``reference``), ``throughput`` (vectorised four-bar vs a numpy baseline, pruned outputs),
``ros_latency`` (the node vs a bare rclpy relay), ``collect`` (one run and its targets),
``report`` (the markdown, its prose and the plot: not library code) and ``command`` (the CLI).
Speed claims are ratios measured in the same run.
"""

from __future__ import annotations

from .all_outputs import PLAIN_LISTENER_LABEL  # noqa: F401
from .collect import (  # noqa: F401
    code_version,
    collect,
    evaluate_targets,
    find_setting,
    machine_info,
    rate_text,
)
from .command import (  # noqa: F401
    add_arguments,
    main,
    run,
)
from .reference import (  # noqa: F401
    MpReference,
    point_errors,
    reference_points,
)
from .report import (  # noqa: F401
    DEFAULT_INTRO,
    interpretation,
    met_text,
    render_markdown,
    save_plot,
    write_report,
)
from .report_node import (  # noqa: F401
    node_interpretation,
    node_markdown,
)
from .ros_driver import (  # noqa: F401
    Driver,
    Link,
    Proc,
    process_cpu_s,
    relay_script,
    ros_env,
)
from .ros_latency import bench_node, sustained_rate  # noqa: F401
from .settings import (  # noqa: F401
    DEFAULT_DEPTH,
    ERROR_FLOOR,
    FULL,
    MARKER,
    NEWTON_TOLS,
    NODE_CPU_BASELINE_US,
    QUICK,
    REF_DPS,
    SCENES,
    SCIPY_XTOLS,
    TARGET_LATENCY_MS,
    TARGET_NEWTON_VS_SCIPY,
    TARGET_RATE_HZ,
    Sizes,
    log,
)
from .throughput import (  # noqa: F401
    bench_outputs,
    bench_throughput,
    numpy_circle_baseline,
)
from .tradeoff import (  # noqa: F401
    DirectStepper,
    KernelStepper,
    ScipyStepper,
    SettingResult,
    SolverStepper,
    Stepper,
    batch_columns,
    bench_scene,
    load_scene,
    run_interleaved,
    sweep_inputs,
    time_batches,
)
