"""Installs the battery_simulator Python package (see catkin_python_setup)."""
from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import setup

setup(**generate_distutils_setup(
    packages=['battery_simulator', 'battery_simulator.core', 'battery_simulator.battery',
              'battery_simulator.robot', 'battery_simulator.cli', 'battery_simulator.ros', 'battery_simulator.ros1',
              'battery_simulator.web'],
    package_data={'battery_simulator.web': ['static/*']},
    package_dir={'': 'src'},
))
