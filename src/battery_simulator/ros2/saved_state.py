"""Where a ROS 2 battery keeps its state across a restart (ros1/saved_state.py's twin): its ``state_file``
(core/state_file.py StateFileKeeper: ROS 2 has no parameter server that outlives a node), or nothing.
Every keeper has ``load()`` (the saved state or None), ``where``, ``maybe_save(state)`` and ``save_now(state)``."""
from battery_simulator.core.state_file import StateFileKeeper


class NoStore:
    """No state file: nothing to resume, nothing kept (for one battery, or a fleet and each of its robots)."""

    where = None

    def load(self):
        return None

    def maybe_save(self, state):
        pass

    def save_now(self, state):
        pass

    def robot(self, name):
        """A fleet's store of one robot (core/state_file.py FleetStateFile.robot): nothing either."""
        return self

    def write_if_due(self, force=False):
        pass


def state_store(path, log):
    """The keeper of one battery's ``state_file`` (``log(text)`` reports a file that cannot be read or written),
    or a NoStore when it is empty."""
    return StateFileKeeper(path, log) if path else NoStore()
