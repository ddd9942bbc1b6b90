#!/usr/bin/env python3
"""Plants publishers and subscriptions for battery_doctor's tests, one node each, in one process.

    doctor_planted.py SPEC [SPEC ...]
    SPEC: pub|sub,node=NAME,ns=/robotN,topic=NAME,type=BatteryState|Twist|TwistStamped
          [,reliability=reliable|best_effort][,durability=volatile|transient_local][,depth=N]
          [,percentage=P,current=A,status=S,voltage=V]   (a BatteryState publisher's values, sent at 5 Hz)
          [,silent_after=N]   (a publisher that sends N messages, then nothing: it went silent)
    or    fleet,robots=N[,lag=S]   (one node publishing /robotK/battery_status and /robotK/battery_state, K < N,
                               at 1 Hz: a fleet host's battery topics, for the doctor at 100 robots; with
                               lag, robot K sends only from K x S seconds after a subscriber is there: a host
                               on a busy machine working through a doctor's new subscriptions one by one)
Several specs may name one node (three publishers sharing a node name: three nodes of that name).

Prints 'ready' once every endpoint exists; ends on SIGINT or SIGTERM. Run under tools/ros2.sh.
Endpoints of two types on one topic need two processes (one DDS participant takes one type a topic).
"""
import signal
import sys
import time

import rclpy
from geometry_msgs.msg import Twist, TwistStamped
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import BatteryState

TYPES = {'BatteryState': BatteryState, 'Twist': Twist, 'TwistStamped': TwistStamped}


def plant_fleet(robots, executor, keep, lag_s=0.0):
    node = rclpy.create_node('planted_fleet')
    executor.add_node(node)
    senders = []
    for k in range(robots):
        msg = BatteryState(percentage=0.5 + 0.004 * k, voltage=11.1, current=-1.0, present=True,
                           power_supply_status=BatteryState.POWER_SUPPLY_STATUS_DISCHARGING)
        for name in ('battery_status', 'battery_state'):
            senders.append((node.create_publisher(BatteryState, '/robot%d/%s' % (k, name), 10), msg, k * lag_s))
    if not lag_s:
        keep.append(node.create_timer(1.0, lambda: [publisher.publish(msg) for publisher, msg, _ in senders]))
        return
    subscribed_at = {}   # publisher -> monotonic time a subscriber was first there
    sent_at = {}

    def send_lagged():
        now = time.monotonic()
        for publisher, msg, lag in senders:
            if publisher not in subscribed_at and publisher.get_subscription_count() > 0:
                subscribed_at[publisher] = now
            if (publisher in subscribed_at and now - subscribed_at[publisher] >= lag
                    and now - sent_at.get(publisher, -1.0) >= 1.0):
                publisher.publish(msg)
                sent_at[publisher] = now
    keep.append(node.create_timer(0.05, send_lagged))


def plant(spec, executor, keep):
    role, *pairs = spec.split(',')
    fields = dict(pair.split('=', 1) for pair in pairs)
    if role == 'fleet':
        plant_fleet(int(fields['robots']), executor, keep, float(fields.get('lag', 0.0)))
        return
    node = rclpy.create_node(fields['node'], namespace=fields.get('ns', '/'))
    executor.add_node(node)
    msg_type = TYPES[fields['type']]
    qos = QoSProfile(depth=int(fields.get('depth', 10)),
                     reliability=(ReliabilityPolicy.BEST_EFFORT if fields.get('reliability') == 'best_effort'
                                  else ReliabilityPolicy.RELIABLE),
                     durability=(DurabilityPolicy.TRANSIENT_LOCAL if fields.get('durability') == 'transient_local'
                                 else DurabilityPolicy.VOLATILE))
    if role == 'sub':
        keep.append(node.create_subscription(msg_type, fields['topic'], lambda msg: None, qos))
        return
    publisher = node.create_publisher(msg_type, fields['topic'], qos)
    msg = msg_type()
    if msg_type is BatteryState:
        msg.percentage = float(fields.get('percentage', 0.5))
        msg.current = float(fields.get('current', -1.0))
        msg.power_supply_status = int(fields.get('status', BatteryState.POWER_SUPPLY_STATUS_DISCHARGING))
        msg.voltage = float(fields.get('voltage', 11.1))
        msg.present = True
    left = [int(fields.get('silent_after', -1))]

    def send():
        if left[0] != 0:
            publisher.publish(msg)
            left[0] -= 1
    keep.append(node.create_timer(0.2, send))


def main():
    rclpy.init(args=sys.argv[:1])
    signal.signal(signal.SIGTERM, lambda signum, frame: (_ for _ in ()).throw(KeyboardInterrupt()))
    executor = SingleThreadedExecutor()
    keep = []
    for spec in sys.argv[1:]:
        plant(spec, executor, keep)
    print('ready', flush=True)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
