"""The battery_simulator action server node (BatterySimServer in sim.launch).

It owns the one battery model. A worker thread steps it at ``~update_rate``,
following the mode parameter ``MyRobot/BatteryStatus`` at every step, takes
and ends the goals of the action ``battery_simulator`` (Full when charging,
Empty when discharging, preempted, or aborted when the mode turns against
them), and publishes the model's state for battery_state_pub. The charger
contact, the motion and payload loads, the test controls and the faults all
act on the model through the same lock.

:ROS Parameters:
  - ``~config`` (str): YAML battery config: a ``preset`` plus overrides
    (default: the package's config/battery.yaml)
  - ``~time_scale`` (float > 0): simulated seconds per wall second (default 22;
    ignored under /use_sim_time, where ROS time drives the model); live-tunable
  - ``~update_rate`` (float, Hz, 0 < r <= 1000): model updates per second (default 10)
  - ``~initial_percentage`` (float, 0..100): charge at start (default 100)
  - ``~charging`` (bool): written to MyRobot/BatteryStatus at start (default false)
  - ``~state_file`` (str): optional JSON file the state is saved to and resumed from
  - ``~saved_state`` (dict): written by the node; a respawned node resumes from it
  - ``MyRobot/BatteryStatus`` (1/true charge, 0/false discharge, unset hold)
  - dynamic_reconfigure (cfg/BatterySim.cfg): ``time_scale``, ``load_current_a``,
    ``load_power_w``, ``charge_current_a``, ``ambient_temperature_c``,
    ``drive_power_w_per_mps``, ``turn_power_w_per_radps``

:Subscribes:
  - ``cmd_vel`` (geometry_msgs/Twist or TwistStamped, as each publisher sends it): motion load while
    discharging
  - ``charger_contact`` (std_msgs/Bool): a change connects (true) or disconnects the charger
  - ``battery_simulator/status_sent`` (std_msgs/UInt64): battery_state_pub has sent a service's change

:Publishes:
  - ``battery_simulator/state`` (battery_simulator/BatterySimState, latched): after every update

:Services:
  - ``battery_simulator/set_load``, ``set_charging``, ``set_state``, ``reset``, ``inject_fault``, ``predict``
    (ros1/services.py). Each but predict replies once battery_state_pub has sent the state it changed on
    battery_status (publish_now, acknowledged on status_sent), so the next battery_status shows the change.
"""
import threading
from contextlib import contextmanager

import actionlib
import rospy
from std_msgs.msg import Bool, UInt64

from battery_simulator.core import ros_names
from battery_simulator.core.battery import UNREADABLE, Goal, GoalEnd
from battery_simulator.core.battery_states import Mode
from battery_simulator.core.resume_rule import resume_battery, say_ready
from battery_simulator.core.server_log import SHUTDOWN_TEXT, ServerLog
from battery_simulator.msg import BatterySimState, battery_simAction, battery_simFeedback, battery_simResult
from battery_simulator.ros1.cached_param import CachedParam
from battery_simulator.ros1.log import RobotLog
from battery_simulator.ros1.messages import STATE_QUEUE_SIZE, SimState
from battery_simulator.ros1.services import BatteryServices
from battery_simulator.ros1.startup import clock_publishers
from battery_simulator.ros1.velocity import twist_of_any

SERVICE_PUBLISH_WAIT_S = 1.0   # a service's reply waits this long (wall) for its change to be published


class BatterySimServer:
    """One battery's rospy front end: the action, the services, the inputs, the state topic.

    The battery's behaviour is the ROS-free ``self.battery`` (core/battery.py);
    this class turns ROS inputs into its calls and its records into messages.

    Lock order: ``self.battery.lock`` (a Condition) guards the battery and the
    publication bookkeeping here; it is taken last and held briefly (a service
    waiting for its change to go out releases it in Condition.wait_for). Goals
    are taken, fed and ended only by the worker thread, never while it holds
    that lock, so actionlib's own locks are always taken first.
    """

    def __init__(self, namespace, node_name, battery, store, loop, status_timer, log=None):
        """``battery`` (core/battery.py, built by ros1/battery_settings.py ros_battery) whose names live under
        ``namespace`` ('/', '/robot3/'); ``node_name`` is where its dynamic_reconfigure lives (its node, or
        '/robot3/BatterySimServer' in a fleet host); ``store`` keeps its saved state (ros1/saved_state.py);
        ``loop`` (UpdateLoop) steps it; ``status_timer`` publishes its goal status."""
        self._ns = namespace
        self._node_name = node_name
        self._log = log or RobotLog()
        self._lines = ServerLog(self._log)
        self._mode_param = CachedParam(namespace + ros_names.MODE_PARAM)
        self.battery = battery
        self._lock = self.battery.lock
        self._loop = loop
        self._status_timer = status_timer
        self._updates = 0                  # model updates taken for publishing (worker)
        self._urgent_update = 0            # the update a service asked for: battery_status shows it at once
        self._published_update = 0         # the last update published on battery_simulator/state
        self._sent_update = 0              # the last publish_now update battery_state_pub has sent on
        self._stopping = threading.Event()
        self._goal = None                  # core Goal, worker thread only
        self._store = store
        self._state_listeners = []         # in-process battery_state_pub logic (a fleet host): called per update
        self._sent_sub = None              # battery_state_pub's acknowledgements, when it is another process

        resumed_from = self._resume()
        if resumed_from is None:   # the start-up mode (the battery's) is the parameter's
            self._mode_param.set(1 if battery.mode is Mode.CHARGE else 0)
        self.battery.follow_mode_value(self._read_mode_param())
        self._resumed_from = resumed_from

        self._latest_state = None
        # a subscriber gets the latest state when it connects (as a latched topic, without building
        # and serializing a message at every update while nobody listens); every update reaches it
        self._state_pub = rospy.Publisher(namespace + ros_names.STATE_TOPIC, BatterySimState,
                                          queue_size=STATE_QUEUE_SIZE,
                                          subscriber_listener=_LatestStateOnConnect(self))
        self._server = actionlib.SimpleActionServer(namespace + ros_names.ACTION, battery_simAction, auto_start=False)
        self._server.register_goal_callback(self._wake_up)
        self._server.register_preempt_callback(self._wake_up)
        loop.add(self)

    @property
    def params(self):
        return self.battery.params

    @property
    def model(self):
        return self.battery.model

    def add_state_listener(self, listener):
        """Call ``listener(SimState)`` after every update, in the worker thread (an in-process publisher)."""
        self._state_listeners.append(listener)

    def _resume(self):
        """Resume a saved state (after a respawn, or from ~state_file); where from, or None."""
        saved = self._store.load()
        return resume_battery(self.battery, saved, self._store.where, self._log)

    def start(self):
        ns = self._ns
        self._subscribers = [rospy.Subscriber(ns + ros_names.CMD_VEL, rospy.AnyMsg, self._on_cmd_vel, queue_size=1),
                             rospy.Subscriber(ns + ros_names.CHARGER_CONTACT, Bool, self._on_contact, queue_size=10)]
        if not self._state_listeners:   # battery_state_pub is another process: it acknowledges on a topic
            self._sent_sub = rospy.Subscriber(ns + ros_names.STATUS_SENT, UInt64,
                                              lambda msg: self.on_status_sent(msg.data), queue_size=10)
        self._services = BatteryServices(self, ns, self._node_name, self._log)
        self._publish_state(self.battery.record())
        self._server.start()
        self._status_timer.add(self._server)
        self._services.start_live_settings()

    def report_ready(self, resumed_only=False):
        """The start-up lines (after /rosout listens): resumed, and ready unless ``resumed_only``."""
        say_ready(self.battery, self._log, self._resumed_from, resumed_only)

    def _wake_up(self):
        """Update and publish now (callers may hold the battery's lock: the loop's lock is taken after it)."""
        self._loop.wake(self)

    @contextmanager
    def service_change(self):
        """Hold the battery's lock around a service's change. The model is first stepped to now; after the
        change the next update carries it and battery_state_pub sends it on battery_status at once.
        Waits (bounded) until it has, so the caller's reply comes after that battery_status (without
        a battery_state_pub to acknowledge, until the state is published). A change that raises
        (refused) is not waited for."""
        with self._lock:
            self.battery.advance_to_now()
            yield
            wanted = self._updates + 1
            self._urgent_update = wanted
            acknowledged = bool(self._state_listeners) or (
                self._sent_sub is not None and self._sent_sub.get_num_connections() > 0)
            self._wake_up()
            self._lock.wait_for(lambda: self._stopping.is_set() or (
                self._published_update >= wanted and (not acknowledged or self._sent_update >= wanted)),
                SERVICE_PUBLISH_WAIT_S)

    def on_status_sent(self, update):
        """battery_state_pub has sent publish_now ``update`` on battery_status (a waiting service may reply)."""
        with self._lock:
            self._sent_update = max(self._sent_update, update)
            self._lock.notify_all()

    # -- the worker thread ----------------------------------------------------

    def run_once(self):
        """One turn of the worker (UpdateLoop): take goals, update; False once rospy shuts down."""
        try:
            self._take_goals()
            self._update()
        except rospy.ROSException as error:   # a topic closed under us: only at shutdown
            if rospy.is_shutdown():
                return False
            self._log.error_throttle(10.0, 'battery update failed: %s', error)
        return True

    def finish(self):
        """At shutdown (the worker): preempt the active goal and save the state."""
        self._stopping.set()
        with self._lock:
            self._lock.notify_all()
        state = self.battery.export_state()
        try:
            self._preempt(SHUTDOWN_TEXT)
        except rospy.ROSException:
            pass   # too late: rospy has closed the action's topics
        self._store.save_now(state)

    def _update(self):
        """One model update: follow the mode, step, publish, check the goal."""
        generation = self.battery.mode_generation
        mode_value = self._read_mode_param()
        with self._lock:   # one step with its number: a service's change is in the update it waits for
            update = self.battery.update(mode_value, generation)
            self._updates += 1
            number, urgent = self._updates, self._updates == self._urgent_update
        if update.time_jump is not None:
            self._lines.time_jump(update, self.battery.max_time_jump, clock_publishers())
        self._publish_state(update.record, publish_now=urgent, update=number)
        with self._lock:
            self._published_update = number
            self._lock.notify_all()
        self._store.maybe_save(update.saved_state)
        self._lines.progress(update.snapshot)
        self._lines.settle()
        self._check_goal(update.snapshot)

    def _read_mode_param(self):
        try:
            return self._mode_param.get()
        except (ConnectionError, OSError) as error:  # master gone: keep the mode
            self._log.warn_throttle(10.0, 'cannot read %s: %s', self._mode_param.name, error)
            return UNREADABLE

    def _set_mode(self, mode, source):
        """Set the mode and the parameter together (a goal, the charger contact, set_charging)."""
        with self._lock:
            self._mode_param.set(1 if mode is Mode.CHARGE else 0)
            self.battery.set_mode(mode, source)
            self._wake_up()

    def _publish_state(self, record, publish_now=False, update=0):
        """Hand this update's record to battery_state_pub: on the state topic while someone subscribes,
        and to the in-process listeners (its message is built only if one of them needs it)."""
        state = SimState(record, rospy.Time.now(), publish_now, update)
        self._latest_state = state
        if self._state_pub.get_num_connections() > 0:
            self._state_pub.publish(state.message())
        for listener in self._state_listeners:
            listener(state)

    # -- goals (worker thread) ---------------------------------------------------

    def _take_goals(self):
        """Accept a new goal (preempting the active one) or act on a cancel. The preempt flag is read first:
        actionlib sets ``new_goal`` before ``preempt_request``, so a new goal's preempt is never a cancel."""
        preempt_requested = self._server.is_preempt_requested()
        if self._server.is_new_goal_available():
            self._preempt('a new goal')
            goal = self._server.accept_new_goal()
            if goal is None:
                return
            self._goal = Goal(goal.charge_state)
            self._set_mode(self._goal.mode, 'goal')
            snapshot = self.battery.snapshot_now()
            self._lines.goal_started(self._goal.mode, snapshot.percentage)
            # cancelled before it was accepted; a preempt with a newer goal waiting is that goal's (it came while
            # this one was being set up: two CPU hogs, a new goal's preempt read as a cancel), taken next turn
            if self._server.is_preempt_requested() and not self._server.is_new_goal_available():
                self._preempt('cancel')
            else:
                self._check_goal(snapshot)
        elif self._goal is not None and preempt_requested:
            self._preempt('cancel')

    def _check_goal(self, snapshot):
        """Feedback for the active goal, and its end if it has reached one."""
        if self._goal is None:
            return
        self._server.publish_feedback(battery_simFeedback(battery_percentage=snapshot.percentage))
        end = self.battery.goal_end(self._goal, snapshot)
        if end is not None:
            self._finish(end)

    def _preempt(self, reason):
        """Preempt the active goal, if any, saying why and at what level."""
        if self._goal is not None:
            self._finish(self.battery.preempted(reason))

    def _finish(self, end):
        self._goal = None
        set_state = {GoalEnd.SUCCEEDED: self._server.set_succeeded, GoalEnd.ABORTED: self._server.set_aborted,
                     GoalEnd.PREEMPTED: self._server.set_preempted}[end.outcome]
        set_state(battery_simResult(battery_status=end.text), end.text)
        self._lines.goal_ended(end)

    # -- inputs (subscriber and service threads) ---------------------------------

    def _on_cmd_vel(self, raw):
        """A cmd_vel of either type (core/velocity.py): its connection says which."""
        twist = twist_of_any(raw)
        if twist is None:
            self._lines.input_error('%s: type %s ignored (Twist or TwistStamped)', self._ns + ros_names.CMD_VEL,
                                    raw._connection_header.get('type'))
            return
        self.battery.take_cmd_vel(twist)

    def _on_contact(self, msg):
        self.change_contact(bool(msg.data), 'charger contact')

    def change_contact(self, connected, source):
        """Only a change acts: connected -> charge, disconnected -> discharge (the parameter follows)."""
        with self._lock:
            changed = self.battery.change_contact(connected, source)
            if changed:
                self._mode_param.set(1 if connected else 0)
                self._wake_up()
        if changed:
            self._lines.charger(connected, source)


class _LatestStateOnConnect(rospy.SubscribeListener):
    def __init__(self, server):
        super().__init__()
        self._server = server

    def peer_subscribe(self, topic_name, topic_publish, peer_publish):
        state = self._server._latest_state
        if state is not None:
            peer_publish(state.message())
