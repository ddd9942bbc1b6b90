"""What the package's command lines share (battery_replay, battery_plot, battery_fit): no ROS."""
import argparse


class OneLineParser(argparse.ArgumentParser):
    """A usage error is one line naming the argument and exit status 2 (argparse would print the usage block
    first)."""

    def error(self, message):
        self.exit(2, '%s: error: %s\n' % (self.prog, message))
