"""The demo's ``gauge`` choices (no ROS): the battery config each takes (in the package's config/) and how long
the robot rests on the dock once full. ros2/demo.py (battery_demo) and launch/demo.launch.py read them;
launch/demo.launch spells the same in its eval expressions.

- ``ideal``: the robot reads the truth (config/battery.yaml);
- ``realistic``: an aged pack of differing cells and a coulomb-counting gauge (battery_realistic.yaml);
- ``impedance_track`` / ``modelgauge``: an aged pack and a learning gauge, TI's or Analog Devices'
  (battery_impedance_track.yaml, battery_modelgauge.yaml; docs/gauge.md). The robot then rests on the
  dock once full, long enough for the gauge to read the rest (30 min for Impedance Track, 48 min for
  ModelGauge, plus the voltage settling).
"""
GAUGE_CONFIGS = {'ideal': 'battery.yaml', 'realistic': 'battery_realistic.yaml',
                 'impedance_track': 'battery_impedance_track.yaml', 'modelgauge': 'battery_modelgauge.yaml'}
#: seconds of ROS time on the dock once full, by gauge (0: undock at once)
REST_ON_DOCK_S = {'impedance_track': 2400.0, 'modelgauge': 3600.0}


def rest_on_dock_s(gauge):
    return REST_ON_DOCK_S.get(gauge, 0.0)
