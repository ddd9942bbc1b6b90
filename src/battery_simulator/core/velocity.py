"""cmd_vel of either type, for both front ends (no ROS import).

Nav2 publishes ``geometry_msgs/TwistStamped`` on ``cmd_vel`` since Kilted
(``enable_stamped_cmd_vel: true`` in its controller server, velocity smoother
and docking server); most other stacks, and Nav2 before, publish ``Twist``.
The battery and the robot's loop take whichever the graph publishes, with no
parameter: on ROS 1 from each connection's type, on ROS 2 (where one process
holds one type per topic name) from the types of the topic's publishers.
"""
TWIST = 'geometry_msgs/Twist'
TWIST_STAMPED = 'geometry_msgs/TwistStamped'
VELOCITY_TYPES = (TWIST, TWIST_STAMPED)


def type_name(ros_type):
    """'geometry_msgs/msg/Twist' (ROS 2) or 'geometry_msgs/Twist' (ROS 1) -> 'geometry_msgs/Twist'."""
    return ros_type.replace('/msg/', '/')


def velocity_type_to_take(publisher_types, current=TWIST):
    """The cmd_vel type to subscribe, given its publishers' types (either spelling): the one they publish,
    the type already taken while they agree or while none publishes, the commoner one when they differ (a
    tie keeps ``current``)."""
    counts = {kind: 0 for kind in VELOCITY_TYPES}
    for ros_type in publisher_types:
        kind = type_name(ros_type)
        if kind in counts:
            counts[kind] += 1
    if counts[TWIST] == counts[TWIST_STAMPED]:
        return current
    return TWIST if counts[TWIST] > counts[TWIST_STAMPED] else TWIST_STAMPED


def twist_of(msg):
    """The Twist of a Twist or a TwistStamped message (anything with ``.twist`` is stamped)."""
    return getattr(msg, 'twist', msg)
