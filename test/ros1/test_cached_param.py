"""ros1/cached_param.py without a master: a read of the master begun before this node's own set() of the
parameter never overwrites the value set (two CPU hogs: the charger contact's mode 1 was overwritten by a read
begun before it, the mode turned back for an update and a discharge goal aborted 'by the parameter')."""
import threading

from battery_simulator.ros1 import cached_param


def test_a_read_begun_before_a_set_does_not_overwrite_the_value_set(monkeypatch):
    master = {'value': 0}
    reading, answer = threading.Event(), threading.Event()
    monkeypatch.setattr(cached_param.rospy, 'resolve_name', lambda name: name)
    monkeypatch.setattr(cached_param.rospy, 'set_param', lambda name, value: master.update(value=value))
    param = cached_param.CachedParam('/MyRobot/BatteryStatus')
    param._subscribed = True   # no master to subscribe to

    def slow_master():
        value = master['value']   # read now ...
        reading.set()
        answer.wait(5.0)          # ... answered late
        return value
    monkeypatch.setattr(param, '_from_master', slow_master)
    worker = threading.Thread(target=lambda: results.append(param.get()))
    results = []
    worker.start()
    assert reading.wait(5.0)
    param.set(1)                  # the contact's mode, while the read is on its way
    answer.set()
    worker.join(5.0)
    assert len(results) == 1
    assert param.get() == 1, 'the stale read overwrote the value this node set'
