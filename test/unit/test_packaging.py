"""The catkin package itself: generated action classes, dependencies, lint, scripts."""
import re
import shutil
import subprocess
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
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


def package_dependencies():
    root = ElementTree.parse(ROOT / 'package.xml').getroot()
    assert root.get('format') == '3'
    return {element.text.strip() for tag in DEPENDENCY_TAGS for element in root.findall(tag)}


def install_lines():
    lines = {}
    for line in (ROOT / 'debian-dependencies.txt').read_text().splitlines():
        fields = line.split()
        if fields and not fields[0].startswith('#'):
            lines[fields[0]] = fields[1:]
    return lines


def test_every_package_xml_dependency_has_an_install_line():
    lines = install_lines()
    missing = sorted(d for d in package_dependencies() if not lines.get(d))
    assert not missing, 'no line in debian-dependencies.txt for %s' % missing


def test_required_dependencies_are_declared():
    assert {'rospy', 'actionlib', 'actionlib_msgs', 'std_msgs', 'sensor_msgs', 'message_generation',
            'message_runtime', 'rostest', 'catkin'} <= package_dependencies()


def test_install_script_reads_the_list():
    script = (ROOT / 'tools' / 'install_dependencies.sh').read_text()
    assert 'debian-dependencies.txt' in script


@pytest.mark.skipif(shutil.which('catkin_lint') is None, reason='catkin_lint not installed')
def test_catkin_lint_reports_nothing(tmp_path):
    copy = tmp_path / 'battery_simulator'  # lint wants the folder named as the package
    shutil.copytree(ROOT, copy, ignore=shutil.ignore_patterns('build', '.git', '__pycache__'))
    result = subprocess.run(['catkin_lint', '-W2', '--offline', str(copy)], capture_output=True, text=True,
                            timeout=120)
    problems = [line for line in (result.stdout + result.stderr).splitlines()
                if re.search(r'(error|warning|notice):', line)]
    assert result.returncode == 0 and not problems, '\n'.join(problems) or result.stderr


def test_scripts_are_thin_entry_points():
    for script in (ROOT / 'scripts').glob('*.py'):
        code = [line for line in script.read_text().splitlines()
                if line.strip() and not line.startswith('#') and not line.startswith('"""')]
        assert len(code) == 2 and code[0].startswith('from battery_simulator.') and code[1] == 'main()', script
        assert script.stat().st_mode & 0o111, '%s is not executable' % script
