"""Command-line programs: the action client and the plotter."""
