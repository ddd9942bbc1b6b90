#!/usr/bin/python3
"""Plot what the robot read (battery_status, the fuel gauge) against the truth (battery_simulator/state's
true_percentage) from a rosbag of the demo, with its phases: tools/record_gauge_demo.sh writes it.

    tools/plot_gauge.py BAG -o PNG [--title TEXT]
"""
import argparse

import matplotlib
import rosbag

matplotlib.use('Agg')
from matplotlib import pyplot  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('bag')
    parser.add_argument('-o', '--output', required=True)
    parser.add_argument('--title', default='')
    args = parser.parse_args()
    read, truth, phases = [], [], []
    with rosbag.Bag(args.bag) as bag:
        for topic, msg, stamp in bag.read_messages():
            if topic.endswith('battery_status'):
                read.append((msg.header.stamp.to_sec(), 100.0 * msg.percentage))
            elif topic.endswith('battery_simulator/state'):
                truth.append((msg.battery.header.stamp.to_sec(), msg.true_percentage))
            elif topic.endswith('phase'):
                phases.append((stamp.to_sec(), msg.data))
    start = min(t for t, _ in read + truth)
    figure, axis = pyplot.subplots(figsize=(10, 4.5))
    axis.plot([(t - start) / 60.0 for t, _ in truth], [v for _, v in truth], color='tab:green', label='the truth')
    axis.plot([(t - start) / 60.0 for t, _ in read], [v for _, v in read], color='tab:purple', linestyle='--',
              label='what the robot read (fuel gauge)')
    for t, phase in phases:
        axis.axvline((t - start) / 60.0, color='grey', linestyle=':', linewidth=0.8)
        axis.annotate(' ' + phase, xy=((t - start) / 60.0, 0.97), xycoords=('data', 'axes fraction'), rotation=90,
                      fontsize=7, va='top', ha='right', color='dimgrey')
    axis.axhline(25.0, color='darkred', linewidth=0.6, linestyle='-.')
    axis.set_xlabel('ROS time (min)')
    axis.set_ylabel('charge (%)')
    axis.set_ylim(0, 102)
    axis.grid(alpha=0.3)
    axis.legend(loc='lower right', fontsize=8)
    figure.suptitle(args.title, fontsize=9)
    figure.tight_layout()
    figure.savefig(args.output, dpi=110)


if __name__ == '__main__':
    main()
