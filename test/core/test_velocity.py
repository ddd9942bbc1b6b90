"""cmd_vel of either type (core/velocity.py): which one to take from the publishers' types."""
from types import SimpleNamespace

from battery_simulator.core.velocity import TWIST, TWIST_STAMPED, twist_of, type_name, velocity_type_to_take


def test_both_spellings_name_one_type():
    assert type_name('geometry_msgs/msg/TwistStamped') == TWIST_STAMPED
    assert type_name('geometry_msgs/Twist') == TWIST


def test_the_type_the_publishers_send_is_taken():
    assert velocity_type_to_take([]) == TWIST                                  # nobody publishes: Twist
    assert velocity_type_to_take(['geometry_msgs/msg/TwistStamped']) == TWIST_STAMPED   # Nav2 Kilted
    assert velocity_type_to_take(['geometry_msgs/msg/Twist']) == TWIST
    assert velocity_type_to_take([], current=TWIST_STAMPED) == TWIST_STAMPED   # publishers gone: keep it


def test_mixed_publishers_take_the_commoner_type_and_a_tie_keeps_the_present_one():
    two_stamped = ['geometry_msgs/msg/TwistStamped'] * 2 + ['geometry_msgs/msg/Twist']
    assert velocity_type_to_take(two_stamped) == TWIST_STAMPED
    tie = ['geometry_msgs/msg/TwistStamped', 'geometry_msgs/msg/Twist']
    assert velocity_type_to_take(tie, current=TWIST) == TWIST
    assert velocity_type_to_take(tie, current=TWIST_STAMPED) == TWIST_STAMPED
    assert velocity_type_to_take(['std_msgs/msg/String'], current=TWIST_STAMPED) == TWIST_STAMPED


def test_the_twist_of_either_message():
    twist = SimpleNamespace(linear=SimpleNamespace(x=0.5), angular=SimpleNamespace(z=0.1))
    assert twist_of(twist) is twist
    assert twist_of(SimpleNamespace(header=None, twist=twist)) is twist
