"""``linkage solve --all-branches`` on a roller on a flat face (issue 27): the nut-cracker's 8
assembly modes, both sides of the roller listed and the drawn one named.

Checked on the constraint geometry read off each mode (written here, not the core's): every link
length as drawn, the roller centre one radius off the jaw's face on the side the mode states,
and eight distinct configurations (the most the mechanism has: two places of the arm's joint,
then two tangent lines of the jaw per side).
"""

from __future__ import annotations

import json
import math
import re

import pytest
import scenes
import yaml

from linkage_ros.cli.parser import main

THETA = 1.2  # rad, the handle (it reaches within about +-1.69)


@pytest.fixture(scope='module')
def scene(tmp_path_factory):
    p = tmp_path_factory.mktemp('roller') / 'nut_cracker.yaml'
    p.write_text(yaml.safe_dump(scenes.nut_cracker()))
    return str(p)


def run(capsys, *argv):
    rc = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _dist(p, q):
    return math.hypot(p[0] - q[0], p[1] - q[1])


def test_all_branches_lists_both_roller_sides_as_json(capsys, scene):
    rc, out, _ = run(capsys, 'solve', scene, '--set', f'handle={THETA}', '--all-branches', '--json')
    assert rc == 0
    modes = json.loads(out)
    assert len(modes) == 8 and all(m['status'] == 'ok' for m in modes)
    drawn = {**scenes.NUT_DRAWN, 'F': scenes.nut_cracker_jaw_point()}
    sides = []
    for m in modes:
        p = m['points']
        for a, b in [('O2', 'A'), ('A', 'B'), ('O4', 'B'), ('O4', 'R'), ('B', 'R'), ('O6', 'F')]:
            assert _dist(p[a], p[b]) == pytest.approx(_dist(drawn[a], drawn[b]), abs=1e-13)
        assert math.atan2(p['A'][1], p['A'][0]) == pytest.approx(THETA, abs=1e-13)
        fx, fy = p['F'][0] - p['O6'][0], p['F'][1] - p['O6'][1]
        wx, wy = p['R'][0] - p['O6'][0], p['R'][1] - p['O6'][1]
        offset = (fx * wy - fy * wx) / math.hypot(fx, fy)  # > 0: R left of the face
        roller = m['rollers']['face']
        assert roller['drawn_side'] == 'left'
        assert offset == pytest.approx(
            scenes.NUT_RADIUS * (1 if roller['side'] == 'left' else -1), abs=1e-13
        )
        sides.append(roller['side'])
    assert sorted(sides) == ['left'] * 4 + ['right'] * 4
    # eight distinct configurations
    for i, a in enumerate(modes):
        for b in modes[i + 1 :]:
            assert max(_dist(a['points'][k], b['points'][k]) for k in a['points']) > 1e-6
    # the drawing's mode: its circuit passes the arm's toggles (test_roller_side), so the arm's
    # two signs with the roller on its drawn side, and only they
    drawn = [m for m in modes if m['drawn_mode']]
    assert sorted(m['branch'] for m in drawn) == ['+++', '-++']
    assert all(m['rollers']['face']['side'] == 'left' for m in drawn)
    assert len({m['branch'] for m in modes}) == 8


def test_all_branches_text_names_the_roller_sign_and_the_drawn_mode(capsys, scene):
    rc, out, _ = run(capsys, 'solve', scene, '--set', f'handle={THETA}', '--all-branches')
    assert rc == 0
    assert out.count('--- assembly mode') == 8
    assert 'roller face: branch sign 2 of 3 is the side of its face' in out
    assert 'drawn left' in out
    # the drawing's circuit (+++ and -++, through the arm's toggles), the 4 with the drawn side
    assert out.count('(as drawn)\n') == 2 + 4
    assert out.count('roller face: right of its face (not drawn)') == 4


def test_branch_chooses_the_side_not_drawn(capsys, scene):
    # the other side is an ordinary branch: --branch takes it like a dyad's sign
    rc, out, _ = run(
        capsys, 'solve', scene, '--set', f'handle={THETA}', '--branch', '+-+', '--json'
    )
    assert rc == 0
    d = json.loads(out)
    assert d['status'] == 'ok' and d['branch'] == '+-+'
    p = d['points']
    fx, fy = p['F'][0] - p['O6'][0], p['F'][1] - p['O6'][1]
    wx, wy = p['R'][0] - p['O6'][0], p['R'][1] - p['O6'][1]
    assert (fx * wy - fy * wx) / math.hypot(fx, fy) == pytest.approx(-scenes.NUT_RADIUS, abs=1e-13)


def test_the_scene_doc_nut_cracker_lists_eight_modes(capsys, tmp_path):
    # docs/SCENES.md's example, as its text says it runs
    text = (scenes.REPO / 'docs' / 'SCENES.md').read_text(encoding='utf-8')
    block = next(b for b in re.findall(r'^```yaml\n(.*?)^```', text, re.S | re.M) if 'nut' in b)
    p = tmp_path / 'nut_cracker.yaml'
    p.write_text(block)
    rc, out, _ = run(capsys, 'solve', p, '--set', 'handle=1.2', '--all-branches', '--json')
    modes = json.loads(out)
    assert rc == 0 and len(modes) == 8 and all(m['status'] == 'ok' for m in modes)
    assert [m['branch'] for m in modes if m['drawn_mode']] == ['+++', '-++']
    assert {m['rollers']['face']['side'] for m in modes} == {'left', 'right'}
