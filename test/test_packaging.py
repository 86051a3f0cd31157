"""The package stays buildable by colcon on a normal ROS 2 install: package.xml declares what the
code imports, and setup.py installs the ament marker, package.xml, every scene and param file."""

import ast
import glob
import re
import xml.etree.ElementTree as ET

from scenes import REPO as ROOT


def test_package_xml_is_format_3_ament_python_with_the_runtime_dependencies():
    root = ET.parse(ROOT / 'package.xml').getroot()
    assert root.tag == 'package' and root.get('format') == '3'
    assert root.findtext('name') == 'linkage_ros'
    assert root.find('export/build_type').text == 'ament_python'
    exec_deps = {e.text for e in root.findall('exec_depend')}
    assert {
        'rclpy',
        'sensor_msgs',
        'geometry_msgs',
        'visualization_msgs',
        'diagnostic_msgs',
        'python3-numpy',
        'python3-scipy',
        'python3-yaml',
    } <= exec_deps
    assert 'python3-pytest' in {e.text for e in root.findall('test_depend')}


def test_every_ros_message_package_imported_by_the_code_is_declared():
    root = ET.parse(ROOT / 'package.xml').getroot()
    declared = {e.text for e in root.findall('exec_depend')}
    used = set()
    for path in (ROOT / 'linkage_ros').rglob('*.py'):
        for m in re.finditer(r'^\s*(?:from|import)\s+(\w+_msgs)\b', path.read_text(), re.M):
            used.add(m.group(1))
    assert used, 'the node imports ROS message packages'
    assert used <= declared, f'undeclared message packages: {sorted(used - declared)}'


def test_core_never_imports_ros():
    for path in (ROOT / 'linkage_ros' / 'core').rglob('*.py'):
        text = path.read_text()
        assert not re.search(
            r'^\s*(import rclpy|from rclpy|from \w+_msgs|import \w+_msgs)', text, re.M
        ), path


def _data_files():
    tree = ast.parse((ROOT / 'setup.py').read_text())
    call = next(
        n
        for n in ast.walk(tree)
        if isinstance(n, ast.Call) and getattr(n.func, 'id', '') == 'setup'
    )
    kw = {k.arg: k.value for k in call.keywords}
    return ast.unparse(kw['data_files']), kw


def test_setup_installs_marker_package_xml_scenes_and_params_for_colcon():
    text, kw = _data_files()
    assert "'share/ament_index/resource_index/packages'" in text
    assert "'resource/' + package_name" in text and (ROOT / 'resource' / 'linkage_ros').exists()
    assert "'package.xml'" in text
    assert "glob('config/*.yaml')" in text and "glob('config/params/*.yaml')" in text
    assert glob.glob(str(ROOT / 'config' / '*.yaml')) and glob.glob(
        str(ROOT / 'config/params/*.yaml')
    )
    scripts = ast.unparse(kw['entry_points'])
    assert 'linkage_node = linkage_ros.node:main' in scripts
    assert 'linkage = linkage_ros.cli:main' in scripts


def test_ci_runs_the_readme_test_command():
    assert 'make test' in (ROOT / '.ci' / 'run').read_text()
    readme = (ROOT / 'README.md').read_text()
    first_block = readme.split('```sh', 1)[1].split('```', 1)[0]
    commands = [l.split('#')[0].strip() for l in first_block.strip().splitlines()]
    assert commands == ['make run', 'make test']
