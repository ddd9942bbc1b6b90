"""The catkin package itself: generated action classes, dependencies, lint, scripts."""
import os
import re
import shutil
import subprocess
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ROS1, ROS2 = '$ROS_VERSION != 2', '$ROS_VERSION == 2'
DEPENDENCY_TAGS = ('depend', 'build_depend', 'buildtool_depend', 'exec_depend', 'test_depend',
                   'build_export_depend')


def test_generated_action_classes_keep_the_original_fields():
    msg = pytest.importorskip('battery_simulator.msg', reason='needs the devel space (tools/run_tests.sh)')
    assert msg.battery_simGoal.__slots__ == ['charge_state']
    assert msg.battery_simGoal._slot_types == ['bool']
    assert msg.battery_simResult.__slots__ == ['battery_status']
    assert msg.battery_simResult._slot_types == ['string']
    assert msg.battery_simFeedback.__slots__ == ['battery_percentage']
    assert msg.battery_simFeedback._slot_types == ['float32']
    assert msg.battery_simAction._type == 'battery_simulator/battery_simAction'


def test_action_file_is_the_original():
    text = (ROOT / 'action' / 'battery_sim.action').read_text()
    assert text.split() == ['bool', 'charge_state', '---', 'string', 'battery_status', '---',
                            'float32', 'battery_percentage']


def package_dependencies(ros_version=None):
    """The dependency keys of package.xml: all, or those that apply when $ROS_VERSION is 1 or 2. The ROS 1
    ones say "!= 2", so that ROS 1's tools (catkin_lint, rosdep) take them without a ROS_VERSION set."""
    root = ElementTree.parse(ROOT / 'package.xml').getroot()
    assert root.get('format') == '3'
    applies = {None: (None, ROS1, ROS2), 1: (None, ROS1), 2: (None, ROS2)}[ros_version]
    keys = set()
    for tag in DEPENDENCY_TAGS:
        for element in root.findall(tag):
            condition = element.get('condition')
            assert condition in (None, ROS1, ROS2), condition
            if condition in applies:
                keys.add(element.text.strip())
    return keys


def install_lines():
    lines = {}
    for line in (ROOT / 'debian-dependencies.txt').read_text().splitlines():
        fields = line.split()
        if fields and not fields[0].startswith('#'):
            lines[fields[0]] = fields[1:]
    return lines


def test_every_ros1_dependency_has_an_install_line():
    lines = install_lines()
    missing = sorted(d for d in package_dependencies(1) if not lines.get(d))
    assert not missing, 'no line in debian-dependencies.txt for %s' % missing


def test_every_ros2_dependency_comes_with_the_ros2_wheels():
    """tools/ros2.sh installs ROS 2 from PyPI: each ROS 2 key has its wheel (ros-kilted-<key>)."""
    wheels = {line.split('==')[0].strip().lower() for line in
              (ROOT / 'tools' / 'ros2' / 'requirements.txt').read_text().splitlines()
              if line.strip() and not line.startswith('#')}
    python_keys = {'python3-yaml': 'pyyaml', 'python3-matplotlib': 'matplotlib', 'python3-pytest': 'pytest',
                   'python3-tornado': 'tornado', 'python3-numpy': 'numpy', 'python3-scipy': 'scipy'}
    missing = []
    for key in sorted(package_dependencies(2)):
        wheel = python_keys.get(key, 'ros-kilted-' + key.replace('_', '-'))
        if key != 'python3-hypothesis' and wheel not in wheels:
            missing.append('%s (%s)' % (key, wheel))
    assert not missing, 'not in tools/ros2/requirements.txt: %s' % missing


def test_every_key_resolves_with_rosdep():
    """Noetic on Ubuntu 20.04 for the ROS 1 keys, Jazzy for the ROS 2 keys (test/data/rosdep_keys.yaml)."""
    import yaml
    known = yaml.safe_load((ROOT / 'test' / 'data' / 'rosdep_keys.yaml').read_text())
    for ros_version, distro in ((1, 'noetic'), (2, 'jazzy')):
        unknown = sorted(key for key in package_dependencies(ros_version)
                         if key not in known['system'] and key not in known[distro])
        assert not unknown, 'not rosdep keys for %s: %s' % (distro, unknown)


def test_the_two_build_types_are_conditioned():
    root = ElementTree.parse(ROOT / 'package.xml').getroot()
    types = {(e.text.strip(), e.get('condition')) for e in root.find('export').findall('build_type')}
    assert types == {('catkin', ROS1), ('ament_cmake', ROS2)}, types
    assert 'rclpy_action' not in package_dependencies(), 'the action API is part of rclpy'


def test_required_dependencies_are_declared():
    assert {'rospy', 'actionlib', 'actionlib_msgs', 'std_msgs', 'sensor_msgs', 'message_generation',
            'message_runtime', 'rostest', 'catkin'} <= package_dependencies(1)
    assert {'rclpy', 'ament_cmake', 'rosidl_default_generators', 'rosidl_default_runtime', 'action_msgs',
            'sensor_msgs', 'std_msgs'} <= package_dependencies(2)


def test_install_script_reads_the_list():
    script = (ROOT / 'tools' / 'install_dependencies.sh').read_text()
    assert 'debian-dependencies.txt' in script


@pytest.mark.skipif(shutil.which('catkin_lint') is None, reason='catkin_lint not installed')
def test_catkin_lint_reports_nothing(tmp_path):
    copy = tmp_path / 'battery_simulator'  # lint wants the folder named as the package
    shutil.copytree(ROOT, copy, ignore=shutil.ignore_patterns('build', '.git', '__pycache__'))
    result = subprocess.run(['catkin_lint', '-W2', '--offline', str(copy)], capture_output=True, text=True,
                            timeout=120, env={k: v for k, v in os.environ.items() if k != 'ROS_VERSION'})   # as run by hand
    problems = [line for line in (result.stdout + result.stderr).splitlines()
                if re.search(r'(error|warning|notice):', line)]
    assert result.returncode == 0 and not problems, '\n'.join(problems) or result.stderr


def test_scripts_are_thin_entry_points():
    for script in (ROOT / 'scripts').glob('*.py'):
        code = [line for line in script.read_text().splitlines()
                if line.strip() and not line.startswith('#') and not line.startswith('"""')]
        assert len(code) == 2 and code[0].startswith('from battery_simulator.') and code[1] == 'main()', script
        assert script.stat().st_mode & 0o111, '%s is not executable' % script


def test_setup_py_installs_every_python_package(monkeypatch):
    """catkin_python_setup installs what setup.py lists: a list by hand left out battery_simulator.core.fit, so
    battery_fit failed from a ROS 1 install space."""
    import runpy
    import setuptools
    captured = {}
    monkeypatch.setattr(setuptools, 'setup', lambda **kwargs: captured.update(kwargs))
    monkeypatch.chdir(ROOT)
    runpy.run_path(str(ROOT / 'setup.py'))
    packages = {'.'.join(init.parent.relative_to(ROOT / 'src').parts)
                for init in (ROOT / 'src').rglob('__init__.py')}
    assert set(captured['packages']) == packages, sorted(packages ^ set(captured['packages']))
