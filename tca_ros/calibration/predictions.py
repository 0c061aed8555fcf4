"""Predictions of a muscle's records: the quasi-static fit model and the full dynamics.

What the calibration fits and checks with, per record and rig: ``predictor`` builds
the engine's prediction of the quasi-static reduction (model/quasistatic.py; a
clamped muscle: model/quasistatic_isometric.py) for calibration values;
``full_predictions`` simulates the full dynamics (18) (the isometric rig's for a
clamped muscle), each record in its environment (conditions.py); the scores are
normalised by each record's peak response.
"""
import numpy as np

from tca_ros.calibration.calibration_parameters import apply_calibration
from tca_ros.calibration.conditions import environment_of, environment_scales, in_environment, \
    is_isometric, measured, rig_of, spring_stiffness_of
from tca_ros.model.quasistatic import QuasiStaticPlant
from tca_ros.model.quasistatic_isometric import isometric_force, spring_equilibrium
from tca_ros.model.resistance import resistance
from tca_ros.model.rig_simulation import simulate_rig
from tca_ros.model.simulation import simulate

PEAK_PERCENTILE = 99.5  # % of a record's contraction taken as its peak (spike-robust)
MIN_PHYSICS_RATE_HZ = 200.0  # Hz, full-dynamics check


def record_params(params, record):
    """Return ``params`` with the record's hanging mass (kg) and initial load (N)."""
    mass = float(record.meta.get('mass_kg', params.dynamics.mass))
    return params.with_values(**{'dynamics.mass': mass, 'dynamics.load': float(record.load[0])})


def peak_stroke(record, mask=None):
    """Return the record's peak contraction (m), robust to single-sample spikes.

    ``mask``: the samples considered (boolean array; default all).
    """
    x = record.displacement if mask is None else record.displacement[mask]
    return float(max(np.percentile(x, PEAK_PERCENTILE), 1e-6))


def normalised_rmse(record, displacement):
    """Return RMSE / peak measured stroke (-) of a predicted ``displacement`` (m)."""
    return float(np.sqrt(np.mean((record.displacement - displacement) ** 2))) \
        / peak_stroke(record)


def peak_response(record, mask=None):
    """Return the peak of what the record's rig measures (m, or N isometric), spike-robust."""
    x = measured(record) if mask is None else measured(record)[mask]
    return float(max(np.percentile(x, PEAK_PERCENTILE), 1e-6))


def predictor(start, model, channels, supply='power', corrections=None):
    """Return the engine's ``predict(values, records)`` for the quasi-static TCA.

    ``corrections``: per record {channel: array} added to the quasi-static
    prediction (the defect correction towards the full dynamics).
    """
    def predict(values, records):
        params = apply_calibration(start, values)
        scales = environment_scales(values)
        plants = {}
        out = []
        for r in records:
            mass = float(r.meta.get('mass_kg', start.dynamics.mass))
            key = (mass, environment_of(r))
            plant = plants.get(key)
            if plant is None:
                plant = plants[key] = QuasiStaticPlant(in_environment(
                    params.with_values(**{'dynamics.mass': mass}), r, scales), model=model)
            if rig_of(r) in ('isometric', 'spring'):
                out.append(rig_prediction(plant, r, channels))
                continue
            sim = plant.simulate(r.time, r.power, r.load, supply=supply)
            pred = {c: getattr(sim, c) for c in channels if c != 'force'}
            if 'force' in channels:  # a hanging mass pulls its weight
                pred['force'] = np.asarray(r.load, dtype=float)
            out.append(pred)
        if corrections is not None:
            out = [{c: p[c] + d[c] for c in channels} for p, d in zip(out, corrections)]
        return out
    return predict


def rig_prediction(plant, record, channels):
    """Return {channel: array} of a clamped or spring-held muscle, quasi-static (m, N)."""
    pretension = float(record.load[0])
    if is_isometric(record):
        force, temperature = isometric_force(plant, record.time, record.power, pretension)
        x = np.zeros_like(record.time)
    else:
        x, force, temperature = spring_equilibrium(plant, record.time, record.power,
                                                   pretension, spring_stiffness_of(record))
    out = {'displacement': x, 'force': force, 'temperature': temperature}
    if 'resistance' in channels:
        p = plant.params
        out['resistance'] = resistance(temperature, x, plant.loaded_length(pretension),
                                       p.electrical, p.thermal.ambient_temperature)
    return {c: out[c] for c in channels}


def full_predictions(params, records, model, channels, supply='power', scales=None):
    """Return per record {channel: array} of the full dynamics (18) with ``params``.

    ``scales``: {environment: heat-loss scale} of the records' environments
    (conditions.py; default: each record in still air).
    """
    out = []
    for r in records:
        rate = max(MIN_PHYSICS_RATE_HZ, r.sample_rate)
        if is_isometric(r):
            p = in_environment(params.with_values(**{
                'rig.mode': 'isometric', 'rig.pretension': float(r.load[0])}), r, scales)
            columns = simulate_rig(p, r.time, r.power, model=model, physics_rate=rate).columns
            columns['displacement'] = np.zeros_like(r.time)
            out.append({c: columns[c] for c in channels})
            continue
        if rig_of(r) == 'spring':
            p = in_environment(params.with_values(**{
                'rig.mode': 'spring', 'rig.pretension': float(r.load[0]),
                'rig.spring_stiffness': spring_stiffness_of(r)}), r, scales)
            columns = simulate_rig(p, r.time, r.power, r.load, model=model,
                                   physics_rate=rate).columns
            out.append({c: columns[c] for c in channels})
            continue
        sim = simulate(in_environment(record_params(params, r), r, scales), r.time, r.power,
                       r.load, model=model, physics_rate=rate, supply=supply)
        if 'force' in channels:
            out.append({**{c: getattr(sim, c) for c in channels if c != 'force'},
                        'force': np.asarray(r.load, dtype=float)})
            continue
        out.append({c: getattr(sim, c) for c in channels})
    return out


def defect_corrections(params, records, model, channels, supply='power', scales=None):
    """Return per record {channel: full dynamics - quasi-static} at ``params``."""
    full = full_predictions(params, records, model, channels, supply, scales)
    fast = predictor(params, model, channels, supply)(
        {f'heat_loss_scale.{k}': v for k, v in (scales or {}).items()}, records)
    return [{c: f[c] - q[c] for c in channels} for f, q in zip(full, fast)]


def full_nrmse(params, records, model, supply='power', scales=None):
    """Return per-record RMSE / peak stroke (-) of the full dynamics (18) with ``params``."""
    predictions = full_predictions(params, records, model, ['displacement'], supply, scales)
    return [normalised_rmse(r, p['displacement']) for r, p in zip(records, predictions)]
