"""Leave-one-condition-out validation of a calibration against two baselines.

Records are grouped by operating condition (the power level and the load). For
each condition, the physics model is calibrated on all the other conditions and
predicts the records of the one left out; the score is the normalised RMSE
(RMSE / peak measured stroke) of each held-out record. Beside it, on the same
held-out records: (a) the uncalibrated start config, (b) the lumped model
(lumped.py) fitted on the same training records.
"""
from dataclasses import dataclass

import numpy as np

from tca_ros.calibration.calibration import calibrate
from tca_ros.calibration.lumped import fit_lumped, lumped_nrmse
from tca_ros.calibration.predictions import full_nrmse

POWER_DIGITS = 2  # W, rounding of the power level that names a condition
LOAD_DIGITS = 3  # N


def condition_of(record):
    """Return (power level (W), load (N)) of a record: its operating condition."""
    return (round(float(record.power.max()), POWER_DIGITS),
            round(float(record.load[0]), LOAD_DIGITS))


@dataclass
class HeldOut:
    """Scores of one held-out record (normalised RMSE, -)."""

    source: str
    condition: tuple
    calibrated: float
    start: float
    lumped: float


def leave_one_condition_out(records, params, model=None, progress=False, supply='power',
                            fit=None):
    """Return (list of HeldOut, {condition: Calibration}) over every condition.

    Needs at least two conditions; a ValueError names the one condition otherwise.
    """
    groups = {}
    for r in records:
        groups.setdefault(condition_of(r), []).append(r)
    if len(groups) < 2:
        only = next(iter(groups))
        raise ValueError(f'conditions = {[only]}: leave-one-condition-out needs records '
                         'at two or more powers or loads')
    rows, calibrations = [], {}
    for cond in sorted(groups):
        test = groups[cond]
        train = [r for c, rs in groups.items() if c != cond for r in rs]
        cal = calibrate(train, params, model=model, progress=progress, check=False,
                        supply=supply, fit=fit)
        calibrations[cond] = cal
        calibrated = full_nrmse(cal.params, test, cal.model, supply, cal.environments)
        start = full_nrmse(cal.start, test, cal.model, supply)
        lumped = lumped_nrmse(fit_lumped(train).values, test)
        for r, a, b, c in zip(test, calibrated, start, lumped):
            rows.append(HeldOut(r.source, cond, a, b, c))
    return rows, calibrations


def condition_label(condition):
    """Return the name of an operating condition (power level W, load N): 'P=1 W, F=0.2 N'."""
    return f'P={condition[0]:g} W, F={condition[1]:g} N'


def format_table(rows):
    """Return the held-out table with per-condition and overall medians.

    Each record row gives its condition's power (W) and load (N); each median row names
    its condition by both, so one power at two loads gives two distinct rows.
    """
    lines = [f'{"held-out record":<38s}{"P (W)":>7s}{"F (N)":>8s}{"calibrated":>12s}'
             f'{"start":>9s}{"lumped":>9s}']
    for h in rows:
        name = h.source.rsplit('/', 1)[-1][-36:]
        lines.append(f'{name:<38s}{h.condition[0]:>7.2f}{h.condition[1]:>8.3g}'
                     f'{h.calibrated:>12.1%}{h.start:>9.1%}{h.lumped:>9.1%}')
    for label, sel in [(f'median {condition_label(c)}', [h for h in rows if h.condition == c])
                       for c in sorted({h.condition for h in rows})] + [('median', rows)]:
        lines.append(f'{label:<53s}{np.median([h.calibrated for h in sel]):>12.1%}'
                     f'{np.median([h.start for h in sel]):>9.1%}'
                     f'{np.median([h.lumped for h in sel]):>9.1%}')
    return '\n'.join(lines)


def repeat_means(records, channel=None):
    """Return per record the mean of its repeats on its time grid, or None without repeats.

    The repeats of a record are the other records at its condition (condition_of)
    and rig, each interpolated onto the record's time grid (s) and averaged: the
    response a model that knew the condition's mean exactly would predict.
    ``channel(record)``: the measured array (default the displacement, m).
    """
    channel = channel or (lambda r: r.displacement)
    out = []
    for r in records:
        others = [o for o in records if o is not r and condition_of(o) == condition_of(r)
                  and getattr(o, 'meta', {}).get('rig') == getattr(r, 'meta', {}).get('rig')]
        out.append(np.mean([np.interp(r.time, o.time, channel(o)) for o in others], axis=0)
                   if others else None)
    return out


def repeat_floor(records, channel=None, normalised=True):
    """Return per record the nRMSE (-) of the mean of its repeats; nan without repeats.

    What a model that knew the condition's mean response exactly would score
    (repeat_means). Different muscles and their history make repeats differ; no
    model of one muscle does better. ``channel(record)``: the measured array
    compared (default the displacement, m); the score is RMSE / its peak, or the
    RMSE itself (the channel's unit) when not ``normalised``.
    """
    channel = channel or (lambda r: r.displacement)
    out = []
    for r, mean in zip(records, repeat_means(records, channel)):
        if mean is None:
            out.append(float('nan'))
            continue
        peak = max(float(np.percentile(channel(r), 99.5)), 1e-9) if normalised else 1.0
        out.append(float(np.sqrt(np.mean((channel(r) - mean) ** 2))) / peak)
    return out
