#!/usr/bin/python3
"""Plants publishers and subscribers for battery_doctor.py's rostest, all in one rospy node.

    doctor_planted.py NODE_NAME SPEC [SPEC ...]
    SPEC: pub|sub,topic=/ABS/NAME,type=BatteryState|Twist|TwistStamped[,percentage=P,current=A,status=S,voltage=V]
          [,silent_after=N][,lag=S]
    (a BatteryState publisher's values, sent at 5 Hz; silent_after: N messages, then nothing: it went silent;
    lag: nothing until S s after its first subscriber connected, as a busy fleet host serving new connections)

Sets /NODE_NAME/ready once every endpoint exists; ends on SIGINT or SIGTERM.
"""
import sys

import rospy
from geometry_msgs.msg import Twist, TwistStamped
from sensor_msgs.msg import BatteryState

TYPES = {'BatteryState': BatteryState, 'Twist': Twist, 'TwistStamped': TwistStamped}


def main():
    argv = rospy.myargv(sys.argv)
    rospy.init_node(argv[1])
    senders = []
    keep = []
    for spec in argv[2:]:
        role, *pairs = spec.split(',')
        fields = dict(pair.split('=', 1) for pair in pairs)
        msg_type = TYPES[fields['type']]
        if role == 'sub':
            keep.append(rospy.Subscriber(fields['topic'], msg_type, lambda msg: None))
            continue
        msg = msg_type()
        if msg_type is BatteryState:
            msg.percentage = float(fields.get('percentage', 0.5))
            msg.current = float(fields.get('current', -1.0))
            msg.power_supply_status = int(fields.get('status', BatteryState.POWER_SUPPLY_STATUS_DISCHARGING))
            msg.voltage = float(fields.get('voltage', 11.1))
            msg.present = True
        senders.append([rospy.Publisher(fields['topic'], msg_type, queue_size=10), msg,
                        int(fields.get('silent_after', -1)), float(fields.get('lag', 0.0)), None])
    rospy.set_param('~ready', True)
    rate = rospy.Rate(5)
    while not rospy.is_shutdown():
        now = rospy.get_time()
        for sender in senders:
            if sender[4] is None and sender[0].get_num_connections() > 0:
                sender[4] = now   # its first subscriber came
            if sender[3] and (sender[4] is None or now - sender[4] < sender[3]):
                continue
            if sender[2] != 0:
                sender[0].publish(sender[1])
                sender[2] -= 1
        try:
            rate.sleep()
        except rospy.ROSInterruptException:
            break


if __name__ == '__main__':
    main()
