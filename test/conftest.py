"""The masterless pytest files (test/core, test/robot, test/cli, test/web, test/package, test/tools and
the ROS 1 adapters' in test/ros1). Under a sourced devel space the package (with its
generated messages) is importable already; from a plain checkout, use src/."""
import importlib.util
import sys
from pathlib import Path

if importlib.util.find_spec('battery_simulator') is None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'src'))
