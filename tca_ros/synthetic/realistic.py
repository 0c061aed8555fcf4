"""Random muscles and records that look measured, for testing identification.

A muscle is drawn around a thread preset's TCA (geometry and thermal constants
+-30 %), its unmeasurable parameters (time constant, steady rise, actuation gain,
damping) drawn independently of any fit's prior. Its records are simulated with
the full central-difference dynamics (18) at a fine physics rate (the fits use
the quasi-static reduction: another integrator), then corrupted the way a bench
corrupts them: power logged as nominal W x on/off, coloured (AR(1)) noise and a
slow drift on the displacement, encoder quantisation, no temperature, a low
sample rate. The truth is returned beside the records.
"""
from dataclasses import dataclass
import math
import os

import numpy as np

from tca_ros.calibration.calibration import apply_calibration
from tca_ros.calibration.calibration_parameters import expansion_zero
from tca_ros.calibration.predictions import record_params
from tca_ros.model.effects import CATALOGUE, true_ambient
from tca_ros.model.params_schema import GRAVITY
from tca_ros.model.simulation import simulate
from tca_ros.model.thermal import heat_capacity, thermal_conductance
from tca_ros.params.files import dump_params, load_params
from tca_ros.records.data import Record, write_csv_record
from tca_ros.synthetic.generator import draw_effect_values, random_power_profile

WARM_TRUTH_K = 0.05  # K: a start warmer than this is in the truth params (the oracle)

#: defects outside the catalogue: a sensor scale nonlinearity; an actuation gain that
#: fades by 25 % over the record (fatigue)
OUTSIDE = ('sensor_nonlinearity', 'fatigue')
RATES = (100.0, 5.0, 2.0, 1.0, 20.0)  # Hz, sample rates of realistic_case by seed
GEOMETRY_SPREAD = 0.3  # +-30 % on fiber radius, coil radius, fiber length
TRUTH_RANGES = {  # calibration parameter -> (low, high) of the hidden truth
    'thermal_time_constant': (0.6, 1.8),  # x the start value
    'steady_rise': (0.7, 1.4),  # x the start value
    'actuation_gain': (0.6, 1.6),
    'damping': (0.2, 2.0),  # N s/m
}


@dataclass
class RealisticSet:
    """Records of one random muscle and the truth behind them."""

    start: object  # TcaParams a maker would write (geometry known, rest nominal)
    truth: object  # TcaParams that made the records
    values: dict  # calibration parameter -> true value
    records: list


def draw_muscle(rng, config='free_stroke', target_peak_c=130.0, powers=3):
    """Return (start params, truth params, true values, powers (W)) of a random muscle.

    Geometry is drawn +-GEOMETRY_SPREAD around ``config`` (a params file name or
    path, or TcaParams) and is known to the start; the powers are chosen so the
    hottest step reaches about ``target_peak_c`` (degC) in the truth.
    """
    base = load_params(config) if isinstance(config, str) else config
    f = lambda: 1.0 + rng.uniform(-GEOMETRY_SPREAD, GEOMETRY_SPREAD)  # noqa: E731
    radius = base.fiber.radius * f()
    coil = max(base.coil.radius * f(), 1.6 * radius)
    start = base.with_values(**{'fiber.radius': radius, 'coil.radius': coil,
                                'fiber.length': base.fiber.length * f(),
                                'thermal.convection_coefficient':
                                base.thermal.convection_coefficient * f(),
                                'fiber.specific_heat': base.fiber.specific_heat * f()})
    conductance = thermal_conductance(start.fiber, start.thermal)
    tau = heat_capacity(start.fiber) / conductance
    values = {'thermal_time_constant': tau * rng.uniform(*TRUTH_RANGES['thermal_time_constant']),
              'steady_rise': rng.uniform(*TRUTH_RANGES['steady_rise']) / conductance,
              'actuation_gain': rng.uniform(*TRUTH_RANGES['actuation_gain']),
              'damping': rng.uniform(*TRUTH_RANGES['damping'])}
    # the same truth in the calibration's own coordinates; no lag, the paper's curvature
    values.update(heat_loss=1.0 / values['steady_rise'],
                  heat_capacity=values['thermal_time_constant'] / values['steady_rise'],
                  actuation_lag=0.0, expansion_zero_temperature=expansion_zero(start.fiber))
    truth = apply_calibration(start, values)
    top = (target_peak_c - start.thermal.ambient_temperature) / values['steady_rise']
    levels = [round(top * (k + 1) / powers, 3) for k in range(powers)]
    return start, truth, values, levels


def bench_record(truth, power, mass, rng, rate=5.0, duration=80.0, on=(20.0, 50.0),
                 quantum=8.4e-6, white=5e-6, coloured=30e-6, drift=0.1e-3,
                 physics_rate=500.0, model='cst', supply='power'):
    """Return a Record of a step of ``power`` (W) on ``truth`` as a bench logs it.

    Logged power is nominal x on/off; displacement gets white noise (m), AR(1)
    noise of ``coloured`` (m, correlation time 2 s), a linear drift of up to
    ``drift`` (m) over the record and quantisation to ``quantum`` (m). The truth
    is simulated at ``physics_rate`` (Hz) with the full dynamics (18).
    """
    time = np.arange(int(round(duration * rate)) + 1) / rate
    nominal = np.where((time >= on[0]) & (time < on[1]), power, 0.0)
    load = np.full_like(time, mass * GRAVITY)
    params = truth.with_values(**{'dynamics.mass': mass, 'dynamics.load': mass * GRAVITY})
    sim = simulate(params, time, nominal, load, model=model, physics_rate=physics_rate,
                   supply=supply)
    n = time.size
    a = math.exp(-1.0 / (rate * 2.0))
    ar = np.zeros(n)
    shocks = rng.standard_normal(n) * coloured * math.sqrt(1.0 - a * a)
    for k in range(1, n):
        ar[k] = a * ar[k - 1] + shocks[k]
    measured = (sim.displacement + white * rng.standard_normal(n) + ar
                + rng.uniform(-drift, drift) * time / time[-1])
    if quantum > 0.0:
        measured = np.round(measured / quantum) * quantum
    measured -= measured[0]  # an encoder reads zero at the start
    return Record(time=time, power=nominal, load=load, displacement=measured,
                  meta={'tca': 'start', 'mass_kg': mass, 'sample_rate_hz': rate},
                  source=f'{power:g} W, {mass * 1e3:g} g')


def realistic_set(seed, config='free_stroke', mass=0.02, repeats=1, **record_options):
    """Return a RealisticSet: a random muscle's step records at three powers."""
    rng = np.random.default_rng(seed)
    start, truth, values, powers = draw_muscle(rng, config)
    records = [bench_record(truth, p, mass, rng, **record_options)
               for p in powers for _ in range(repeats)]
    return RealisticSet(start=record_params(start, records[0]), truth=truth, values=values,
                        records=records)


def ar1(rng, n, rate, sigma, tau=2.0):
    """Return AR(1) noise of std ``sigma`` and correlation time ``tau`` (s) at ``rate`` Hz."""
    a = math.exp(-1.0 / (rate * tau))
    out = np.zeros(n)
    shocks = rng.standard_normal(n) * sigma * math.sqrt(1.0 - a * a)
    for k in range(1, n):
        out[k] = a * out[k - 1] + shocks[k]
    return out


def conditions(seed):
    """Return the record conditions of ``seed`` (each a different share of the seeds).

    ``not_at_rest``: 30 s at 0.5 W ending ``cool_before`` (s) before the record. The
    default 30 s of cooling brings the drawn muscles back to within a kelvin of
    ambient (their thermal time constants are seconds): the motion and the sensor
    are what is not at rest. A few seconds leave the fibre tens of kelvin warm.
    """
    return {'rate': RATES[seed % len(RATES)], 'plant': 'rod' if seed % 2 else 'cst',
            'temperature': seed % 4 < 2, 'drift': seed % 3 == 0,
            'nominal_power': seed % 3 == 1, 'noisy_power': seed % 3 == 2,
            'jitter': seed % 4 == 1, 'not_at_rest': seed % 4 == 3, 'cool_before': 30.0}


def truth_path(directory, seed, take=0):
    """Return the path of the truth params file realistic_case writes for ``seed``."""
    return os.path.join(directory, f'truth_{seed}{_take_suffix(take)}.yaml')


def _take_suffix(take):
    """Return the file-name suffix of record ``take`` of a muscle ('' for the first)."""
    return f'_{take}' if take else ''


def realistic_case(seed, hidden, directory, duration=240.0, mass=None, take=0, **overrides):
    """Write one bench-like record and its muscle description; return (record, start) paths.

    The muscle is drawn by :func:`draw_muscle`; ``hidden`` lists catalogue effects
    (drawn at random magnitudes) and/or OUTSIDE defects; the record's conditions
    (:func:`conditions`) vary with ``seed`` unless ``overrides`` set them. The
    description (start params, model cst) is what a maker would write; the
    plant's params (truth, effects included) go to :func:`truth_path`.
    ``mass`` (kg) replaces the drawn hanging mass. ``take`` > 0 makes another
    record of the same muscle with the same effects: its power profile and its
    noise are drawn anew.
    """
    rng = np.random.default_rng(seed)
    other = np.random.default_rng([seed, take]) if take else None
    cond = {**conditions(seed), **overrides}
    start, truth, _, _ = draw_muscle(rng)
    rate = cond['rate']
    pre = 30.0 + cond['cool_before'] if cond['not_at_rest'] else 0.0
    time_s = np.arange(int(round((duration + pre) * rate)) + 1) / rate - pre
    power = random_power_profile(rng, time_s + pre)
    if other is not None:  # the first take's draws are made all the same: same muscle
        power = random_power_profile(other, time_s + pre)
    if pre:  # heat 30 s, then let it cool for cond['cool_before'] s before the record
        cool = cond['cool_before']
        before = time_s < 0.0
        power[before] = np.where((time_s[before] < -cool) & (time_s[before] >= -cool - 30.0),
                                 0.5, 0.0)
        power[(time_s >= 0.0) & (time_s < 3.0)] = 0.0
    drawn = rng.uniform(0.015, 0.04)
    mass = drawn if mass is None else mass
    load = np.full_like(time_s, mass * GRAVITY)
    truth = truth.with_values(**{'dynamics.mass': mass, 'dynamics.load': mass * GRAVITY})
    inside = [h for h in hidden if h in CATALOGUE]
    truth = truth.with_values(**draw_effect_values(rng, inside))
    rng = rng if other is None else other
    n = time_s.size
    applied = power
    if cond['nominal_power']:  # the plant got +-3 % slow variation, the log the command
        applied = power * (1.0 + ar1(rng, n, rate, 0.03, tau=10.0))
    sim = simulate(truth, time_s, applied, load, model=cond['plant'], physics_rate=500.0)
    x = sim.displacement
    if 'fatigue' in hidden:  # the actuation gain fades by 25 % over the record
        gain = truth.fiber.untwist_gain
        tired = simulate(truth.with_values(**{'fiber.untwist_gain': 0.75 * gain}), time_s,
                         applied, load, model=cond['plant'], physics_rate=500.0)
        share = np.clip(time_s / duration, 0.0, 1.0)
        x = (1.0 - share) * x + share * tired.displacement
    keep = time_s >= 0.0
    time_s, power, load, x = time_s[keep], power[keep], load[keep], x[keep]
    temperature = sim.temperature[keep]
    if pre:  # the truth of the record as logged starts where the plant was at t = 0
        excess = float(temperature[0]) - true_ambient(truth.thermal, truth.effects)
        if excess > WARM_TRUTH_K:
            truth = truth.with_values(**{'thermal.initial_temperature_rise': excess})
    n = time_s.size
    if 'sensor_nonlinearity' in hidden:
        x = x + 8.0 * (x - x[0]) ** 2  # 8 /m: 0.8 mm read extra at 10 mm
    x = x + ar1(rng, n, rate, 20e-6) + 3e-6 * rng.standard_normal(n)
    if cond['drift']:
        x = x + rng.choice([-1.0, 1.0]) * rng.uniform(0.1e-3, 0.4e-3) * time_s / time_s[-1]
    x = np.round(x / 2e-6) * 2e-6
    logged = power + (0.01 * power.max() * rng.standard_normal(n) if cond['noisy_power']
                      else 0.0)
    logged = np.maximum(logged, 0.0)
    stamps = time_s.copy()
    if cond['jitter']:  # sampled on the grid, stamped +-20 % of a period off (on arrival)
        stamps[1:-1] += rng.uniform(-0.2, 0.2, n - 2) / rate
    temperature = (temperature + 0.2 * rng.standard_normal(n)) if cond['temperature'] else None
    start_path = os.path.join(directory, f'start_{seed}.yaml')
    dump_params(start.with_values(model='cst'), start_path)
    # the plant's own parameters (effects included), for benchmarks that ask whether
    # the truth itself passes the verdict's test on the logged record
    dump_params(truth.with_values(model=cond['plant']), truth_path(directory, seed, take))
    record = Record(time=stamps, power=logged, load=load, displacement=x - x[0],
                    temperature=temperature,
                    meta={'tca': os.path.basename(start_path), 'mass_kg': round(mass, 6),
                          'sample_rate_hz': rate,
                          **({'power_logged': 'command'} if cond['nominal_power'] else {})})
    path = os.path.join(directory, f'record_{seed}{_take_suffix(take)}.csv')
    write_csv_record(record, path)
    return path, start_path


def realistic_loads(seed, hidden, directory, masses):
    """Write records of one muscle at each of ``masses`` (kg); return (paths, start path).

    Record k is :func:`realistic_case`'s ``take`` k at ``masses[k]``: the same
    muscle and effects, its own power profile and noise (the first one's as
    the drawn case's), for diagnosing several loads together.
    """
    cases = [realistic_case(seed, hidden, directory, mass=m, take=k)
             for k, m in enumerate(masses)]
    return [path for path, _ in cases], cases[0][1]
