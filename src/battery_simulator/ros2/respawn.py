"""The ROS 2 launch files' respawn rule: ROS 1's ``respawn="true"`` less a process that failed at start-up.

launch_ros's ``respawn=True`` starts a process again whatever its exit status, so a bad argument
(``time_scale:=-1``) or a duplicate battery respawned for ever (six starts and ten fatal lines in 20 s). A
process that ends with the start-up exit status (2: its one fatal line said why) is not started again: the
launch ends with that line, as ROS 1's sim.launch does. Any other end (a crash, SIGKILL) respawns after
``delay_s``; nothing respawns while the launch itself is shutting down.
"""
from battery_simulator.core.node_settings import EXIT_STARTUP_ERROR   # a bad start-up value or a duplicate battery

RESPAWN, END_LAUNCH, NOTHING = 'respawn', 'end the launch', 'nothing'


def after_exit(returncode, launch_shutting_down):
    """What the launch does when its process ends with ``returncode``: RESPAWN, END_LAUNCH or NOTHING."""
    if launch_shutting_down:
        return NOTHING
    if returncode == EXIT_STARTUP_ERROR:
        return END_LAUNCH
    return RESPAWN


def respawning_node(delay_s=1.0, **node_arguments):
    """[launch_ros Node(**node_arguments), its OnProcessExit handler]: the node comes back ``delay_s`` after it
    ends (a new Node action of the same arguments), except after a start-up error, which ends the launch."""
    from launch.actions import RegisterEventHandler, Shutdown, TimerAction
    from launch.event_handlers import OnProcessExit
    from launch_ros.actions import Node

    node = Node(**node_arguments)

    def on_exit(event, context):
        what = after_exit(event.returncode, bool(getattr(context, 'is_shutdown', False)))
        if what == RESPAWN:
            return [TimerAction(period=delay_s, actions=respawning_node(delay_s, **node_arguments))]
        if what == END_LAUNCH:
            return [Shutdown(reason='%s ended at start-up (exit %d, its line above says why): not respawned' % (
                node_arguments.get('executable'), EXIT_STARTUP_ERROR))]
        return None
    return [node, RegisterEventHandler(OnProcessExit(target_action=node, on_exit=on_exit))]
