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
    assert 'linkage = linkage_ros.cli.parser:main' in scripts


def test_ci_runs_the_readme_test_command():
    assert 'make test' in (ROOT / '.ci' / 'run').read_text()
    readme = (ROOT / 'README.md').read_text()
    # the first sh block (fenced `sh norun`: the doc test does not run make inside make test)
    first_block = readme.split('```sh', 1)[1].split('```', 1)[0].partition('\n')[2]
    commands = [l.split('#')[0].strip() for l in first_block.splitlines()]
    commands = [c for c in commands if c]
    assert commands == ['make run', 'make test']


#: import name -> rosdep key, for the third-party modules the package imports
ROSDEP_KEYS = {
    'numpy': 'python3-numpy',
    'scipy': 'python3-scipy',
    'yaml': 'python3-yaml',
    'matplotlib': 'python3-matplotlib',
    'tqdm': 'python3-tqdm',
    'mpmath': 'python3-mpmath',
}


def _imported_top_modules() -> set[str]:
    used = set()
    for path in (ROOT / 'linkage_ros').rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                used |= {a.name.split('.')[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                used.add(node.module.split('.')[0])
    return used


def test_package_xml_lists_every_import_and_nothing_else():
    import sys

    root = ET.parse(ROOT / 'package.xml').getroot()
    declared = {e.text for e in root.findall('exec_depend')}
    text = (ROOT / 'package.xml').read_text()
    no_rosdep = set(re.findall(r'no-rosdep: (\w+)', text))
    third_party = {m for m in _imported_top_modules() if m not in sys.stdlib_module_names} - {
        'linkage_ros'
    }
    for module in sorted(third_party):
        key = ROSDEP_KEYS.get(module, module)
        assert key in declared or module in no_rosdep, f'{module} is imported, not in package.xml'
    launch = {'launch', 'launch_ros', 'robot_state_publisher', 'rviz2'}
    wanted = {ROSDEP_KEYS.get(m, m) for m in third_party} | launch
    assert declared <= wanted, f'declared but never used: {sorted(declared - wanted)}'
    assert 'rosbags' in no_rosdep and 'pip install rosbags' in text


def test_launch_file_names_executables_and_files_that_exist():
    """The launch file cannot run here (no launch in the wheels): check what it names."""
    path = ROOT / 'config' / 'launch' / 'view.launch.py'
    source = path.read_text()
    tree = ast.parse(source)
    compile(source, str(path), 'exec')
    funcs = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert 'generate_launch_description' in funcs
    nodes = [
        n for n in ast.walk(tree) if isinstance(n, ast.Call) and getattr(n.func, 'id', '') == 'Node'
    ]
    started = {}
    for call in nodes:
        kw = {k.arg: k.value for k in call.keywords}
        started[ast.literal_eval(kw['package'])] = ast.literal_eval(kw['executable'])
    assert started == {
        'linkage_ros': 'linkage_node',
        'robot_state_publisher': 'robot_state_publisher',
        'rviz2': 'rviz2',
    }
    _, kw = _data_files()
    scripts = ast.unparse(kw['entry_points'])
    assert 'linkage_node = ' in scripts and 'linkage = linkage_ros.cli.parser:main' in scripts
    # robot_description comes from the CLI, run as an argument list (not a string launch splits)
    assert 'urdf_argv(scene, prefix, frame_id)' in source and 'OpaqueFunction' in source
    assert 'Command(' not in source
    text, _ = _data_files()
    assert "glob('config/launch/*.launch.py')" in text and "glob('config/rviz/*.rviz')" in text
    assert "'rviz', 'linkage.rviz'" in source and (ROOT / 'config/rviz/linkage.rviz').exists()
    import yaml

    rviz = yaml.safe_load((ROOT / 'config/rviz/linkage.rviz').read_text())
    manager = rviz['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == 'world'
    assert "default_value='world'" in source  # the launch file's frame_id default
    classes = {d['Class'] for d in manager['Displays']}
    assert 'rviz_default_plugins/RobotModel' in classes
    # every launch argument the launch file reads is declared
    declared = set(re.findall(r"DeclareLaunchArgument\('(\w+)'", source))
    read = set(re.findall(r"LaunchConfiguration\('(\w+)'\)", source))
    assert read <= declared


def test_start_up_does_not_import_scipy_optimize():
    """scipy.optimize takes ~0.4 s to import: the node and every CLI command would pay it at
    start-up. Only a refusal's least-squares miss and a description's assembly use it, and they
    import it when they run."""
    import subprocess
    import sys

    code = (
        'import sys, linkage_ros.core.model, linkage_ros.core.solver, linkage_ros.engine, '
        'linkage_ros.node, linkage_ros.cli; print("scipy.optimize" in sys.modules)'
    )
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == 'False', out.stdout + out.stderr


def test_the_launch_files_urdf_command_takes_a_scene_path_with_spaces(tmp_path):
    """The launch file built `linkage urdf` as one string that launch's Command substitution
    splits on spaces: a scene in 'my scenes/four bar.yaml' was two arguments and failed. It now
    runs urdf_argv's argument list: the URDF of that scene, prefixed, rooted at the frame."""
    import contextlib
    import shlex
    import subprocess
    import sys
    import xml.etree.ElementTree as ET

    from linkage_ros.cli.urdf import urdf_argv

    folder = tmp_path / 'my scenes'
    folder.mkdir()
    scene = folder / "four bar's.yaml"
    scene.write_text((ROOT / 'config' / 'four_bar.yaml').read_text())
    old = f"linkage urdf {scene} --prefix 'left_' --frame-id world"  # the string it built
    # the path cut apart, or (its quote unclosed) no command at all
    with contextlib.suppress(ValueError):
        assert str(scene) not in shlex.split(old)
    argv = urdf_argv(
        str(scene), 'left_', 'world', program=(sys.executable, '-m', 'linkage_ros.cli')
    )
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    robot = ET.fromstring(done.stdout)
    joints = {j.get('name') for j in robot.iter('joint')}
    links = {l.get('name') for l in robot.iter('link')}
    assert 'world' in links and joints and all(j.startswith('left_') for j in joints)
