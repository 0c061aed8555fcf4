"""Transfer: a calibrated muscle predicting records it was not fitted on.

A physics model earns its place where a lumped one cannot follow: another rig,
load, power or air flow. ``trained_range`` keeps what a calibration saw (powers,
loads, rigs, the hottest predicted temperature) and the lumped model fitted on
the same records; ``validate`` predicts any records with the calibrated params
(full dynamics (18)) and sets each score beside the lumped model and the repeat
floor, with a warning wherever a prediction extrapolates.
"""
from dataclasses import dataclass, field
import json

import numpy as np

from tca_ros.calibration.conditions import environment_of, measured, rig_of, scale_of, \
    SCALE_PREFIX, STILL_AIR
from tca_ros.calibration.lumped import fit_lumped, predict_lumped
from tca_ros.calibration.posterior import header_entry
from tca_ros.calibration.predictions import full_predictions, normalised_rmse, predictor
from tca_ros.calibration.validation import condition_of, repeat_floor

HEADER_KEY = 'calibrated_on'  # params-file header line written by `tca_sim calibrate`
POWER_MARGIN = 1.05  # a power this far past the trained ones is an extrapolation
LOAD_MARGIN = 1.10  # likewise a load (x the largest, / the smallest trained)
TEMPERATURE_MARGIN_K = 10.0  # K past the hottest trained prediction


def rig_prediction(params, record, model, scales=None):
    """Return the full-dynamics prediction (m or N) of what the record's rig measures.

    Isotonic (a hanging mass): the contraction; isometric (clamped at its length
    under the record's pretension, N): the force rise above the pretension.
    """
    if rig_of(record) == 'isometric':
        force = full_predictions(params, [record], model, ['force'], 'power',
                                 scales)[0]['force']
        return force - force[0]
    return full_predictions(params, [record], model, ['displacement'], 'power',
                            scales)[0]['displacement']


def rig_nrmse(record, prediction):
    """Return RMSE / peak measured response (-) of the record's measured channel."""
    values = measured(record)
    peak = max(float(np.percentile(values, 99.5)), 1e-9)
    return float(np.sqrt(np.mean((values - prediction) ** 2))) / peak


def peak_temperatures(params, records, model, supply='power', scales=None):
    """Return per record the hottest predicted temperature (degC), quasi-static."""
    values = {SCALE_PREFIX + k: v for k, v in (scales or {}).items()}
    sims = predictor(params, model, ['temperature'], supply)(values, records)
    return [float(np.max(s['temperature'])) for s in sims]


def trained_range(cal):
    """Return a JSON-ready dict of what calibration ``cal`` was fitted on.

    Peak powers (W), loads (N), rigs, the hottest predicted temperature (degC) and
    the lumped model (gain m/W, tau s, delay s) fitted on the same records (those
    that measure a contraction: none when every record is isometric).
    """
    records = cal.records
    moving = [r for r in records if rig_of(r) != 'isometric']
    lumped = fit_lumped(moving).values if moving else None
    return {'power_w': [float(np.max(r.power)) for r in records],
            'load_n': [float(np.max(r.load)) for r in records],
            'rig': sorted({rig_of(r) for r in records}),
            'environment': {STILL_AIR: 1.0, **cal.environments},
            'peak_temperature_c': max(peak_temperatures(cal.params, records, cal.model,
                                                        cal.supply, cal.environments)),
            'lumped': ({k: float(lumped[k]) for k in ('gain', 'tau', 'delay')}
                       if lumped is not None else None),
            'records': [r.source for r in records]}


def header_line(trained):
    """Return the params-file header line that stores ``trained`` (one JSON line)."""
    return f'{HEADER_KEY}: {json.dumps(trained, separators=(",", ":"))}'


def read_trained_range(path):
    """Return the trained range stored in a calibrated params file's header, or None."""
    text = header_entry(path, HEADER_KEY)
    try:
        return None if text is None else json.loads(text)
    except ValueError:
        return None


def profile_extrapolation(trained, power, load, rig):
    """Return the warnings (strings) of a run at peak ``power`` (W), ``load`` (N) on ``rig``."""
    out = []
    if power > POWER_MARGIN * max(trained['power_w']):
        out.append(f'power {power:.3g} W above the calibrated {max(trained["power_w"]):.3g} W')
    low, high = min(trained['load_n']), max(trained['load_n'])
    if rig != 'isometric' and (load > LOAD_MARGIN * high or load < low / LOAD_MARGIN):
        out.append(f'load {load:.3g} N outside the calibrated {low:.3g}-{high:.3g} N')
    if rig not in trained['rig']:
        out.append(f'rig {rig} not calibrated ({", ".join(trained["rig"])})')
    return out


def extrapolation(record, trained, peak_temperature):
    """Return the warnings (strings) of a record outside ``trained``'s range."""
    out = profile_extrapolation(trained, float(np.max(record.power)),
                                float(np.max(record.load)), rig_of(record))
    env = environment_of(record)
    if env not in trained.get('environment', {STILL_AIR: 1.0}):
        out.append(f'environment {env} not calibrated (its heat loss is taken at the prior '
                   f"{scale_of(env, None):g}x still air's)")
    hot = temperature_extrapolation(trained, peak_temperature)
    return out + ([hot] if hot else [])


def temperature_extrapolation(trained, peak_temperature):
    """Return the warning of a predicted peak (degC) past ``trained``'s hottest, or ''.

    Past the hottest temperature the records reached, the stroke-temperature
    characteristic (eq. 2's Gamma(T), the curvature) is the model's extrapolation:
    nothing there was fitted, and a real thread heated towards its annealing
    temperature may stop following it (a stroke that peaks and falls while heated).
    """
    top = trained.get('peak_temperature_c')
    if top is None or not peak_temperature > top + TEMPERATURE_MARGIN_K:
        return ''
    return (f'predicted {peak_temperature:.0f} degC above the calibrated {top:.0f} degC '
            '(the stroke-temperature characteristic there is extrapolated, not fitted)')


@dataclass
class Transfer:
    """One record predicted by a calibrated muscle (normalised RMSE, -)."""

    source: str
    condition: tuple
    physics: float
    lumped: float
    floor: float  # nan without repeats
    warnings: list = field(default_factory=list)


def validate(records, params, model, trained=None, supply='power'):
    """Return [Transfer] of ``records`` predicted by calibrated ``params``.

    ``trained``: the calibration's trained range (:func:`trained_range`); without
    it the lumped model is fitted on ``records`` themselves (an optimistic
    baseline, said by the caller) and nothing is flagged as extrapolated.
    """
    scales = trained.get('environment') if trained else None
    if supply != 'power':
        raise ValueError(f'supply = {supply!r}: validate predicts a delivered power only')
    isotonic = [r for r in records if rig_of(r) != 'isometric']
    lumped = trained['lumped'] if trained else (fit_lumped(isotonic).values if isotonic
                                                else None)
    floors = repeat_floor(records, channel=measured)
    peaks = peak_temperatures(params, records, model, supply, scales) if trained else \
        [0.0] * len(records)
    rows = []
    for r, floor, peak in zip(records, floors, peaks):
        physics = rig_nrmse(r, rig_prediction(params, r, model, scales))
        # the lumped model maps power to contraction: it has nothing to say of a force
        base = normalised_rmse(r, predict_lumped(lumped, [r])[0]['displacement']) \
            if rig_of(r) != 'isometric' and lumped else float('nan')
        rows.append(Transfer(r.source, condition_of(r), physics, base, floor,
                             extrapolation(r, trained, peak) if trained else []))
    return rows


def format_validation(rows, lumped_label='lumped'):
    """Return the transfer table: per record physics, lumped, repeat floor and warnings."""
    lines = [f'{"record":<38s}{"P (W)":>7s}{"load (N)":>10s}{"physics":>9s}'
             f'{lumped_label:>9s}{"floor":>8s}']
    for h in rows:
        name = (h.source or '?').rsplit('/', 1)[-1][-36:]
        floor = f'{h.floor:>8.1%}' if h.floor == h.floor else f'{"-":>8s}'
        lumped = f'{h.lumped:>9.1%}' if h.lumped == h.lumped else f'{"-":>9s}'
        lines.append(f'{name:<38s}{h.condition[0]:>7.2f}{h.condition[1]:>10.3f}'
                     f'{h.physics:>9.1%}{lumped}{floor}')
        lines += [f'  warning: extrapolates: {w}' for w in h.warnings]
    floors = [h.floor for h in rows if h.floor == h.floor]
    lumps = [h.lumped for h in rows if h.lumped == h.lumped]
    lines.append(f'{"median":<55s}{np.median([h.physics for h in rows]):>9.1%}'
                 + (f'{np.median(lumps):>9.1%}' if lumps else f'{"-":>9s}')
                 + (f'{np.median(floors):>8.1%}' if floors else f'{"-":>8s}'))
    lines.append('nRMSE = RMSE / peak measured response (stroke, or force rise on an '
                 'isometric rig); floor: each record predicted by the mean of its repeats '
                 '(no model of one muscle does better)')
    return '\n'.join(lines)
