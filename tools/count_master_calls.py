#!/usr/bin/python3
"""Counts the ROS master calls a fleet host makes at start-up, per robot (a developer tool).

    tools/count_master_calls.py      # needs the devel space sourced (tools/benchmark.sh does it)

Runs a host of 1 and then of 21 robots, each on a master of its own, with the
XML-RPC calls to the master counted by method, until the host is ready; the
difference divided by 20 is what one robot costs.
"""
import ast
import collections
import os
import socket
import subprocess
import sys
import time

COUNTING_HOST = r'''
import collections, xmlrpc.client
import rospy
counts = collections.Counter()
master = __import__('os').environ['ROS_MASTER_URI'].rstrip('/')
request = xmlrpc.client.ServerProxy._ServerProxy__request
def counted(self, name, params):
    if ('http://' + self._ServerProxy__host).rstrip('/') == master:
        counts[name] += 1
    return request(self, name, params)
xmlrpc.client.ServerProxy._ServerProxy__request = counted
from battery_simulator.ros1 import fleet_host
original_loginfo = rospy.loginfo
def loginfo(text, *args):
    original_loginfo(text, *args)
    if text.startswith('battery_fleet ready'):
        print(dict(counts), flush=True)
        rospy.signal_shutdown('counted')
rospy.loginfo = loginfo
fleet_host.main()
'''


def free_port():
    with socket.socket() as sock:
        sock.bind(('127.0.0.1', 0))
        return sock.getsockname()[1]


def count(robots):
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % port)
    master = subprocess.Popen(['rosmaster', '--core', '-p', str(port)], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        time.sleep(1.5)
        output = subprocess.run([sys.executable, '-c', COUNTING_HOST, '_robots:=%d' % robots], env=env,
                                capture_output=True, text=True, timeout=120).stdout
        line = [l for l in output.splitlines() if l.startswith('{')][-1]
        return collections.Counter(ast.literal_eval(line))
    finally:
        master.terminate()
        master.wait()


def main():
    one, many = count(1), count(21)
    per_robot = {name: (many[name] - one[name]) / 20.0 for name in sorted(set(one) | set(many))}
    print('master calls at start-up, per robot: %.1f' % sum(per_robot.values()))
    for name, calls in sorted(per_robot.items(), key=lambda item: -item[1]):
        if calls:
            print('  %-22s %.1f' % (name, calls))
    print('the host itself (1 robot): %d' % sum(one.values()))


if __name__ == '__main__':
    main()
