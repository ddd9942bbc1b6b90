"""The pack's shared states (no rospy): what it is asked to do (Mode), what it does (Status), why its
protection cut it off (CutOff), its health (Health) and a consistent picture of it (Snapshot). Every layer
reads these; the physics that moves between them is core/battery_model.py."""
import enum
from collections import namedtuple


class Mode(enum.Enum):
    """What the pack is asked to do."""

    IDLE = 'idle'            # no charger, no load: the level holds
    CHARGE = 'charge'        # charger connected: CC-CV
    DISCHARGE = 'discharge'  # load connected


class Status(enum.Enum):
    """What the pack is doing (mapped to BatteryState.power_supply_status)."""

    NOT_CHARGING = 'not charging'
    CHARGING = 'charging'
    DISCHARGING = 'discharging'
    FULL = 'full'    # CV taper ended: the charger is off
    EMPTY = 'empty'  # cut-off reached: the load is disconnected


class CutOff(enum.Enum):
    """Why the pack protection has disconnected the load or the charger."""

    UNDER_VOLTAGE = 'cut-off voltage reached'
    OVER_CURRENT = 'over-current'
    POWER_LIMIT = 'constant-power load beyond what the pack can deliver'
    OVER_TEMPERATURE = 'over-temperature'



class Health(enum.Enum):
    """Mapped to BatteryState.power_supply_health."""

    GOOD = 'good'
    OVERHEAT = 'overheat'
    COLD = 'cold'


#: A consistent picture of the pack at one instant, in pack units.
#: ``percentage``, ``charge_ah`` and ``capacity_ah`` are the fuel gauge's view (what a robot reads: the
#: truth with an ideal gauge); ``true_percentage`` is the truth. ``cell_voltage_v`` is the mean cell,
#: ``cell_voltages_v`` and ``cell_temperatures_c`` one per series group.
Snapshot = namedtuple('Snapshot', (
    'percentage', 'voltage_v', 'current_a', 'temperature_c', 'charge_ah',
    'capacity_ah', 'design_capacity_ah', 'cell_voltage_v', 'mode', 'status',
    'health', 'cycle_count', 'state_of_health', 'cut_off', 'time_remaining_s', 'charger_fault',
    'true_percentage', 'cell_voltages_v', 'cell_temperatures_c'))

