"""Battery parameters, without ROS: every parameter with its unit in its name and its default
(BatteryParameters), and what follows from them (pack capacity, currents, power).

A pack is ``cells_series`` x ``cells_parallel`` identical cells. Cell values are
per cell; load and charger values are per pack, as a robot sees them. Their rules are
core/parameter_rules.py; reading them from YAML, a mapping or a preset is core/config_files.py.
"""
from dataclasses import dataclass, fields

from battery_simulator.core.parameter_rules import validate


@dataclass(frozen=True)
class BatteryParameters:
    """Every parameter of the battery model, with its unit in its name."""

    name: str = 'custom'
    #: cells in series (multiplies voltage and resistance)
    cells_series: int = 1
    #: strings in parallel (multiplies capacity and current, divides resistance)
    cells_parallel: int = 1
    #: cell capacity when new, Ah (charged CC-CV, discharged to cut-off)
    cell_capacity_ah: float = 2.78
    #: open-circuit voltage table: state of charge 0..1, strictly increasing
    ocv_soc: tuple = (0.0, 1.0)
    #: open-circuit voltage at each ``ocv_soc`` point, V per cell, increasing
    ocv_voltage_v: tuple = (2.8, 4.2)
    #: series (ohmic) resistance per cell at the reference temperature, ohm
    r0_ohm: float = 0.02
    #: RC-pair (polarisation) resistance per cell at the reference temperature, ohm
    r1_ohm: float = 0.015
    #: RC-pair time constant, s (with a fast pair beside it, this is the slow one: diffusion)
    tau1_s: float = 60.0
    #: a second, fast RC pair (charge transfer) per cell at the reference temperature, ohm (0 = none)
    r_fast_ohm: float = 0.0
    #: the fast RC pair's time constant, s
    tau_fast_s: float = 20.0
    #: the OCV is read at a surface state of charge that trails the bulk (counted) one under current
    #: (solid diffusion): settled, by this many seconds of the current, SOC = bulk - lag_s * I_discharge / Q
    #: (0 = none: the OCV at the bulk SOC)
    surface_soc_lag_s: float = 0.0
    #: the time constant with which the surface SOC's lag follows the current, s
    tau_surface_s: float = 300.0
    #: SOC grid (0..1, strictly increasing) of the resistance factor tables; empty: no SOC dependence
    resistance_soc: tuple = ()
    #: r0_ohm is multiplied by these factors at the ``resistance_soc`` points (linear between); empty = 1
    r0_soc_factor: tuple = ()
    #: r1_ohm is multiplied by these factors at the ``resistance_soc`` points; empty = 1
    r1_soc_factor: tuple = ()
    #: r_fast_ohm is multiplied by these factors at the ``resistance_soc`` points; empty = 1
    r_fast_soc_factor: tuple = ()
    #: while charging r0 is multiplied by this as well (the discharge direction is 1)
    r0_charge_factor: float = 1.0
    #: while charging r1 is multiplied by this as well
    r1_charge_factor: float = 1.0
    #: while charging r_fast is multiplied by this as well
    r_fast_charge_factor: float = 1.0
    #: open-circuit voltage of the charge branch at each ``ocv_soc`` point, V per cell, at or above
    #: ``ocv_voltage_v`` (then the discharge branch); empty: one OCV curve for both directions
    ocv_charge_voltage_v: tuple = ()
    #: charge per cell that moves the OCV 63 % of the way from one branch to the other, Ah
    hysteresis_ah: float = 0.1
    #: fraction of the charge put in that is stored, 0 < eta <= 1
    coulombic_efficiency: float = 0.999
    #: constant-voltage limit per cell, V (above the OCV table's start, at most 0.05 V above its top)
    cell_charge_voltage_v: float = 4.2
    #: discharge cut-off per cell, V (the load is disconnected there)
    cell_cutoff_voltage_v: float = 2.8
    #: charger constant current per pack, A
    charge_current_a: float = 1.5
    #: CV taper end per pack, A; None means C/20 of the pack's design capacity
    termination_current_a: float = None
    #: base discharge current per pack, A
    load_current_a: float = 1.5
    #: constant-power discharge load per pack, W (adds I = P / V)
    load_power_w: float = 0.0
    #: ambient temperature, degC
    ambient_temperature_c: float = 25.0
    #: temperature at start; None means ambient, degC
    initial_temperature_c: float = None
    #: heat capacity per cell, J/K
    cell_heat_capacity_j_per_k: float = 45.0
    #: heat transfer from a cell to ambient, W/K
    cell_heat_transfer_w_per_k: float = 0.06
    #: Arrhenius activation temperature Ea/R of the resistances, K (0 = none)
    arrhenius_temperature_k: float = 2800.0
    #: temperature at which r0_ohm and r1_ohm hold, degC
    reference_temperature_c: float = 25.0
    #: maximum continuous discharge current per cell (datasheet), A: the protection cuts the load off above it
    cell_max_discharge_current_a: float = 20.0
    #: maximum charge current per cell (datasheet), A: the protection cuts the charger off above it
    cell_max_charge_current_a: float = 4.0
    #: the pack protection disconnects load and charger at this cell temperature, degC
    protection_temperature_c: float = 75.0
    #: health OVERHEAT above this cell temperature, degC
    overheat_temperature_c: float = 60.0
    #: health COLD below this cell temperature, degC
    cold_temperature_c: float = 0.0
    #: capacity lost per equivalent full cycle, fraction of design capacity
    capacity_fade_per_cycle: float = 0.0002
    #: equivalent full cycles the pack has done at start
    initial_cycle_count: float = 0.0
    #: motion load: drive power per m/s of |cmd_vel.linear.x|, W/(m/s)
    drive_power_w_per_mps: float = 0.0
    #: motion load: turning power per rad/s of |cmd_vel.angular.z|, W/(rad/s)
    turn_power_w_per_radps: float = 0.0
    #: a cmd_vel older than this counts as standing still, s
    cmd_vel_timeout_s: float = 0.5
    #: measurement_noise fault: standard deviation of the reported voltage, V
    voltage_noise_v: float = 0.02
    #: measurement_noise fault: standard deviation of the reported current, A
    current_noise_a: float = 0.05
    #: BatteryState.location
    location: str = 'base'
    #: BatteryState.serial_number
    serial_number: str = ''
    #: where the numbers come from
    source: str = ''
    #: the cells' chemistry: 'li-ion' (NMC / NCA) or 'lfp'; a config naming 'lfp' without an OCV table of
    #: its own gets LFP's (core/lfp_tables.py)
    chemistry: str = 'li-ion'
    #: when a profile row's current flowed, for battery_replay (core/replay.py, PROFILE_TIMINGS):
    #: 'until_next_row' (from the row's time until the next row's) or 'since_previous_row' (measured at the
    #: row's instant, as a cycler or BatteryState logs it: it flowed since the previous row). battery_fit
    #: writes the one its log shows, so that the log's own current replays it
    profile_current_timing: str = 'until_next_row'
    #: a pack of differing cells (Part 5): relative standard deviation of the series groups' capacity and
    #: resistance, drawn with ``spread_seed`` (0: identical groups, the lumped model); below MAX_SPREAD
    capacity_spread: float = 0.0
    resistance_spread: float = 0.0
    spread_seed: int = 0
    #: or each group given: ({capacity_factor, resistance_factor, initial_soc_offset}, ...), cells_series long
    groups: tuple = ()
    #: passive balancing {current_a, start_voltage_v, threshold_v} (per group; None: no balancing)
    balancing: dict = None
    #: the diagnostics warn when the cell voltages differ by more than this, V
    imbalance_warn_v: float = 0.05
    #: the fuel gauge: None or {model: ideal} (the percentage is the truth) or {model: coulomb_counter,
    #: current_offset_a, current_gain_error, capacity_error, initial_error, deadband_a, recalibrate_at_full,
    #: recalibrate_at_empty}
    gauge: dict = None
    #: a full pack on the dock is held full (Part 7): once the charge has ended the connected charger tops
    #: up what the robot's own load draws (load_current_a, load_power_w, payloads, motion) as it draws it,
    #: so the pack stays at 100 % and battery_status shows that current as charge (status FULL), as docks
    #: that power the robot through its pack do (opennav_docking's SimpleChargingDock calls > 0.5 A
    #: charging). false: the charger switches off at Full and a full pack on the dock shows 0 A
    charger_holds_full: bool = True
    #: how a driver's BatteryState reads, to test a consumer against drivers that invert conventions:
    #: None or {invert_current_sign: false, percentage_scale: 1}; true / 100 give Gazebo's
    #: invert_current_sign and 0-100 percentages on battery_status (the model and battery_simulator/state
    #: keep the package's own conventions)
    conventions: dict = None

    def __post_init__(self):
        validate(self)

    @property
    def design_capacity_ah(self):
        """Pack capacity when new, Ah."""
        return self.cell_capacity_ah * self.cells_parallel

    @property
    def max_discharge_current_a(self):
        """The most current the pack may deliver (its cells' datasheet current), A."""
        return self.cell_max_discharge_current_a * self.cells_parallel

    @property
    def max_discharge_power_w(self):
        """The most power the pack can ever deliver, W: its datasheet current at its full voltage."""
        return (self.cell_max_discharge_current_a * self.cells_parallel
                * self.cell_charge_voltage_v * self.cells_series)

    def motion_power_w(self, speed_mps, turn_radps):
        """The motion load of a robot driving at ``speed_mps`` and turning at ``turn_radps`` (either sign), W."""
        return self.drive_power_w_per_mps * abs(speed_mps) + self.turn_power_w_per_radps * abs(turn_radps)

    @property
    def has_groups(self):
        """Whether the pack is modelled group by group (a spread, given groups or balancing)."""
        return bool(self.capacity_spread or self.resistance_spread or self.groups or self.balancing)

    @property
    def pack_termination_current_a(self):
        """The CV taper end per pack, A (C/20 unless set)."""
        if self.termination_current_a is None:
            return self.design_capacity_ah / 20.0
        return self.termination_current_a


#: every parameter's name, in the order of the dataclass
PARAMETER_NAMES = tuple(f.name for f in fields(BatteryParameters))
