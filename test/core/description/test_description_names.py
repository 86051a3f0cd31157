"""A description's names that are not scene names (letters, digits, _) are renamed, and a
rename never takes a name another of the description's links or points has as its own: a
target on that name must move what the description calls so (an integrator: `left-crank`
beside `left_crank` took the name, and `--target left_crank=1.0` turned the crank)."""

from __future__ import annotations

import math

from linkage_ros.core.description import import_description

# a URDF+ <loop> four-bar: crank 0.1 (link `left-crank`), coupler 0.35 (link `left_crank`),
# rocker 0.3, ground 0.4; the joint between crank and coupler is `p-1`, the loop's pin `p_1`
URDF = """<?xml version="1.0"?>
<robot name="fb">
  <link name="base"/><link name="left-crank"/><link name="left_crank"/><link name="rocker"/>
  <joint name="j1" type="revolute" independent="true">
    <parent link="base"/><child link="left-crank"/>
    <origin xyz="0 0 0" rpy="0 0 0.7"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="p-1" type="continuous" independent="false">
    <parent link="left-crank"/><child link="left_crank"/>
    <origin xyz="0.1 0 0" rpy="0 0 -0.4"/><axis xyz="0 0 1"/></joint>
  <joint name="j4" type="continuous" independent="false"><parent link="base"/><child link="rocker"/>
    <origin xyz="0.4 0 0" rpy="0 0 2.0"/><axis xyz="0 0 1"/></joint>
  <loop name="p_1" type="revolute">
    <predecessor link="left_crank"><origin xyz="0.35 0 0"/></predecessor>
    <successor link="rocker"><origin xyz="0.3 0 0"/></successor>
    <axis xyz="0 0 1"/>
  </loop>
</robot>
"""


def test_a_renamed_name_never_takes_another_ones_own(tmp_path):
    path = tmp_path / 'fb.urdf'
    path.write_text(URDF)
    imp = import_description(str(path))
    mech = imp.mechanism
    pts = {p: tuple(v) for p, v in mech.points.items()}
    links = {k: set(v.points) for k, v in mech.links.items()}
    # the loop's pin keeps its name: 0.3 from the rocker's pivot (j4, at (0.4, 0)) and 0.35
    # from the crank pin, which is 0.1 from the origin
    assert math.dist(pts['p_1'], pts['j4']) == _near(0.3)
    assert math.dist(pts['p_1'], (0.0, 0.0)) != _near(0.1)
    crank_pin = [p for p in pts if p.startswith('p_1_')]
    assert crank_pin == ['p_1_2']
    assert math.dist(pts['p_1_2'], (0.0, 0.0)) == _near(0.1)
    assert math.dist(pts['p_1_2'], pts['p_1']) == _near(0.35)
    # the coupler keeps `left_crank` (it holds both pins), the crank is renamed
    assert {'p_1', 'p_1_2'} <= links['left_crank']
    assert 'p_1_2' in links['left_crank_2'] and 'p_1' not in links['left_crank_2']
    note = next(n for n in imp.notes if 'these changed' in n)
    assert "link 'left-crank': left_crank_2" in note and "point of 'p-1': p_1_2" in note


class _near:
    """Equal to within 1e-12 m."""

    def __init__(self, v):
        self.v = v

    def __eq__(self, other):
        return abs(other - self.v) <= 1e-12

    def __repr__(self):
        return f'~{self.v}'
