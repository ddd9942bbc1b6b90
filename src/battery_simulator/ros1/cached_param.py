"""A parameter followed through the master's pushes instead of read at every use.

``rospy.get_param`` is one master call; a fleet host reading each robot's mode
parameter at every update would keep the master busy (250 robots at 10 Hz: a
quarter of its core). Here the master pushes every change (rospy's parameter
subscription, as ``rospy.get_param_cached`` makes it) and the push only marks
the parameter changed: the value is then read once from the master itself.
The pushes come from the master's thread pool and can arrive out of order
(someone's ``set 0`` after this node's ``set 1``), so the master, which orders
the sets, has the last word; a pushed value is never taken as the value.
"""
import threading

import rosgraph
import rospy
from rospy.impl.paramserver import get_param_server_cache

_followed = {}              # resolved name -> [CachedParam]
_followed_lock = threading.Lock()


def _on_push(key, value):
    """rospy's parameter-cache notifier (called under its lock: only marks)."""
    key = key.rstrip('/')   # the master sends "/robot1/MyRobot/BatteryStatus/"
    for name, params in list(_followed.items()):
        if name == key or name.startswith(key + '/'):   # the parameter, or a namespace above it
            for param in params:
                param.changed = True


class CachedParam:
    """One parameter (a resolved name): ``get()`` costs a master call only after a change was pushed."""

    def __init__(self, name):
        self.name = rospy.resolve_name(name)
        self.changed = True     # read from the master at the next get()
        self._subscribed = False
        self._value = None
        self._sets = 0          # this node's own set() calls: a read begun before one of them is stale
        self._lock = threading.Lock()

    def get(self, default=None):
        """The value, or ``default`` while it is unset (ConnectionError/OSError: the master is gone)."""
        if not self._subscribed:
            self._subscribe()
        if self.changed:
            self.changed = False   # before reading: a push from now on marks it again
            with self._lock:
                sets_before = self._sets
            value = self._from_master()
            with self._lock:
                # a set() of this node while the master answered: the read may predate it (two CPU hogs: the
                # charger contact's 1 overwritten by a read begun before it, the mode turned back for an update
                # and a discharge goal aborted 'by the parameter'); the set's value stands, the push re-reads
                if self._sets == sets_before:
                    self._value = value
        with self._lock:
            value = self._value
        return default if value is None else value

    def set(self, value):
        """Set it on the master (the push of it then reads it back once)."""
        rospy.set_param(self.name, value)
        with self._lock:
            self._sets += 1
            self._value = value

    def _subscribe(self):
        with _followed_lock:
            _followed.setdefault(self.name, []).append(self)
            get_param_server_cache().set_notifier(_on_push)
        rospy.get_param_cached(self.name, None)   # subscribes: from now on the master pushes changes
        self._subscribed = True

    def _from_master(self):
        """The master's value (None: unset), never rospy's cache (rospy.get_param reads it once subscribed)."""
        try:
            return rosgraph.Master(rospy.get_name()).getParam(self.name)
        except rosgraph.MasterError:   # unset
            return None
