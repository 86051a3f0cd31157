"""Bad descriptions and side files are refused with one line naming the element, in bounded time.

Every refusal is a DescriptionError (a SceneError: the node and the CLI report it as a bad scene),
its text one line that names the file (or ``<robot_description>`` for text) and the element at
fault, and it comes in bounded time: a hostile description (entity expansion, a huge file) is
refused before any work grows with it.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from linkage_ros.core.description import DescriptionError, import_description
from linkage_ros.core.description.xml_text import MAX_DESCRIPTION_BYTES, MAX_ELEMENTS
from linkage_ros.core.errors import SceneError

FIXTURES = Path(__file__).resolve().parents[2] / 'fixtures' / 'robot_descriptions'
FOUR_BAR = FIXTURES / 'grbda_four_bar.urdf'
GEPETTO = FIXTURES / 'gepetto_5bar_linkage' / 'robot.urdf'
DRAKE = FIXTURES / 'drake_four_bar_loop.sdf'
TEXT = '<robot_description>'

#: seconds any refusal may take (the slowest, a loop that cannot close, tries every restart of
#: its least-squares assembly: about 3 s for the four-bar on a laptop)
BOUND = 20.0
QUICK = 1.0  # seconds: refusals that need no assembly


def refused(*needles: str, seconds: float = QUICK, **kwargs) -> DescriptionError:
    """import_description(**kwargs) must raise a one-line DescriptionError containing every
    needle, within ``seconds``."""
    args = kwargs.pop('args')
    t0 = time.perf_counter()
    with pytest.raises(DescriptionError) as info:
        import_description(*args, **kwargs)
    elapsed = time.perf_counter() - t0
    text = str(info.value)
    assert isinstance(info.value, SceneError)
    assert '\n' not in text, text
    for needle in needles:
        assert needle in text, (needle, text)
    assert elapsed < seconds, (elapsed, text)
    return info.value


def four_bar_text() -> str:
    return FOUR_BAR.read_text()


def edited(old: str, new: str, text: str | None = None) -> str:
    text = four_bar_text() if text is None else text
    assert text.count(old) == 1, old
    return text.replace(old, new)


def side(tmp_path: Path, name: str, content: str) -> str:
    path = tmp_path / name
    path.write_text(content)
    return str(path)


# ---- XML -------------------------------------------------------------------------------------


def test_malformed_xml():
    bad = four_bar_text().replace('</robot>', '')
    refused(TEXT, 'malformed XML', 'line', args=[bad], text=True)
    refused(TEXT, 'malformed XML', args=['<robot name="r"><link name="a"></robot>'], text=True)
    refused(TEXT, 'malformed XML', args=[''], text=True)


def test_malformed_xml_in_a_file_names_the_file(tmp_path):
    path = side(tmp_path, 'broken.urdf', '<robot name="r"><link name="a"></robot>')
    refused(path, 'malformed XML', args=[path])


def test_a_root_element_that_is_no_description():
    refused(TEXT, '<scene>', '<robot>', '<sdf>', args=['<scene/>'], text=True)


def test_a_description_with_no_links_says_so():
    """It was refused as 'no root link (the joints form a cycle)': it has no joints either."""
    for text in (
        "<robot name='r'/>",
        '<robot name="y"></robot>',
        '<sdf version="1.9"><model name="m"/></sdf>',  # (an IndexError)
    ):
        err = refused(TEXT, 'no links', args=[text], text=True)
        assert 'cycle' not in str(err)


def test_entity_expansion_is_refused_before_parsing():
    """The billion laughs: ten entities of ten references each, 10**9 'lol's if expanded."""
    entities = '<!ENTITY lol0 "lol">' + ''.join(
        f'<!ENTITY lol{i} "{f"&lol{i - 1};" * 10}">' for i in range(1, 10)
    )
    laughs = f'<?xml version="1.0"?><!DOCTYPE robot [{entities}]><robot name="r">&lol9;</robot>'
    refused(TEXT, 'DOCTYPE', args=[laughs], text=True, seconds=0.2)
    # a DOCTYPE alone (an external entity could be declared in it) and an entity spelt lower
    refused('DOCTYPE', args=['<!DOCTYPE robot SYSTEM "x.dtd"><robot/>'], text=True, seconds=0.2)
    refused('DOCTYPE', args=['<!doctype robot [<!entity a "b">]><robot/>'], text=True)


def test_an_unexpanded_xacro_names_what_it_found():
    xacro = """<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://ros.org/wiki/xacro">
  <xacro:property name="length" value="0.5"/>
  <link name="base"/>
  <link name="arm"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="arm"/>
    <origin xyz="${length} 0 0"/>
    <axis xyz="0 0 1"/>
  </joint>
</robot>
"""
    refused(TEXT, 'xacro', 'xacro:property', 'run xacro', args=[xacro], text=True)
    # the properties already expanded away, a ${} left in an attribute
    only_expr = xacro.replace('  <xacro:property name="length" value="0.5"/>\n', '')
    refused(TEXT, 'xacro', 'origin', '${length}', args=[only_expr], text=True)
    # $(find pkg) of a mesh path, in a file without the xacro namespace
    find = edited(
        '<link name="base_link"/>',
        '<link name="base_link"><visual><geometry><mesh filename="$(find arm)/base.stl"/>'
        '</geometry></visual></link>',
    )
    refused(TEXT, 'xacro', 'mesh', '$(find arm)', args=[find], text=True)


def test_a_description_larger_than_the_limit(tmp_path):
    pad = '<!--' + 'x' * MAX_DESCRIPTION_BYTES + '-->'
    big = four_bar_text().replace('<robot name="four_bar"', pad + '<robot name="four_bar"')
    refused(TEXT, 'larger than', str(MAX_DESCRIPTION_BYTES), args=[big], text=True)
    path = tmp_path / 'big.urdf'
    path.write_text(big)
    refused(str(path), 'larger than', str(MAX_DESCRIPTION_BYTES), args=[str(path)])


def test_more_elements_than_the_limit():
    links = ''.join(f'<link name="l{i}"/>' for i in range(MAX_ELEMENTS + 1))
    refused(TEXT, str(MAX_ELEMENTS), args=[f'<robot name="r">{links}</robot>'], text=True)


def test_a_missing_file_and_a_missing_side_file(tmp_path):
    refused(str(tmp_path / 'none.urdf'), 'not found', args=[str(tmp_path / 'none.urdf')])
    missing = str(tmp_path / 'none.yaml')
    refused(missing, 'not found', args=[str(FOUR_BAR)], closures=missing)


def test_a_number_that_is_not_finite():
    bad = edited('<origin xyz="1.0 0.0 0.0"/>\n        <axis', '<origin xyz="nan 0 0"/>\n<axis')
    refused(TEXT, "joint 'joint3'", 'origin xyz', 'nan', args=[bad], text=True)


# ---- links, joints, closures -----------------------------------------------------------------


def test_a_loop_naming_an_unknown_link():
    bad = edited('<successor link="link3">', '<successor link="link9">')
    refused(TEXT, "loop 'loop1'", 'unknown link', 'link9', args=[bad], text=True)
    bad = edited('<predecessor link="link2">', '<predecessor link="nowhere">')
    refused(TEXT, "loop 'loop1'", 'nowhere', args=[bad], text=True)


@pytest.mark.parametrize(
    ('leader', 'said'), [('nosuch', '<mimic> names an unknown joint'), ('joint3', 'follows itself')]
)
def test_a_mimic_of_no_joint_is_refused(leader, said):
    """A <mimic> of a joint the description lacks, or of itself, was accepted without a word
    and its follower left out of joint_states (an integrator)."""
    bad = edited(
        '<child link="link3"/>', f'<child link="link3"/><mimic joint="{leader}" multiplier="2"/>'
    )
    refused(TEXT, "joint 'joint3'", said, leader, args=[bad], text=True)


def test_an_origin_near_the_float_range_is_refused_naming_no_internal_point(recwarn):
    """A joint's <origin> of 1e300 m was refused naming the scene's internal point world_axis
    (an overflow of its length scale), with numpy's overflow warning on stderr (an
    integrator): the loop cannot close, and the refusal says so."""
    bad = edited(
        '<child link="link3"/>\n        <origin xyz="1.0 0.0 0.0"/>',
        '<child link="link3"/>\n        <origin xyz="1e300 0.0 0.0"/>',
    )
    err = refused(TEXT, 'cannot assemble', 'misses closing', args=[bad], text=True)
    assert '_axis' not in str(err)
    assert not [w for w in recwarn if 'overflow' in str(w.message)]


def test_an_over_constrained_chain_names_what_its_closures_join(tmp_path):
    """A closure file whose pin joins two links the chain already closes gave 'the closed
    chain has -1 degree(s) of freedom ... state the actuated joints', pointing at the actuated
    joints where the closures are the mistake (an integrator)."""
    extra = side(
        tmp_path,
        'extra.yaml',
        'closures:\n  - {name: extra, type: revolute, a: {frame: joint2}, b: {frame: joint3}}\n',
    )
    err = refused(
        'the closed chain is over-constrained: it has -1 degree(s) of freedom',
        "closure 'loop1' joins links link2 and link3",
        "closure 'extra' joins links",
        'more closures than its joints can close',
        args=[str(FOUR_BAR), extra],
    )
    assert 'state the actuated joints' not in str(err)


def test_a_constraint_naming_an_unknown_link():
    constraint = edited(
        four_bar_text()[four_bar_text().index('    <loop') : four_bar_text().index('</robot>')],
        '<constraint name="c1" type="revolute"><parent link="link2"/>'
        '<parent_origin xyz="1 0 0"/><parent_axis xyz="0 0 1"/><child link="ghost"/>'
        '<child_origin xyz="0.5 0 0"/></constraint>\n',
    )
    refused(TEXT, "constraint 'c1'", 'ghost', args=[constraint], text=True)


def test_a_link_with_two_parents():
    bad = edited(
        '</robot>',
        '<joint name="extra" type="revolute"><parent link="link2"/><child link="link3"/>'
        '</joint></robot>',
    )
    refused(TEXT, "'link3'", "'joint3'", "'extra'", '<loop>', args=[bad], text=True)


def test_non_parallel_axes_name_both_joints():
    bad = edited(
        '<origin xyz="1.0 0.0 0.0"/>\n        <axis xyz="0 0 1"/>',
        '<origin xyz="1.0 0.0 0.0"/>\n        <axis xyz="0 0.1 1"/>',
    )
    err = refused(TEXT, 'not a planar chain', "'joint1'", "'joint3'", 'deg', args=[bad], text=True)
    assert '5.71' in str(err)  # atan(0.1): how far from parallel
    assert 'rounded' not in str(err)  # (not a rounding: no hint about one)


def test_axes_a_rounded_rpy_apart_say_how_to_write_it():
    """joint3 turned over by rpy 3.14159 (pi to 6 digits) with its axis flipped: its axis is
    2.65e-6 rad off joint1's, beyond the 1e-9 rad that count as parallel. The refusal says why
    such a description is refused and how to write the rpy."""
    bad = edited(
        '<origin xyz="1.0 0.0 0.0"/>\n        <axis xyz="0 0 1"/>',
        '<origin xyz="1.0 0.0 0.0" rpy="3.14159 0 0"/>\n        <axis xyz="0 0 -1"/>',
    )
    refused(TEXT, 'not a planar chain', '0.000152', 'within 1e-09 rad', '3.141592653589793',
            args=[bad], text=True)  # fmt: skip


def test_a_loop_axis_across_the_plane():
    bad = edited('<axis xyz="0 0 1"/>\n    </loop>', '<axis xyz="0 1 0"/>\n    </loop>')
    refused(TEXT, "loop 'loop1'", 'axis', args=[bad], text=True)


@pytest.mark.parametrize('kind', ['fixed', 'floating', 'planar', 'hinge'])
def test_a_loop_type_a_planar_chain_cannot_have(kind):
    bad = edited('<loop name="loop1" type="revolute">', f'<loop name="loop1" type="{kind}">')
    refused(TEXT, "loop 'loop1'", f"'{kind}'", args=[bad], text=True)


def test_an_sdf_loop_joint_of_a_type_a_planar_chain_cannot_have():
    sdf = DRAKE.read_text()
    for kind in ('fixed', 'universal', 'screw'):
        bad = sdf.replace(
            '<joint name="coupler_rocker" type="revolute">',
            f'<joint name="coupler_rocker" type="{kind}">',
        )
        refused(TEXT, "joint 'coupler_rocker'", f"'{kind}'", args=[bad], text=True)


def test_a_joint_in_the_chain_that_is_not_planar():
    bad = edited(
        '<joint name="joint2" type="revolute" independent="false">',
        '<joint name="joint2" type="floating" independent="false">',
    )
    refused(TEXT, "joint 'joint2'", args=[bad], text=True)


def test_a_loop_within_one_rigid_body():
    bad = edited('<successor link="link3">', '<successor link="link2">')
    refused(TEXT, "loop 'loop1'", 'one rigid body', args=[bad], text=True)


def test_a_description_with_no_closure():
    text = four_bar_text()
    tree = text[: text.index('    <loop')] + '</robot>\n'
    refused(TEXT, 'no closure', '--closures', args=[tree], text=True)


# ---- actuated joints -------------------------------------------------------------------------


def test_actuated_joints_that_do_not_match_the_freedom():
    err = refused(
        str(FOUR_BAR), '1 degree', "2 joint(s) are actuated", 'joint1, joint3',
        args=[str(FOUR_BAR)], actuated=['joint1', 'joint3'],
    )  # fmt: skip
    assert 'chain joints: joint1, joint3, joint2' in str(err)
    # no independent marks at all: every joint counts as actuated
    unmarked = (
        four_bar_text().replace(' independent="true"', '').replace(' independent="false"', '')
    )
    refused(TEXT, '1 degree', '3 joint(s) are actuated', args=[unmarked], text=True)


def test_an_sdf_is_told_its_own_passive_mark():
    """SDF has no independent= attribute: a passive SDF joint is one with <effort>0</effort> in
    its limit (Drake's mark); the Drake four-bar without its closure file marks none."""
    err = refused(str(DRAKE), '3 joint(s) are actuated', '<effort>0</effort>', args=[str(DRAKE)])
    assert 'independent mark' not in str(err)
    # by its format, not its file name: the same SDF as text (the node's robot_description)
    err = refused(TEXT, '<effort>0</effort>', args=[DRAKE.read_text()], text=True)
    assert 'independent mark' not in str(err)


def test_actuated_joints_that_are_not_there(tmp_path):
    refused('actuated', 'joint9', args=[str(FOUR_BAR)], actuated=['joint9'])
    refused('values', 'joint9', args=[str(FOUR_BAR)], values={'joint9': 0.1})


# ---- assembly --------------------------------------------------------------------------------


def test_a_loop_that_cannot_close_gives_the_miss():
    """The rocker pin moved from 0.5 m to 5 m along link3: at joint1 = 0 the coupler (1 m
    about (0.5, 0)) and the rocker (5 m about (1, 0)) miss by 5 - 1 - 0.5 = 3.5 m."""
    bad = edited(
        '<origin xyz="0.5 0.0 0.0"/>\n        </successor>',
        '<origin xyz="5.0 0.0 0.0"/>\n        </successor>',
    )
    refused(TEXT, 'cannot assemble', 'joint1 = 0', 'by 3.5 m', args=[bad], text=True, seconds=BOUND)


def test_a_loop_that_cannot_close_at_the_actuated_values():
    """The six-bar with link4 shortened to 0.05 m: the link4-link5 arm then reaches 0.45 to
    0.55 m from the origin, and at joint1 = joint2 = joint3 = 0 link3's pin is at 0.6 m: the
    nearest configuration misses by 0.05 m (and the three joints are named with their values)."""
    text = (FIXTURES / 'grbda_six_bar.urdf').read_text()
    assert text.count('<origin xyz="0.4 0.0 0.0"/>') == 1
    text = text.replace('<origin xyz="0.4 0.0 0.0"/>', '<origin xyz="0.05 0.0 0.0"/>')
    refused(
        TEXT, 'cannot assemble at joint1 = 0, joint2 = 0, joint3 = 0', 'by 0.05 m',
        args=[text], text=True, seconds=BOUND,
    )  # fmt: skip


# ---- side files ------------------------------------------------------------------------------


def test_a_gepetto_side_file_naming_an_unknown_frame(tmp_path):
    path = side(
        tmp_path,
        'robot.yaml',
        "closed_loop: [['closedloop1_A', 'nonesuch']]\ntype: ['6d']\nname_mot: ['mot1', 'mot2']\n",
    )
    refused(path, 'closed_loop[0]', 'nonesuch', args=[str(GEPETTO)], closures=path)


def test_a_gepetto_side_file_with_a_bad_type_or_motor(tmp_path):
    path = side(
        tmp_path,
        'type.yaml',
        "closed_loop: [['closedloop1_A', 'closedloop1_B']]\ntype: ['5d']\nname_mot: [mot1, mot2]\n",
    )
    refused(path, 'type[0]', '5d', args=[str(GEPETTO)], closures=path)
    path = side(
        tmp_path,
        'mot.yaml',
        "closed_loop: [['closedloop1_A', 'closedloop1_B']]\ntype: ['6d']\nname_mot: [mot1, mot9]\n",
    )
    refused(path, 'name_mot', 'mot9', args=[str(GEPETTO)], closures=path)


def test_a_6d_pair_of_frames_no_joint_turns_would_weld(tmp_path):
    """The effector (fixed to end_rod) and the base link 'built': no joint turns either frame.
    (Links below revolute joints, such as sphere and sphere_2, have those joints' frames: a
    6d pair of them closes; test_description_frames.py.)"""
    path = side(
        tmp_path,
        'weld.yaml',
        "closed_loop: [['effector', 'built']]\ntype: ['6d']\nname_mot: [mot1, mot2]\n",
    )
    refused('closed_loop[0]', '6d', 'weld', args=[str(GEPETTO)], closures=path)


def test_a_closure_file_with_an_unknown_key(tmp_path):
    path = side(tmp_path, 'top.yaml', 'actuated: [world_driver]\nactuator: [x]\n')
    refused(path, 'unknown key', "'actuator'", args=[str(DRAKE)], closures=path)
    item = (
        'closures:\n  - {name: p, type: revolute, a: {link: link2, xyz: [1, 0, 0]},\n'
        '     b: {link: link3, xyz: [0.5, 0, 0]}, bogus: 1}\n'
    )
    path = side(tmp_path, 'item.yaml', item)
    refused(path, 'closures[0]', "'bogus'", args=[str(FOUR_BAR)], closures=path)
    end = 'closures:\n  - {name: p, a: {link: link2, xyz: [1, 0, 0], frame_id: x}, b: link3}\n'
    path = side(tmp_path, 'end.yaml', end)
    refused(path, 'closures[0].a', "'frame_id'", args=[str(FOUR_BAR)], closures=path)


def test_a_closure_file_naming_unknown_links_joints_and_types(tmp_path):
    path = side(
        tmp_path,
        'link.yaml',
        'closures:\n  - {name: p, a: {link: link22, xyz: [1, 0, 0]}, b: {link: link3}}\n',
    )
    refused(path, 'closures[0].a.link', 'link22', args=[str(FOUR_BAR)], closures=path)
    path = side(
        tmp_path,
        'type.yaml',
        'closures:\n  - {name: p, type: fixed, a: {link: link2}, b: {link: link3}}\n',
    )
    refused(path, 'closures[0].type', 'fixed', args=[str(FOUR_BAR)], closures=path)
    path = side(
        tmp_path, 'limits.yaml', 'actuated: [world_driver]\nlimits: {nojoint: {lower: 0}}\n'
    )
    refused(path, 'limits.nojoint', args=[str(DRAKE)], closures=path)


def test_a_closure_file_with_a_yaml_bomb(tmp_path):
    """YAML's billion laughs are aliases: refused before they are expanded."""
    lines = ['a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]']
    lines += [f'a{i}: &a{i} [' + ', '.join([f'*a{i - 1}'] * 9) + ']' for i in range(1, 9)]
    path = side(tmp_path, 'bomb.yaml', '\n'.join(lines) + '\nclosures: *a8\n')
    refused(path, 'alias', args=[str(FOUR_BAR)], closures=path, seconds=0.5)


def test_a_side_file_that_is_not_a_mapping(tmp_path):
    path = side(tmp_path, 'list.yaml', '- closures\n')
    refused(path, 'mapping', args=[str(FOUR_BAR)], closures=path)


def test_a_limit_whose_lower_is_above_its_upper_is_refused_naming_the_joint():
    """lower="1" upper="-1" was read as the interval [-1, 1] without a word; no value fits
    it as written. The SDFormat reader refuses it alike."""
    text = four_bar_text()
    first = text.index('lower="-13.14" upper="13.14"')
    swapped = (
        text[:first] + 'lower="1" upper="-1"' + text[first + len('lower="-13.14" upper="13.14"') :]
    )
    refused(TEXT, 'limit lower 1 is above upper -1', 'swap them', args=[swapped], text=True)
    sdf = DRAKE.read_text()
    joint = sdf.index('<axis>')
    bad = sdf[:joint] + sdf[joint:].replace(
        '<axis>', '<axis><limit><lower>2</lower><upper>0.5</upper></limit>', 1
    )
    refused(TEXT, 'limit lower 2 is above upper 0.5', args=[bad], text=True)


def test_a_closure_with_a_joints_name_is_refused_naming_the_clash():
    """A <loop> named like a tree joint made their two pins one scene point, and the refusal
    spoke of a motion left free, not of the name."""
    clash = edited('<loop name="loop1"', '<loop name="joint2"')
    refused(TEXT, "closure 'joint2' has the name of a joint", args=[clash], text=True)


def test_two_closures_of_one_name_are_refused_naming_it(tmp_path):
    """A closure file entry named as the description's <loop> (or two <loop>s of one name):
    both pins became one scene point and the refusal spoke of 0 degrees of freedom
    (Kutzbach) and assemble_at."""
    entry = (
        'closures:\n  - {name: loop1, type: revolute, a: {link: link2, xyz: [1, 0, 0]},\n'
        '     b: {link: link3, xyz: [0.5, 0, 0]}}\n'
    )
    path = side(tmp_path, 'dup.yaml', entry)
    refused(path, "two closures are named 'loop1'", args=[str(FOUR_BAR)], closures=path)


def test_a_joint_named_as_a_links_axis_mark_is_a_joint_like_any(tmp_path):
    """Each link's axis mark is a scene point named <link>_axis; a joint of that name (here
    joint2 renamed link2_axis) was merged with the mark and refused as 'shares points with
    link ...: one rigid link'. The mark takes another name; the joint answers as joint2 did.
    Oracle: the parallelogram relation of the GRBDA four-bar in the drawing's mode."""
    from linkage_ros.engine import Engine, EngineSettings

    text = four_bar_text().replace('name="joint2"', 'name="link2_axis"')
    assert text.count('link2_axis') == 1
    mech = import_description(text, text=True).mechanism
    r = Engine(mech, EngineSettings(branch='-')).command({'joint1': 0.4})
    assert r.success, r.reason
    joints = dict(zip(mech.output_joint_names, mech.output_joints(r.joints)))
    assert abs(joints['link2_axis'] + 0.4) < 1e-12 and abs(joints['joint3'] - 0.4) < 1e-12


def test_an_assembly_outside_a_turned_joints_limit_is_said_in_the_descriptions_values():
    """joint1 turned by its <origin> rpy (2 rad) and flipped (axis -z), its <limit> [2.5, 5],
    no assemble_at: the description is assembled at joint1 = 0, outside. The refusal quoted the
    scene's values ('joint1 = 2 rad is below its minimum -3'), which the description never
    shows; now the description's value and limit, and a value to assemble at. The value is
    judged as given, as a command is (0 is below 2.5, not a turn of it beyond 5)."""
    bad = edited(
        '<origin xyz="0.0 0.0 0.0"/>\n        <axis xyz="0 0 1"/>\n'
        '        <limit effort="30" velocity="1.0" lower="-13.14" upper="13.14"/>',
        '<origin xyz="0.0 0.0 0.0" rpy="0 0 2.0"/>\n        <axis xyz="0 0 -1"/>\n'
        '        <limit effort="30" velocity="1.0" lower="2.5" upper="5.0"/>',
    )
    err = refused(TEXT, 'joint1 = 0 rad', 'minimum 2.5', 'no assemble_at', '<limit>: [2.5, 5]',
                  'assemble_at: {joint1: 3.75}', args=[bad], text=True)  # fmt: skip
    assert '-3' not in str(err) and '= 2 rad' not in str(err), err


@pytest.mark.parametrize('limits', ['{upper: -0.5}', '{lower: 3.1}', '{lower: 4}'])
def test_an_actuated_angle_with_one_limit_is_refused_naming_it(tmp_path, limits):
    """A closure file's one limit on the GRBDA four-bar's actuated crank: the import judged the
    assembly by it while the commands took no limit from it (answered beyond it), and bounding
    the commands by the arc to +-pi named a +-pi limit nobody wrote (reviews' finds). An angle's
    range is an arc: both ends are asked for."""
    path = side(tmp_path, 'one.yaml', f'limits: {{joint1: {limits}}}\n')
    refused(
        'limits of the actuated joint joint1: an angle needs both lower and upper',
        'one.yaml',  # (the closure file, not the description, states them)
        args=[str(FOUR_BAR)],
        closures=path,
    )


def test_a_descriptions_single_limit_end_on_an_actuated_angle_bounds_nothing(tmp_path):
    """A description's <limit> with one end on its actuated angle (URDF upper="1.5" alone; an
    SDF <lower> alone) bounds no command: an angle's range is an arc and one end is none, as
    the description's commands were read before this stop. Refusing it (a review's find: valid
    URDF and SDF were refused) or reading urdfdom's 0 for the other end (a lower of 0.02 became
    [0.02, 0]: refused as upside down) were both wrong."""
    from linkage_ros.engine import Engine, EngineSettings

    text = edited(
        '<limit effort="30" velocity="1.0" lower="-13.14" upper="13.14"/>\n    </joint>\n\n'
        '    <joint name="joint2"',
        '<limit effort="30" velocity="1.0" upper="1.5"/>\n    </joint>\n\n    <joint name="joint2"',
    )
    mech = import_description(text, text=True).mechanism
    engine = Engine(mech, EngineSettings())
    for crank in (0.7, -0.2, 2.0):
        assert engine.command({'joint1': crank}).success, crank
    sdf = DRAKE.read_text()
    axis = sdf.index('<axis>', sdf.index('name="world_driver"'))
    sdf = sdf[:axis] + '<axis><limit><lower>-1</lower></limit>' + sdf[axis + len('<axis>') :]
    path = tmp_path / 'one_end.sdf'
    path.write_text(sdf)
    side_file = str(DRAKE).replace('.sdf', '.closures.yaml')
    assert import_description(str(path), closures=side_file).mechanism is not None


def test_a_count_of_actuated_joints_off_the_chains_freedom_says_why(tmp_path):
    """An outside integrator's two: the Robotiq's closure file with only its motor's joint
    actuated (the right finger's loop then has none: its knuckle follows the left one by
    <mimic> and must be listed too), and the GRBDA four-bar's <loop> stated again in a closure
    file (-1 degrees of freedom). The refusal said 'state the actuated joints' to both; it now
    names the loop without an actuated joint and its follower, and the closure stated twice."""
    shipped = (FIXTURES / 'picknik_robotiq_2f_85.closures.yaml').read_text()
    both = 'actuated: [robotiq_85_left_knuckle_joint, robotiq_85_right_knuckle_joint]'
    assert both in shipped
    one = side(
        tmp_path, 'one.yaml', shipped.replace(both, 'actuated: [robotiq_85_left_knuckle_joint]')
    )
    refused(
        '2 degree(s) of freedom',
        "loop 'right_tip_pin' has no actuated joint, and its robotiq_85_right_knuckle_joint "
        'follows robotiq_85_left_knuckle_joint by <mimic>: list it too',
        args=[str(FIXTURES / 'picknik_robotiq_2f_85.expanded.urdf')],
        closures=one,
        seconds=BOUND,
    )
    dup = side(
        tmp_path,
        'dup.yaml',
        'closures:\n  - {name: again, type: revolute, a: {link: link2, xyz: [1.0, 0, 0]}, '
        'b: {link: link3, xyz: [0.5, 0, 0]}}\n',
    )
    refused(
        '-1 degree(s) of freedom',
        "closure 'again' joins link2 and link3 as 'loop1' does: stated twice?",
        args=[str(FOUR_BAR)],
        closures=dup,
    )
