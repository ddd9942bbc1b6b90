"""A charge watched as a robot reads it, shared by the learning gauge's tests (test_learning_gauge.py, and
test_gauge_end_of_charge_presets.py on every preset). No ROS."""
from battery_simulator.core.battery_states import Mode, Status


def charge_watch(model, dt_s=1.0, stop_at_as=None):
    """Charge until the charger's Full and 200 s on (or until ``stop_at_as`` A*s went in): (the time 100 % first
    showed, the time the charger terminated, the highest percentage before 100 %, the charge put in A*s)."""
    model.set_mode(Mode.CHARGE)
    t = charged = 0.0
    hundred = terminated = None
    highest = 0.0
    while t < 40000.0:
        model.step(dt_s)
        t += dt_s
        charged += model.cell_current_a * model.params.cells_parallel * dt_s   # what the charge put in
        shown = model.gauge_reading()[0]
        if shown >= 100.0:
            hundred = t if hundred is None else hundred
        elif hundred is None:
            highest = max(highest, shown)
        if terminated is None and model.status is Status.FULL:
            terminated = t
        if stop_at_as is not None and charged >= stop_at_as:
            break
        if terminated is not None and t > terminated + 200.0:
            break
    return hundred, terminated, highest, charged
