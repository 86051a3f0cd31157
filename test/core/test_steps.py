"""Branch text and the assembly modes of a dyad plan (core.steps): one rule for the text of a
mode ('+-') and one enumeration of the modes, which the solver's every-mode answer
(solver.modes) and the URDF's slide ranges (urdf) both walk."""

from __future__ import annotations

import scenes
from hypothesis import given
from hypothesis import strategies as st

from linkage_ros.core.solver import Solver
from linkage_ros.core.steps import branch_signs, branch_text, sign_combinations


@given(st.text(alphabet='+-', max_size=12))
def test_branch_text_and_signs_are_inverse(text):
    assert branch_text(branch_signs(text)) == text
    assert all(s in (1, -1) for s in branch_signs(text))


def test_sign_combinations_are_every_mode_once_all_plus_first():
    for n in range(5):
        got = list(sign_combinations(n))
        # the oracle: each mode as the bits of a counter (1 -> '-')
        every = {tuple(-1 if (k >> i) & 1 else 1 for i in range(n)) for k in range(2**n)}
        assert len(got) == 2**n and set(got) == every
        assert got[0] == (1,) * n


def test_every_mode_of_a_command_has_the_text_of_one_combination():
    """The solver's every-mode answer (solver.modes) walks sign_combinations: the quick-return's
    modes are a subset of the combinations' texts, each once, the reference mode among them."""
    mech = scenes.load('quick_return')
    solver = Solver(mech)
    assert solver.branch_count >= 1
    texts = {branch_text(s) for s in sign_combinations(solver.branch_count)}
    answers = solver.solve_all(solver.reference_values())
    got = [r.branch for r in answers if r.success]
    assert got and len(got) == len(set(got)) and set(got) <= texts
    ref = solver.solve(solver.reference_values())
    assert ref.branch in got
