"""``battery_sim_client`` (ROS 2): send a charge (1) or discharge (0) goal and show progress.

    ros2 run battery_simulator battery_sim_client 1|0|charge|discharge [--timeout S] [--ros-args ...]

The same command line and exit codes as battery_sim_client.py on ROS 1: 0 when
the goal succeeds; 1 when it is aborted or cancelled or the server goes away;
2 for bad arguments (no goal is sent); 3 when no action server answers within
--server-timeout; 4 on timeout (the goal is cancelled); 130 on Ctrl-C or SIGTERM
(the goal is cancelled first).
"""
import signal
import sys
import time

from battery_simulator.core import ros_names
from battery_simulator.cli.client_cli import goal_request
from battery_simulator.cli.interrupt import CANCEL_WAIT_S

STEP_S = 0.1
#: the end: rcl's teardown (milliseconds for this one node) bounded by this, then os._exit, as every node of the
#: package ends. The interpreter's own teardown after it took 0.25-0.45 s beside CPU hogs and other tests, and
#: with it a Ctrl-C still passed 2 s in a CI run beside two hogs (the cancel's wait already 0.5 s)
END_S = 0.5
#: no feedback (the server sends one at every update, 1-10 Hz) for this long, or the server gone from the graph:
#: the server is lost (a SIGKILL leaves its entities in the graph until DDS's lease ends, 20 s)
LOST_SERVER_S = 3.0


class _Stop(Exception):
    pass


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    ros_args = argv[argv.index('--ros-args'):] if '--ros-args' in argv else []
    ours = argv[:argv.index('--ros-args')] if ros_args else argv
    args = goal_request(ours)

    import rclpy
    from action_msgs.msg import GoalStatus
    from rclpy.action import ActionClient
    from rclpy.signals import SignalHandlerOptions
    from sensor_msgs.msg import BatteryState

    from battery_simulator.action import BatterySim
    from battery_simulator.cli.progress import ProgressPrinter
    from battery_simulator.ros2.qos import STATUS_QOS
    from battery_simulator.ros2.rcl_args import init_rclpy
    from battery_simulator.ros2.startup import end_process

    init_rclpy('battery_sim_client', ['battery_sim_client'] + ros_args, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node('battery_sim_client')
    client = ActionClient(node, BatterySim, 'battery_simulator')
    printer = ProgressPrinter(sys.stdout)
    heard = [time.monotonic()]

    def on_feedback(feedback):
        heard[0] = time.monotonic()
        printer.on_feedback(feedback.feedback.battery_percentage)
    node.create_subscription(BatteryState, ros_names.BATTERY_STATUS, lambda msg: setattr(printer, 'state', msg),
                             STATUS_QOS)
    charge = args.charge
    goal_handle = None
    code = 1

    def _stop(signum, frame):   # from here on a stop cancels the goal (before: ros2/__init__'s one line, exit 130)
        raise _Stop()
    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)
    try:
        if not client.wait_for_server(timeout_sec=args.server_timeout):
            print('battery_sim_client: no action server %s after %g s'
                  % (node.resolve_topic_name('battery_simulator'), args.server_timeout), file=sys.stderr)
            code = 3
            return
        print('%s the battery...' % ('Charging' if charge else 'Discharging'), flush=True)
        sent = client.send_goal_async(BatterySim.Goal(charge_state=charge),
                                      feedback_callback=on_feedback)
        while not sent.done():
            rclpy.spin_once(node, timeout_sec=STEP_S)
        goal_handle = sent.result()
        if not goal_handle.accepted:
            print('Result: (none) (rejected)')
            return
        result = goal_handle.get_result_async()
        deadline = time.monotonic() + args.timeout if args.timeout else None
        heard[0] = time.monotonic()
        while not result.done():
            rclpy.spin_once(node, timeout_sec=STEP_S)
            if not result.done() and (time.monotonic() - heard[0] >= LOST_SERVER_S or not client.server_is_ready()):
                goal_handle = None   # nobody to cancel it with
                print('\nbattery_sim_client: lost the action server %s while the goal was running (nothing from it '
                      'for %g s)' % (node.resolve_topic_name('battery_simulator'), LOST_SERVER_S), file=sys.stderr)
                code = 1
                return
            if deadline is not None and time.monotonic() >= deadline:
                _cancel(node, goal_handle)
                print('\ntimed out after %g s; goal cancelled' % args.timeout)
                code = 4
                return
        if sys.stdout.isatty():
            print()
        answer = result.result()
        state = {GoalStatus.STATUS_SUCCEEDED: 'succeeded', GoalStatus.STATUS_ABORTED: 'aborted',
                 GoalStatus.STATUS_CANCELED: 'cancelled'}.get(answer.status, 'status %d' % answer.status)
        print('Result: %s (%s)' % (answer.result.battery_status, state))
        code = 0 if answer.status == GoalStatus.STATUS_SUCCEEDED else 1
    except _Stop:
        if goal_handle is not None:
            _cancel(node, goal_handle)
        print('\ncancelled')
        code = 130
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        node.destroy_node()
        end_process(code, time.monotonic() + END_S)


def _cancel(node, goal_handle):
    import rclpy
    cancelled = goal_handle.cancel_goal_async()
    deadline = time.monotonic() + CANCEL_WAIT_S
    while not cancelled.done() and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=STEP_S)


if __name__ == "__main__":
    main()
