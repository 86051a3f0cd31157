"""A batch row with a value that is NaN or infinite is refused as a single solve of the same
values refuses it: the same reason, naming the first such value (not a batch-only wording).

Oracle: Solver.solve of the row's own values on a fresh solver.
Would fail if: the batch's reason for such a row said anything else than the single solve's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scenes

from linkage_ros.core.solver import Solver

BAD = [math.nan, math.inf, -math.inf]


@pytest.mark.parametrize(
    'name, knowns',
    [('four_bar', None), ('excavator', None), ('plagiograph', ['point:B'])],
)
def test_a_non_finite_row_is_refused_as_a_single_solve(name, knowns):
    mech = scenes.load(name)
    ref = Solver(mech, knowns=knowns).reference_values()
    rows = []
    for k in range(len(ref)):  # each value in turn, then every value, not finite
        for bad in BAD:
            row = dict(ref)
            key = list(ref)[k]
            row[key] = (ref[key][0], bad) if isinstance(ref[key], tuple) else bad
            rows.append(row)
    rows.append(
        {k: (math.nan, math.nan) if isinstance(v, tuple) else math.inf for k, v in ref.items()}
    )
    columns = {k: np.array([row[k] for row in rows], float) for k in ref}
    got = Solver(mech, knowns=knowns).solve_batch(columns)
    for i, row in enumerate(rows):
        single = Solver(mech, knowns=knowns).solve(row)
        assert not single.success and not got.ok[i]
        assert got.reason[i] == single.reason, row
