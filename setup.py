"""Installs the battery_simulator Python package (see catkin_python_setup)."""
from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import find_packages, setup

setup(**generate_distutils_setup(
    packages=find_packages('src'),   # every package under src/ (a list by hand left out battery_simulator.core.fit)
    package_data={'battery_simulator.web': ['static/*']},
    package_dir={'': 'src'},
))
