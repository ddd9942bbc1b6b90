"""The series count (no ROS): every count the fitted part's voltage range allows for each candidate chemistry,
scored by how well that chemistry's OCV shape fits the logs, on thinned copies of them."""
import math
from dataclasses import replace

import numpy as np

from battery_simulator.core.fit import FitError
from battery_simulator.core.fit.circuit import Chemistry, counted_charge_ah, log_arrays, regressors, state_of_charge
from battery_simulator.core.fit.electrical import fit_electrical, non_negative_lstsq, parallel_count
from battery_simulator.core.fit.known import preset_temperature
from battery_simulator.core.parameter_rules import MAX_CELLS

#: the series count is clear when the runner-up's fit is this many times worse than the best's
SERIES_CLEAR = 1.5
#: samples per log the series-count search looks at
SEARCH_SAMPLES = 2500
#: per-cell voltage a log of each chemistry can show beyond its cut-off and charge voltage (load, charge), V
CELL_VOLTAGE_MARGIN = {'below': 0.45, 'above': 0.2}
#: the series counts tried in full per chemistry (nearest its nominal voltage) when no percentage screens them
FULL_FIT_CANDIDATES = 6
#: another chemistry than the first (the preset given or Li-ion) is taken where its fit's RMSE is below this
#: fraction of the first's: over a short span of SOC a flat curve and a sloped one can fit nearly alike (a BMW
#: i3 winter drive over 15 % of SOC: LFP's shape at 116 cells 1.9 times better than Li-ion's at 97; the A123
#: LFP cell's DST test: LFP 8 times better)
CHEMISTRY_CLEAR = 1.0 / 3.0
#: a candidate whose one cell holds more than the first's is tried only where the pack's capacity is known
#: (the logged percentage, or a full charge and a cut-off) and at least this fraction of that cell's: a pack
#: holds no less than one of its cells (the BMW i3's 62 Ah cell is no candidate for a robot's 5.6 Ah 4S2P pack).
#: The first candidate is then the largest cell of the first's chemistry the pack holds: between two Li-ion
#: cells the level does not choose (it spreads by 5 % between cells and is read from the percentage anyway;
#: on the BMW i3's 60 drives LG HG2's level fitted up to 3.2 times better where the i3's own cell held out
#: 6.6 mV per cell against 28.9), so a large pack is taken to be of large cells unless another fits
#: CHEMISTRY_CLEAR better
LARGE_CELL_FILL = 0.9
#: and another cell of the first's chemistry is taken only where the first's level is off by more than this
#: per cell (RMS, V): how far a car's own cell reads from the BMS's percentage varies from drive to drive. On
#: the BMW i3's 60 drives its own cell (bmw_i3_60ah_cell) was off by a median 10.9 mV per cell and up to 48
#: (B29, below the preset's learned range); on B18 it was off by 22.7 and LG HG2 by 7.1, and LG HG2 taken held
#: out 28.9 mV per cell against 6.6 with the fitted offset over the i3's own shape
LEVEL_NOISE_V = 0.030
#: The level of the OCV is what tells the counts apart, and it is a cell's own: at the same state of charge
#: Li-ion cells differ in OCV by up to this fraction of their voltage. Measured: LG HG2 (the preset), the LG M50
#: (NMC811, Chen et al. 2020, doi:10.1149/1945-7111/ab9050) and Samsung SDI's 94 Ah NMC111 cell (the OCV fit of
#: SimSES, Moeller et al. 2022, doi:10.1016/j.est.2021.103743) lie within 40 mV of each other between 30 and
#: 90 % SOC, but the BMW i3's cells (96S, Samsung SDI 60 Ah) sit up to 5 % above them at the car's BMS
#: percentage (3.81 V per cell at 38 %: 190 mV). So counts within this fraction of the best-fitting one are
#: not told apart by a pack's voltage; among them the count built of the largest of MODULE_SIZES is taken,
#: the nearest to the best fit on a tie. It never moves the count further than this fraction, so below 21
#: cells (where n / (n - 1) > 1.05) it never acts.
LEVEL_SPREAD = 0.05
#: the cells in series of a pack's module, most usual first: packs are built of equal modules of 12 (the BMW
#: i3: 8 x 12 = 96; VW's MEB: 9 x 12 = 108), 8, 6 or 4 cells in series (robots: 24, 48)
MODULE_SIZES = (12, 8, 6, 4, 2, 1)


def _cell_range(params):
    """(lowest, highest) voltage per cell a log of ``params``'s cell may show."""
    return (params.cell_cutoff_voltage_v - CELL_VOLTAGE_MARGIN['below'],
            params.cell_charge_voltage_v + CELL_VOLTAGE_MARGIN['above'])


def _refuse_a_count_no_cell_allows(cells_series, low, high, candidates):
    """FitError where the fitted part's voltage (``low``-``high``) at ``cells_series`` cells is no candidate's."""
    ranges = [(name, _cell_range(params)) for name, params in candidates]
    if any(bottom <= low / cells_series and high / cells_series <= top for _, (bottom, top) in ranges):
        return
    raise FitError('at %d cells in series the logs\' voltage is %.3g-%.3g V per cell, no cell\'s (%s): check '
                   '--cells-series (or leave it out: the count is found from the voltage)' % (
                       cells_series, low / cells_series, high / cells_series,
                       '; '.join('%s %.2f-%.2f V' % ((name,) + cell_range) for name, cell_range in ranges)))


def series_count(logs, masks, candidates, known, cells_series, why, progress, warnings):
    """(series count, why, chemistry name, chemistry params, whether the count is not the best fit's but the
    usual layout near it): every count the fitted part's voltage range
    allows for each chemistry's cells, scored by the fit of that chemistry's OCV shape (no offset: the
    level is what tells the counts apart) in pack volts."""
    voltages = np.concatenate([log.voltage_v[mask] for log, mask in zip(logs, masks)])
    low, high = float(np.percentile(voltages, 0.1)), float(np.percentile(voltages, 99.9))
    short_logs, short_masks = [], []
    for log, mask in zip(logs, masks):
        step = max(1, len(log.time_s) // SEARCH_SAMPLES)
        short_logs.append(_thinned(log, step))
        short_masks.append(mask[::step])
    short_known = known.thinned([max(1, len(log.time_s) // SEARCH_SAMPLES) for log in logs])
    candidates = _pack_sized_first([item for item in candidates
                                    if _holds_a_cell(item[1], candidates[0][1], known.capacity_ah)])
    if cells_series:
        _refuse_a_count_no_cell_allows(cells_series, low, high, candidates)
    scores, tried = [], []
    for name, params in candidates:
        chemistry = Chemistry(params)
        if cells_series:
            counts = [cells_series]
        else:
            bottom, top = _cell_range(params)
            counts = list(range(max(1, math.ceil(high / top)), min(MAX_CELLS, int(low / bottom)) + 1))
        if not counts:
            continue
        screened = short_known.starts(short_logs)
        if screened is None and len(counts) > FULL_FIT_CANDIDATES:
            nominal = float(np.interp(0.5, chemistry.soc_points, chemistry.ocv))
            middle = float(np.median(voltages)) / nominal
            counts = sorted(sorted(counts, key=lambda n: abs(n - middle))[:FULL_FIT_CANDIDATES])
        tried.append('%s %s' % (name, _ranges(counts)))
        for count in counts:
            if screened is not None:
                score = _screen(short_logs, short_masks, chemistry, count, short_known.capacity_ah, screened)
            else:
                temperatures = [preset_temperature(log, chemistry) for log in short_logs]
                try:
                    result = fit_electrical(short_logs, short_masks, chemistry, count, 1, temperatures, False,
                                             None, max_evaluations=40, known=short_known)
                    score = result.rmse_v * count
                except FitError:
                    continue
            scores.append((score, count, name, params))
        progress(0.02 + 0.2 * len(tried) / len(candidates), 'series count')
    if not scores:
        raise FitError('no series count of %s cells fits the voltage range %.2f-%.2f V'
                       % (' or '.join(name for name, _ in candidates), low, high))
    scores.sort(key=lambda item: item[0])
    taken = {}   # per chemistry: its score at the count it would take (the usual layout near its best fit)
    for _, count, name, params in scores:
        if name not in taken:
            same = {item[1]: item[0] for item in scores if item[2] == name}
            usual = usual_count(sorted(same), count)
            taken[name] = (same[usual], usual, count, same, params)
    first = candidates[0][0]
    for name in sorted(taken, key=lambda n: taken[n][0]):   # another than the first only where it fits
        score, best, fitted_best, same, params = taken[name]    # clearly better
        if name == first or first not in taken:
            break
        first_score, first_count, _, _, first_params = taken[first]
        within_noise = (params.chemistry == first_params.chemistry
                        and first_score / first_count <= LEVEL_NOISE_V)
        if score < CHEMISTRY_CLEAR * first_score and not within_noise:
            break
    bests = {}
    for item in scores:
        bests.setdefault(item[2], item)
    tried = ['%s (best %d: %.3g V)' % (text, bests[text.split()[0]][1], bests[text.split()[0]][0])
             if text.split()[0] in bests else text for text in tried]
    if why is None:
        rivals = [item for item in scores if item[2] == name and item[0] < SERIES_CLEAR * score and item[1] != best]
        if best != fitted_best:
            band = [n for n in sorted(same) if abs(n - fitted_best) <= LEVEL_SPREAD * fitted_best]
            warnings.append('cells in series: %d taken, the usual pack layout among %s (within %.0f %% of the '
                            'best fit of the OCV level, %d cells: %.3g V pack RMSE against %.3g at %d; an unknown '
                            'cell\'s OCV level is not known to better than that); --cells-series settles it'
                            % (best, _ranges(band), 100 * LEVEL_SPREAD, fitted_best, same[fitted_best], score, best))
        elif rivals:
            warnings.append('cells in series: %d fits best (%.3g V pack RMSE), but %d nearly as well (%.3g V); '
                            '--cells-series settles it' % (best, score, rivals[0][1], rivals[0][0]))
        why = ('the fitted part\'s voltage %.2f-%.2f V and the best fit of the OCV shape among %s cells%s'
               % (low, high, '; '.join(tried), ' (the SOC from the logged percentage)'
                  if known.soc0 is not None else ''))
        if best != fitted_best:
            why += '; %d taken: the usual pack layout within %.0f %% of %d (the level of an unknown cell\'s OCV ' \
                   'does not tell them apart)' % (best, 100 * LEVEL_SPREAD, fitted_best)
    return best, why, name, params, best != fitted_best


def _holds_a_cell(params, first, capacity_ah):
    """Whether a candidate's cell can be in the pack: no larger than the first candidate's, or the pack's
    known capacity holds at least LARGE_CELL_FILL of it."""
    if params.cell_capacity_ah <= first.cell_capacity_ah:
        return True
    return capacity_ah is not None and capacity_ah >= LARGE_CELL_FILL * params.cell_capacity_ah


def _pack_sized_first(candidates):
    """``candidates`` with the largest cell of the first's chemistry first (the others in their order)."""
    chemistry = candidates[0][1].chemistry
    largest = max((item for item in candidates if item[1].chemistry == chemistry),
                  key=lambda item: item[1].cell_capacity_ah)
    return [largest] + [item for item in candidates if item is not largest]


def usual_count(counts, best):
    """Among ``counts`` within LEVEL_SPREAD of ``best``, the one built of the largest of MODULE_SIZES (the
    nearest to ``best`` on a tie)."""
    band = [n for n in counts if abs(n - best) <= LEVEL_SPREAD * best] or [best]
    return max(band, key=lambda n: (max(m for m in MODULE_SIZES if n % m == 0), -abs(n - best), -n))


def _ranges(counts):
    return '%d' % counts[0] if len(counts) == 1 else '%d-%d' % (counts[0], counts[-1])


def _screen(logs, masks, chemistry, count, capacity_ah, soc0):
    """Pack-volt RMSE of the chemistry's OCV shape plus resistances (least squares, preset time constants)
    with the SOC the logged percentage gives, for ``count`` cells in series."""
    p = chemistry.params
    parallel = parallel_count(capacity_ah, p.cell_capacity_ah)
    rows, targets = [], []
    for k, (log, mask) in enumerate(zip(logs, masks)):
        a = log_arrays(log, chemistry, count, parallel)
        soc = state_of_charge(a, capacity_ah / parallel, soc0[k], p.coulombic_efficiency)
        x0, _, xf = regressors(a, soc, chemistry.arrhenius(preset_temperature(log, chemistry)), chemistry,
                               p.tau1_s, p.tau_fast_s, False)
        rows.append(np.column_stack([x0[mask], xf[mask]]))
        targets.append((a.cell_voltage - chemistry.ocv_at(soc, a.weight))[mask])
    # no slow RC pair: over a drive its long memory would stand in for the OCV's slope, the very thing that
    # tells the chemistries and the counts apart
    _, _, residual = non_negative_lstsq(np.vstack(rows), np.concatenate(targets), ['r0_ohm', 'r_fast_ohm'])
    return float(np.sqrt(np.mean(residual ** 2))) * count


def _thinned(log, step):
    copy = replace(log)
    for name in ('time_s', 'voltage_v', 'current_a', 'temperature_c', 'percentage'):
        value = getattr(log, name)
        if value is not None:
            setattr(copy, name, value[::step])
    if step > 1:   # a thinned log's current: the mean over the new interval after each sample (the charge kept)
        picked = counted_charge_ah(log)[::step] * 3600.0
        span = np.diff(copy.time_s)
        copy.current_a = np.concatenate([np.diff(picked) / np.where(span > 0, span, 1.0), [log.current_a[-1]]])
    return copy
