"""One update's state as the nodes publish it, ROS-free (core/battery.py's Battery makes one per update): the
sensor_msgs/BatteryState and BatterySimState fields, the noise of a measurement_noise fault, the gauge's
summary and the status it reports, and the consumers' conventions battery_status may be published with."""
import math
from collections import namedtuple

from battery_simulator.core.battery_states import Status
from battery_simulator.core.status_codes import (CHARGING_STATE, SUPPLY_HEALTH, SUPPLY_STATUS, TECHNOLOGY_LION,
                                                 SupplyStatus)


class BatteryRecord:
    """One update's state as the nodes publish it, ROS-free.

    The cheap fields a publisher reads at every update are attributes;
    ``battery_fields()`` (the sensor_msgs/BatteryState fields, noise drawn
    once) and ``sim_fields()`` (the rest of BatterySimState) are built at the
    first call: a fleet host updates hundreds of batteries ten times a second
    but publishes each once a second.
    """

    def __init__(self, snapshot, params, load_power_w=0.0, faults=frozenset(), noise=None, gauge=None):
        self.snapshot = snapshot
        self.params = params
        self.gauge = gauge if gauge is not None else GaugeSummary(0, False, snapshot.capacity_ah, None)
        self.percentage = snapshot.percentage / 100.0             # as BatteryState.percentage
        status = reported_status(snapshot.status, self.gauge.full)
        self.power_supply_status = SUPPLY_STATUS[status]
        self.charging_state = CHARGING_STATE[status]
        self.load_power_w = load_power_w
        self.faults = frozenset(faults)
        self.sensor_dropout = 'sensor_dropout' in self.faults
        self._noise = noise if 'measurement_noise' in self.faults else None
        self._battery = None

    def battery_fields(self):
        """sensor_msgs/BatteryState's fields (pack units: V, A, Ah, degC; percentage 0-1), header aside."""
        if self._battery is None:
            s, p = self.snapshot, self.params
            voltage, current = s.voltage_v, s.current_a
            cells = list(s.cell_voltages_v)
            if self._noise is not None:
                voltage = noisy_voltage(voltage, self._noise.gauss(0.0, p.voltage_noise_v))
                current = noisy_current(current, self._noise.gauss(0.0, p.current_noise_a),
                                        self.power_supply_status)
                cells = [cell * voltage / s.voltage_v for cell in cells] if s.voltage_v > 0.0 else cells
            self._battery = dict(
                voltage=voltage, temperature=s.temperature_c, current=current, charge=s.charge_ah,
                capacity=s.capacity_ah, design_capacity=s.design_capacity_ah, percentage=self.percentage,
                power_supply_status=self.power_supply_status, power_supply_health=SUPPLY_HEALTH[s.health],
                power_supply_technology=TECHNOLOGY_LION, present=True, cell_voltage=cells,
                cell_temperature=list(s.cell_temperatures_c), location=p.location,
                serial_number=p.serial_number)
        return self._battery

    def sim_fields(self):
        """battery_simulator/BatterySimState's fields besides ``battery`` (and the publish handshake)."""
        s = self.snapshot
        return dict(
            charging_state=self.charging_state,
            cut_off=s.cut_off.value if s.cut_off is not None else '',
            cycle_count=s.cycle_count,
            state_of_health=s.state_of_health,
            time_remaining_s=s.time_remaining_s if s.time_remaining_s is not None else math.nan,
            load_power_w=self.load_power_w,
            active_faults=sorted(self.faults),
            sensor_dropout=self.sensor_dropout,
            true_percentage=s.true_percentage,
            imbalance_warn_v=self.params.imbalance_warn_v,
            invert_current_sign=bool((self.params.conventions or {}).get('invert_current_sign', False)),
            percentage_scale=float((self.params.conventions or {}).get('percentage_scale', 1)),
            gauge_corrections=self.gauge.corrections,
            gauge_learned=self.gauge.learned,
            gauge_full_capacity_ah=self.gauge.full_capacity_ah,
        )


#: what the diagnostics and battery_simulator/state say of the gauge: the corrections larger than one point
#: so far, whether it has learned its capacity, the capacity it believes (Ah), and ``full``: None for a
#: gauge that calls the truth's Full full, else whether it has seen its own end of charge (Part 9)
GaugeSummary = namedtuple('GaugeSummary', 'corrections learned full_capacity_ah full')


def gauge_summary(model):
    """The GaugeSummary of ``model``'s gauge (an ideal gauge: none, the pack's capacity)."""
    gauge = model.gauge
    if gauge is None:
        return GaugeSummary(0, False, model.capacity_ah, None)
    return GaugeSummary(gauge.corrections, gauge.learned, gauge.capacity_as / 3600.0, gauge.full)


def reported_status(status, gauge_full):
    """The status battery_status shows: a gauge that watches its own end of charge (``gauge_full`` not None)
    says FULL at it, and CHARGING until it even when the charger has already stopped."""
    if gauge_full is None:
        return status
    if status is Status.CHARGING and gauge_full:
        return Status.FULL
    if status is Status.FULL and not gauge_full:
        return Status.CHARGING
    return status


def fill_fields(msg, fields):
    """Set a message's fields from a record's dict (the names are the messages', in ROS 1 and ROS 2)."""
    for name, value in fields.items():
        setattr(msg, name, value)
    return msg


def apply_conventions(current_a, percentage, conventions):
    """(current, percentage) as a driver with ``conventions`` (the config key) publishes them, for testing a
    consumer's robustness: the opposite current sign (Gazebo's invert_current_sign, firmware that counts
    charge negative) and 0-100 percentages. None or {} changes nothing. battery_status only: the record
    carries them (sim_fields) and core/status_rules.py applies them to what goes out."""
    if not conventions:
        return current_a, percentage
    if conventions.get('invert_current_sign', False):
        current_a = 0.0 - current_a   # 0.0 stays 0.0, not -0.0
    return current_a, percentage * conventions.get('percentage_scale', 1)


def noisy_voltage(voltage_v, noise_v):
    """A noisy voltage reading: never <= 0 or beyond twice the true value (sigma is bounded by the config)."""
    return min(max(voltage_v + noise_v, 0.5 * voltage_v), 2.0 * voltage_v)


def noisy_current(current_a, noise_a, power_supply_status):
    """A noisy current reading whose sign never contradicts the status (negative discharging, positive charging)."""
    noisy = current_a + noise_a
    if power_supply_status == SupplyStatus.DISCHARGING:
        return min(noisy, 0.0)
    if power_supply_status == SupplyStatus.CHARGING:
        return max(noisy, 0.0)
    return noisy
