"""The tests are laid out like the code (issue 41 item 4, docs/testing.md): a ROS-free test in the test/ folder
named after its src/battery_simulator/ folder, in test_<module>.py (or test_<module>_<aspect>.py, or
test_<folder>_<aspect>.py across the folder's modules); each rostest <x>.test in test/ros1/ beside its executable
node test_<x>.py (a <x>_fleet.test shares test_<x>.py), and every file a .test or .launch there names exists.
Read from the files, nothing imported."""
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TEST = ROOT / 'test'
PACKAGE = ROOT / 'src' / 'battery_simulator'
#: the ROS-free test folders that mirror a folder of src/battery_simulator/ (test/ros1 holds the ROS 1 adapters')
MIRRORED = ('core', 'robot', 'cli', 'web', 'ros1')
#: every folder test/ may hold (docs/testing.md's table)
FOLDERS = set(MIRRORED) | {'ros2', 'package', 'tools', 'workspace', 'netns', 'config', 'data'}
FIND = re.compile(r'\$\(find battery_simulator\)/([^"\s<]+)')
NODE = re.compile(r'<test\b[^>]*\btype="([^"]+)"')


def modules_of(folder):
    """The module names of src/battery_simulator/<folder>/ (a subpackage by its own name too: core/fit)."""
    names = set()
    for path in (PACKAGE / folder).rglob('*.py'):
        names.add(path.parent.name if path.name == '__init__.py' else path.stem)
    return names


def masterless_tests(folder):
    """The pytest files of test/<folder>/ (in test/ros1, those that are not a rostest's executable node)."""
    return sorted(p for p in (TEST / folder).glob('test_*.py') if not os.access(p, os.X_OK))


def test_test_holds_only_the_known_folders_and_no_loose_test_file():
    entries = {p.name for p in TEST.iterdir() if p.name != '__pycache__'}
    assert {p for p in entries if (TEST / p).is_dir()} <= FOLDERS, sorted(entries - FOLDERS)
    assert {p for p in entries if (TEST / p).is_file()} <= {'conftest.py'}, sorted(entries)


@pytest.mark.parametrize('folder', MIRRORED)
def test_each_ros_free_test_is_named_after_a_module_of_its_folder(folder):
    modules = modules_of(folder) | {folder}   # test_<folder>_<aspect>.py: across the folder's modules
    misnamed = [p.name for p in masterless_tests(folder)
                if not any(p.stem == 'test_' + m or p.stem.startswith('test_%s_' % m) for m in modules)]
    assert not misnamed, 'test/%s: %s are named after no module of src/battery_simulator/%s/' % (
        folder, misnamed, folder)


def test_each_tool_test_is_named_after_its_tool():
    tools = {p.stem for p in (ROOT / 'tools').glob('*.py')}
    assert all(p.stem[len('test_'):] in tools for p in masterless_tests('tools')), masterless_tests('tools')


def test_each_rostest_sits_beside_its_executable_node():
    rostests = sorted((TEST / 'ros1').glob('*.test'))
    assert len(rostests) >= 20, rostests
    for rostest in rostests:
        name = rostest.stem[:-len('_fleet')] if rostest.stem.endswith('_fleet') else rostest.stem
        node = TEST / 'ros1' / ('test_%s.py' % name)
        assert node.is_file() and os.access(node, os.X_OK), '%s has no executable %s beside it' % (
            rostest.name, node.name)


def test_every_node_and_file_a_rostest_names_is_in_the_tree():
    for path in sorted((TEST / 'ros1').glob('*.test')) + sorted((TEST / 'ros1').glob('*.launch')):
        text = path.read_text(encoding='utf-8')
        for named in FIND.findall(text):
            assert (ROOT / named).exists(), '%s names $(find battery_simulator)/%s' % (path.name, named)
        for node in NODE.findall(text):
            assert os.access(TEST / 'ros1' / node, os.X_OK), '%s runs %s: not an executable of test/ros1' % (
                path.name, node)
