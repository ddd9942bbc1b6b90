"""A parameter followed through the master's pushes instead of read at every use.

``rospy.get_param`` is one master call; a fleet host reading each robot's mode
parameter at every update would keep the master busy (250 robots at 10 Hz: a
quarter of its core). Here the master pushes every change (rospy's parameter
cache, as ``rospy.get_param_cached`` subscribes) and the cache only tells that
something changed: the value is then read once from the master. The pushes
come from the master's thread pool and can arrive out of order (someone's
``set 0`` after this node's ``set 1``), so the master, which orders the sets,
has the last word; a push is never taken as the value.
"""
import threading

import rosgraph
import rospy
from rospy.impl.paramserver import get_param_server_cache


class CachedParam:
    """One parameter (a resolved name): ``get()`` costs a master call only after a change was pushed."""

    def __init__(self, name):
        self.name = rospy.resolve_name(name)
        self._lock = threading.Lock()
        self._subscribed = False
        self._pushed = None     # what the cache held when the value was last read from the master
        self._value = None

    def get(self, default=None):
        """The value, or ``default`` while it is unset (ConnectionError/OSError: the master is gone)."""
        with self._lock:
            if not self._subscribed:
                rospy.get_param_cached(self.name, None)   # subscribes: from now on the master pushes changes
                self._subscribed = True
                self._pushed = self._cached()
                self._value = self._from_master()
            elif self._cached() != self._pushed:
                self._value = self._from_master()   # the master's word, in order with every set
                self._pushed = self._value
                self._remember(self._value)
            return default if self._value is None else self._value

    def set(self, value):
        """Set it on the master (its push then reads it back once)."""
        rospy.set_param(self.name, value)
        with self._lock:
            self._value = value

    def _from_master(self):
        """The master's value (None: unset), never the cache (rospy.get_param reads the cache once subscribed)."""
        try:
            return rosgraph.Master(rospy.get_name()).getParam(self.name)
        except rosgraph.MasterError:   # unset
            return None

    def _cached(self):
        try:
            return get_param_server_cache().get(self.name)
        except KeyError:   # unset (or deleted)
            return None

    def _remember(self, value):
        """Put the master's value into the cache, so that a stale push is not read as a change again."""
        try:
            get_param_server_cache().update(self.name, {} if value is None else value)
        except KeyError:
            pass
