"""`linkage range --point` requests at their edges: a point no actuator moves, an actuator
named twice (a hydraulics engineer's review)."""

from __future__ import annotations

from cli_helpers import loads, run


def test_range_of_a_ground_point_is_that_point(capsys):
    # O2 is the four-bar's ground pivot at the origin: no actuator moves it (was KeyError)
    rc, out, err = run(capsys, 'range', 'four_bar', '--point', 'O2')
    assert rc == 0, err
    assert 'region of O2 (no actuator moves it): point, area 0 m^2' in out
    assert 'x 0 .. 0 m, y 0 .. 0 m' in out
    rc, out, _ = run(capsys, 'range', 'excavator', '--point', 'O4', '--json')
    assert rc == 0
    reg = loads(out)['region']['O4']
    (x0, x1), (y0, y1) = reg['extent']
    assert x0 == x1 and y0 == y1 and reg['area'] == 0.0
    assert [x0, y0] == reg['boundary'][0]


def test_range_refuses_an_actuator_named_twice(capsys):
    # Z1,Z1 read as two axes gave the curve L moves on an area of 0.0235 m^2
    rc, out, err = run(capsys, 'range', 'excavator', '--point', 'L', '--actuators', 'Z1,Z1')
    assert rc == 2 and out == ''
    assert '--actuators: Z1 named more than once' in err
