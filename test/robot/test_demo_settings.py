"""The demo's settings live once, in robot/demo_settings.py (issue 41): battery_demo takes them, demo.launch.py
reads its defaults from them, and demo.launch (roslaunch XML, which cannot import Python) spells the same."""
import re
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest

from battery_simulator.robot import demo_settings

LAUNCH = Path(__file__).resolve().parents[2] / 'launch'
#: demo.launch's arguments that are the demo's settings (the rest: the dashboard, sim.launch's own)
NAMES = [s.name for s in demo_settings.SETTINGS if s.name != 'config']   # demo.launch's config is an eval by gauge


def ros1_defaults():
    root = ElementTree.parse(LAUNCH / 'demo.launch').getroot()
    return {arg.get('name'): arg.get('default') for arg in root.findall('arg')}


@pytest.mark.parametrize('name', NAMES)
def test_demo_launch_has_the_demo_settings_defaults(name):
    given, wanted = ros1_defaults()[name], demo_settings.default(name)
    assert (float(given) if isinstance(wanted, float) else given) == wanted, \
        'demo.launch %s default %s, robot/demo_settings.py %r' % (name, given, wanted)


@pytest.mark.parametrize('name', [s.name for s in demo_settings.SETTINGS])
def test_demo_launch_py_reads_its_defaults_from_robot(name):
    assert "launch_default('%s')" % name in (LAUNCH / 'demo.launch.py').read_text(), \
        'demo.launch.py spells its own %s default' % name


def test_one_tick_rate_for_every_demo():
    assert demo_settings.default('tick_hz') == 250.0
    assert ros1_defaults()['tick_hz'] == '250'


def test_the_ros2_demo_takes_them():
    demo = (Path(demo_settings.__file__).parents[1] / 'ros2' / 'demo.py').read_text()
    assert re.search(r'from battery_simulator\.robot\.demo_settings import [\w, ]*\bSETTINGS\b', demo)
    assert 'Setting(' not in demo, 'battery_demo declares a setting of its own'


def test_demo_launch_paces_its_clock_on_the_robots_commands():
    """demo.launch's sim_clock waits at every tick for the topics of CLOCK_PACE_ON, as battery_demo's and
    demo.launch.py's clocks (issue 40 items 8 and 15)."""
    root = ElementTree.parse(LAUNCH / 'demo.launch').getroot()
    sim = next(include for include in root.findall('include') if 'sim.launch' in include.get('file'))
    pace_on = {arg.get('name'): arg.get('value') for arg in sim.findall('arg')}['clock_pace_on']
    assert [topic.strip() for topic in pace_on.strip('[]').split(',')] == list(demo_settings.CLOCK_PACE_ON)
