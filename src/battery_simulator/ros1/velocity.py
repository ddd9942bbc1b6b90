"""cmd_vel of either type on ROS 1 (core/velocity.py's rule; ros2/velocity.py's twin): rospy hands a
subscription of rospy.AnyMsg each message with its connection's type, so one subscriber takes Twist and
TwistStamped alike and decodes each as its publisher sent it."""
from geometry_msgs.msg import Twist, TwistStamped

from battery_simulator.core.velocity import TWIST, TWIST_STAMPED, twist_of

MESSAGE_CLASSES = {TWIST: Twist, TWIST_STAMPED: TwistStamped}


def velocity_of_any(raw):
    """The Twist or TwistStamped message of a velocity command received as rospy.AnyMsg (its connection's
    type says which); None for another type."""
    message_class = MESSAGE_CLASSES.get(raw._connection_header.get('type'))
    return None if message_class is None else message_class().deserialize(raw._buff)


def twist_of_any(raw):
    """The Twist of a cmd_vel received as rospy.AnyMsg (core/velocity.py); None for another type."""
    msg = velocity_of_any(raw)
    return None if msg is None else twist_of(msg)
