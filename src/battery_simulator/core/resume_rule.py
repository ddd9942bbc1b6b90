"""Resuming a battery from a saved state, for any ROS (no ROS import): the one rule every front end's resume
follows (a respawned server, a state file, a fleet's robot), and the start-up lines that say where it resumed
from and that it is ready. The lines go to a core/battery_log.py BatteryLog."""


def resume_battery(battery, saved, where, log):
    """Resume ``battery`` (core/battery.py) from a saved state read from ``where``: where, or None when there is
    nothing saved or it does not fit (said in one line; the battery then starts as configured). Every front
    end's resume (a respawned server, a state file, a fleet's robot) is this one rule."""
    if saved is None:
        return None
    try:
        battery.resume(saved)
    except ValueError as error:
        log.warn('not resuming from %s: %s; starting at %.1f %%', where, error, battery.initial_percentage)
        return None
    return where


def say_ready(battery, log, resumed_from=None, resumed_only=False):
    """The start-up lines of one battery: where it resumed from (if it did), and ready (unless
    ``resumed_only``: a fleet host says ready once for every robot)."""
    snapshot = battery.snapshot_now()
    if resumed_from:
        log.info('battery_simulator resumed from %s: %.1f %%, %.2f cycles, state of health %.1f %%',
                 resumed_from, snapshot.percentage, snapshot.cycle_count, 100.0 * snapshot.state_of_health)
    if not resumed_only:
        log.info('battery_simulator ready: %s, %.1f %%, %s, %s', battery.params.name, snapshot.percentage,
                 snapshot.status.value, 'ROS time' if battery.sim_time else 'time x%g' % battery.time_scale)
