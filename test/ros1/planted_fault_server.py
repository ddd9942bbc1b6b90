#!/usr/bin/python3
"""battery_sim_server.py with a fault planted in its model (for rostest only).

On its first run the model's step raises RuntimeError after ~planted_after_updates
updates, as a model defect would inside the worker thread; the private parameter
~planted (kept across respawns, as ~saved_state is) makes a respawned server run
clean. The node must then end with one FATAL line, be respawned and resume.
"""
import rospy

from battery_simulator.ros1 import battery_sim
from battery_simulator.core.battery_model import BatteryModel

PLANTED_PARAM = '~planted'


def plant_fault(after_updates):
    clean_step = BatteryModel.step
    steps = {'timed': 0}

    def step(model, dt_s, *args, **kwargs):
        if dt_s > 0.0:
            steps['timed'] += 1
            if steps['timed'] == after_updates:
                rospy.set_param(PLANTED_PARAM, True)
                raise RuntimeError('planted fault at update %d' % after_updates)
        return clean_step(model, dt_s, *args, **kwargs)
    BatteryModel.step = step


def main():
    rospy.init_node('BatterySimServer', disable_signals=True)   # battery_sim.main() initialises again, alike
    if not rospy.get_param(PLANTED_PARAM, False):
        plant_fault(int(rospy.get_param('~planted_after_updates', 30)))
    battery_sim.main()


if __name__ == '__main__':
    main()
