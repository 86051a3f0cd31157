"""core.batch_inplace's batch-wide tests against their plain numpy oracles: every_finite_in
(one summing pass per column) answers what np.isfinite(a).all() answers, overflowing sums and
infinities that cancel included."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from linkage_ros.core.batch_inplace import every_finite_in

_SPECIAL = [math.nan, -math.nan, math.inf, -math.inf, 1.7e308, -1.7e308, 5e-324, -0.0, 0.0]
_VALUES = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(_SPECIAL))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.lists(_VALUES, min_size=0, max_size=40), min_size=1, max_size=4))
def test_every_finite_in_is_the_elementwise_test(columns):
    arrays = [np.array(c, float) for c in columns]
    assert every_finite_in(arrays) == all(bool(np.isfinite(a).all()) for a in arrays)


def test_every_finite_in_overflowing_and_cancelling_sums():
    """Finite values whose sum overflows are finite; inf and -inf (a NaN sum) are not; (n, 2)
    point columns alike."""
    big = np.full(1000, 1.7e308)
    assert every_finite_in([big, -big])
    assert not every_finite_in([np.array([math.inf, -math.inf, 1.0])])
    assert not every_finite_in([np.array([1.0, 2.0]), np.array([[0.0, 1.0], [math.nan, 2.0]])])
    assert every_finite_in([np.zeros(0), np.array([[1e300, -1e300], [5e-324, -0.0]])])
