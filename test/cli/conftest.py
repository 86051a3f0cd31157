"""The command-line tests' shared fixture: ``scenes``, the small scene files test_cli_*.py run
(their lengths are cli_helpers' CR, DR and CP)."""

import pytest
from cli_helpers import CP, CR, DR

FOUR_BAR = f"""\
four_bar: {{ground: {CR['l1']}, crank: {CR['l2']}, coupler: {CR['l3']}, rocker: {CR['l4']},
           coupler_point: {{distance: {CP['distance']}, angle: {CP['angle']}}}}}
"""
DOUBLE_ROCKER = f"""\
four_bar: {{ground: {DR['l1']}, crank: {DR['l2']}, coupler: {DR['l3']}, rocker: {DR['l4']},
           input: 0.8}}
"""
SLIDER_CRANK = 'slider_crank: {crank: 0.1, rod: 0.3, offset: 0.02}\n'
# 2-DOF five-bar; T is a tool point on link l2 (a point that is not a joint)
FIVE_BAR = """\
name: five_bar
points: {O2: [0, 0], O5: [0.3, 0], A: [0.0, 0.15], P: [0.15, 0.3], B: [0.3, 0.15],
         T: [0.1, 0.35]}
links: {ground: [O2, O5], l1: [O2, A], l2: [A, P, T], l3: [P, B], l4: [O5, B]}
actuators:
  a1: {type: angle, link: l1, pivot: O2, toward: A}
  a2: {type: angle, link: l4, pivot: O5, toward: B}
"""
# one actuator for a 2-DOF chain: the scene must not load
FIVE_BAR_ONE_ACTUATOR = (
    FIVE_BAR.split('actuators:')[0]
    + """actuators:
  a1: {type: angle, link: l1, pivot: O2, toward: A}
"""
)


@pytest.fixture(scope='module')
def scenes(tmp_path_factory):
    d = tmp_path_factory.mktemp('scenes')
    out = {}
    for name, text in [
        ('four_bar', FOUR_BAR),
        ('double_rocker', DOUBLE_ROCKER),
        ('slider_crank', SLIDER_CRANK),
        ('five_bar', FIVE_BAR),
        ('bad_dof', FIVE_BAR_ONE_ACTUATOR),
    ]:
        p = d / f'{name}.yaml'
        p.write_text(text)
        out[name] = str(p)
    return out
