"""The OCV tables of an LFP (LiFePO4) cell, the chemistry ``lfp`` (config key ``chemistry``; no ROS).

LFP's open-circuit voltage is flat (about 3.2-3.35 V over most of its range) and its charge branch lies
clearly above the discharge branch (hysteresis); its cut-off is 2.0 V and its charge voltage 3.6 V. A
config that says ``chemistry: lfp`` and gives no OCV table of its own gets these (the model is unchanged:
it reads whatever tables the parameters hold).

The discharge branch: the voltage at the end of the 57 s rests of the DST test of an A123 APR18650M1A cell
at 20 degC (its SOC counted from the CC-CV charge's end over the 1.04 Ah it then delivered to 2.0 V), the
last ~20 mV of relaxation added at mid range; the ends (below 4 % and above 96 % SOC) from the same log's
1C discharge to 2.0 V and its CC-CV charge to 3.6 V. The charge branch: the discharge branch plus the
hysteresis the same cell's 1C charge shows at mid range, and above 90 % SOC what its CC-CV taper holds: the
3.601 V the cell keeps while its current falls from 0.8 to 0.09 A, less the drop of this preset's circuit
(a123_lfp_cell.yaml: R0, R1 / tau1, R_fast / tau_fast), lies 0.117, 0.150 and 0.133 V above the discharge
branch at 95, 97 and 99 % (the same cell's US06 and FUDS tapers: 0.08, 0.12, 0.12). Carried down from mid
range as 0.025, 0.02, 0.01 V, the model's taper sat up to 130 mV below the cell and its replayed charges
stopped short of full. Data: CALCE Battery Research Group, University
of Maryland (A123 dynamic tests, test/data/measured/); cite Zheng et al. (2016) Applied Energy 183,
513-525 and Xing et al. (2014) Applied Energy 113, 106-115.
"""

#: the config key's values; 'li-ion' (NMC / NCA, the default) keeps the tables of the preset or config
CHEMISTRIES = ('li-ion', 'lfp')

#: The table as measured, over the charge from a dynamic cycle's cut-off (SOC 0 there, 2.0 V under load) to
#: the CC-CV charge's end (SOC 1).
_MEASURED_SOC = (0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.08, 0.1, 0.125, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4,
                 0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 0.97, 0.99, 1.0)
_MEASURED_VOLTAGE_V = (2.00, 2.80, 2.93, 3.02, 3.07, 3.10, 3.13, 3.17, 3.19, 3.20, 3.21, 3.23, 3.245, 3.257,
                       3.267, 3.275, 3.281, 3.286, 3.290, 3.293, 3.298, 3.307, 3.318, 3.326, 3.332, 3.337,
                       3.347, 3.360, 3.420, 3.600)
_MEASURED_GAP_V = (0.0, 0.02, 0.03, 0.035, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04,
                   0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04, 0.035, 0.03, 0.03, 0.03, 0.117, 0.150, 0.133, 0.0)
#: A cut-off under load is not empty: the cell's voltage relaxes from 2.0 V to 2.59 V within 2 minutes of the
#: 1C discharge's cut-off and to 2.70 V within 5 minutes of the DST's (2.60 V after FUDS's), and the cycles
#: that end at lighter loads or after rests give more charge from full (1C 1.038 Ah, US06 1.040, DST 1.042,
#: FUDS 1.051). So the table's SOC 0 (its OCV at the 2.0 V cut-off) lies below a dynamic cut-off: that
#: cut-off at DYNAMIC_CUTOFF_SOC with the relaxed OCV DYNAMIC_CUTOFF_OCV_V, 2.4 % of the charge (0.025 Ah
#: of this cell) above the table's end: FUDS's extra 0.009 Ah beyond the DST's, at 2.57 V after a rest,
#: lies on that segment.
DYNAMIC_CUTOFF_SOC, DYNAMIC_CUTOFF_OCV_V = 0.024, 2.60
LFP_OCV_SOC = (0.0,) + tuple(round(DYNAMIC_CUTOFF_SOC + (1.0 - DYNAMIC_CUTOFF_SOC) * s, 4) for s in _MEASURED_SOC)
LFP_OCV_VOLTAGE_V = (2.00, DYNAMIC_CUTOFF_OCV_V) + _MEASURED_VOLTAGE_V[1:]
#: the charge branch: at or above the discharge branch, the hysteresis of mid range and the taper's near full
LFP_OCV_GAP_V = (0.0, 0.0) + _MEASURED_GAP_V[1:]
LFP_OCV_CHARGE_VOLTAGE_V = tuple(round(v + g, 4) for v, g in zip(LFP_OCV_VOLTAGE_V, LFP_OCV_GAP_V))


#: the cell's voltage limits of each chemistry, V
LIMITS = {'lfp': {'cell_charge_voltage_v': 3.6, 'cell_cutoff_voltage_v': 2.0}}


def chemistry_tables(chemistry):
    """The OCV keys (ocv_soc, ocv_voltage_v, ocv_charge_voltage_v) of ``chemistry``; None for li-ion
    (its tables are the preset's or the config's own)."""
    if chemistry == 'lfp':
        return {'ocv_soc': LFP_OCV_SOC, 'ocv_voltage_v': LFP_OCV_VOLTAGE_V,
                'ocv_charge_voltage_v': LFP_OCV_CHARGE_VOLTAGE_V}
    return None
