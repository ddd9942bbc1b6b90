"""test/ros1 holds two kinds of file: the rostests' nodes (test_<x>.py beside <x>.test, executable, run by
rostest against a master) and masterless pytest files of the ROS 1 adapters (test_<module>.py, not
executable). pytest takes only the second kind: a rostest's node run without its master would fail."""
import os


def pytest_ignore_collect(collection_path):
    return collection_path.suffix == '.py' and os.access(collection_path, os.X_OK)
