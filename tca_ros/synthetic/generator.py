"""Seeded synthetic TCA records: the nominal model plus hidden effects, plus noise.

A record is made from a random input profile (power steps, ramps, pseudo-random
binary sequences and cooling phases; a hanging mass with ramped load changes),
simulated with the nominal parameters and the hidden effect(s) of the catalogue at
random magnitudes in a physical range (``EFFECT_RANGES``), at a fine physics rate,
sampled and corrupted with white Gaussian sensor noise. The diagnosis sees only the
record and the nominal config; the truth is returned separately.
"""
from dataclasses import dataclass, field
import math

import numpy as np

from tca_ros.diagnosis.fitting import TRAIN_FRACTION
from tca_ros.model.effects import CATALOGUE, true_ambient
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import loaded_length
from tca_ros.model.kinetostatics import pitch_angle_of_length
from tca_ros.model.params_schema import GRAVITY
from tca_ros.model.simulation import simulate
from tca_ros.params.files import load_params
from tca_ros.records.data import Record

#: Physical magnitude ranges the generator draws from: dotted name -> (low, high, log).
#: Sources: creep of loaded nylon coils of 1-5 % of the loaded length over minutes
#: (Kianzad et al. 2015); play widths of 5-20 K (Zhang et al. 2017); emissivity of
#: nylon 0.5-0.95; laminar natural convection exponent 1/4 (Masuya et al. 2017);
#: modulus loss of 10-40 % by 150 degC (Demsar et al. 2010); LVDT / laser sensor
#: filters of 0.1-1 s; lab ambient differing by 2-8 K from the 25 degC assumed; 5-30 %
#: of the drive power lost in leads, contacts and the clamps; drive dead times of
#: 0.4-2 s and second thermal lags of 1-5 s (the real mandrel-coiled records of
#: ../shared/realdata start moving 1-4 s after the power); pulley friction of
#: 10-40 mN (the 1-3 mm steps and residual offsets of those records at k ~ 10 N/m).
EFFECT_RANGES = {
    'effects.creep_compliance': (0.004, 0.015, True),
    'effects.creep_time_constant': (15.0, 60.0, True),
    'effects.hysteresis_width': (6.0, 20.0, False),
    'effects.emissivity': (0.5, 0.95, False),
    'effects.convection_exponent': (0.15, 0.4, False),
    'effects.extra_softening': (4e6, 1.5e7, True),
    'effects.sensor_lag': (0.15, 1.0, True),
    'effects.ambient_offset': (2.0, 8.0, False),  # sign drawn separately
    'effects.power_loss_fraction': (0.08, 0.3, False),
    'effects.dead_time': (0.4, 2.0, False),  # switching and controller delays of a drive
    'effects.second_thermal_lag': (1.0, 5.0, True),  # core behind surface, thread behind heater
    'effects.friction_force': (0.01, 0.04, True),  # pulley bearing / coil-on-coil sliding
}
CONTACT_STROKE_FRACTION = (0.6, 0.85)  # the stop cuts the peak contraction to this fraction
CONTACT_ANGLE_MARGIN_DEG = 0.3  # keep alpha_min this far inside its allowed range (deg)
MASS_RANGE_KG = (0.015, 0.045)
# light loads leave the coils close to touching, where contact binds (Sec. V-D1: 2 g)
CONTACT_MASS_RANGE_KG = (0.005, 0.02)
POWER_RANGE_W = (0.3, 1.5)  # keeps the nominal fiber below about 140 degC
DISPLACEMENT_NOISE_M = (3e-6, 12e-6)  # laser / LVDT noise, 1 sigma
TEMPERATURE_NOISE_K = (0.1, 0.4)  # thermocouple / IR noise, 1 sigma
RESISTANCE_NOISE_OHM = 0.005
CONTACT_PHYSICS_RATE_HZ = 50.0  # Hz, placing the contact stop
MAX_PROFILE_DRAWS = 20  # profiles redrawn when coil contact cannot bind


@dataclass
class SyntheticRecord:
    """A synthetic record and the truth behind it."""

    record: Record
    effects: list  # hidden effect names, catalogue order
    values: dict = field(default_factory=dict)  # dotted name -> hidden value
    noise: dict = field(default_factory=dict)  # channel -> sigma (SI)
    seed: int = 0


def _draw(rng, low, high, log):
    if log:
        return float(math.exp(rng.uniform(math.log(low), math.log(high))))
    return float(rng.uniform(low, high))


def random_power_profile(rng, time):
    """Return a power profile (W) on ``time`` (s): steps, ramps, PRBS and cooling.

    Starts with 2-5 s at zero power so the record begins at ambient equilibrium.
    """
    power = np.zeros_like(time)
    start = rng.uniform(2.0, 5.0)
    end = time[-1]
    kinds = ('step', 'ramp', 'prbs', 'cool')
    last = 'cool'
    while start < end:
        kind = rng.choice([k for k in kinds if k != last])
        length = rng.uniform(10.0, 30.0) if kind != 'prbs' else rng.uniform(15.0, 40.0)
        sel = (time >= start) & (time < start + length)
        if kind == 'step':
            power[sel] = rng.uniform(*POWER_RANGE_W)
        elif kind == 'ramp':
            a, b = rng.uniform(0.0, POWER_RANGE_W[1], size=2)
            power[sel] = a + (b - a) * (time[sel] - start) / length
        elif kind == 'prbs':
            level, hold = rng.uniform(0.6, POWER_RANGE_W[1]), rng.uniform(0.5, 2.0)
            bits = rng.integers(0, 2, size=int(length / hold) + 2)
            power[sel] = level * bits[((time[sel] - start) / hold).astype(int)]
        last = kind
        start += length
    return power


def random_load_profile(rng, time, mass):
    """Return a tensile load (N) on ``time`` (s): m g with 0-3 ramped changes."""
    base = mass * GRAVITY
    load = np.full_like(time, base)
    n_changes = int(rng.integers(0, 4))
    if n_changes == 0:
        return load
    moments = np.sort(rng.uniform(0.1, 0.9, size=n_changes)) * time[-1]
    level = base
    for moment in moments:
        new = base * rng.uniform(0.6, 1.6)
        ramp = rng.uniform(0.5, 2.0)
        frac = np.clip((time - moment) / ramp, 0.0, 1.0)
        load = load + (new - level) * frac
        level = new
    return load


def draw_effect_values(rng, names):
    """Return {dotted name: value} for the effects ``names`` (coil contact excluded)."""
    values = {}
    for name in names:
        for dotted in CATALOGUE[name]:
            if dotted not in EFFECT_RANGES:
                continue
            value = _draw(rng, *EFFECT_RANGES[dotted])
            if dotted == 'effects.ambient_offset':
                value *= rng.choice([-1.0, 1.0])
            values[dotted] = value
    return values


def contact_angle_for_record(params, time, power, load, model, physics_rate, rng):
    """Return alpha_min (deg) making the coil stop bind at a random stroke fraction.

    The stop cuts the lower of the peak contractions of the first TRAIN_FRACTION
    of the record and of the rest to CONTACT_STROKE_FRACTION of itself. Returns
    None when no alpha_min in the allowed range does so for this profile.
    """
    free = params.with_values(**{'coil.contact': False})
    # the peak only places the stop: a coarse physics rate is accurate enough. It is
    # the lower of the peaks of the part the diagnosis trains on by default and of
    # the rest: a stop that binds in one part only is seen by no train/test method.
    contraction = simulate(free, time, power, load, model=model,
                           physics_rate=min(physics_rate, CONTACT_PHYSICS_RATE_HZ)
                           ).displacement
    train = time <= TRAIN_FRACTION * time[-1]
    peak = float(min(contraction[train].max(), contraction[~train].max()))
    km = make_kinetostatic_model(free, model)
    loaded = loaded_length(km, float(load[0]), true_ambient(free.thermal, free.effects))
    length = params.fiber.length
    lo = math.radians(math.degrees(params.coil.min_pitch_angle) + CONTACT_ANGLE_MARGIN_DEG)
    hi = math.radians(math.degrees(params.coil.pitch_angle) - CONTACT_ANGLE_MARGIN_DEG)
    stop_lo = max(loaded - length * math.sin(hi), CONTACT_STROKE_FRACTION[0] * peak)
    stop_hi = min(loaded - length * math.sin(lo), CONTACT_STROKE_FRACTION[1] * peak)
    if stop_hi <= stop_lo:
        return None
    stop = rng.uniform(stop_lo, stop_hi)
    return math.degrees(pitch_angle_of_length(loaded - stop, params.fiber))


def make_synthetic_record(seed, effects='random', n_effects=1, duration=240.0,
                          sample_rate=100.0, config='free_stroke', model='cst',
                          physics_rate=500.0, measure_temperature=True):
    """Return a seeded SyntheticRecord with hidden effect(s) from the catalogue.

    Parameters
    ----------
    seed : int
        Seed of every random draw (profile, magnitudes, noise).
    effects : 'random', None or sequence of str
        'random' draws ``n_effects`` distinct names; None or () hides none.
    duration, sample_rate : float
        Record length (s) and sample rate (Hz).
    config : str
        Nominal params file (path or shipped name).
    model : str
        Kinetostatic model of the truth (rod | cst | love).
    physics_rate : float
        Physics rate (Hz) of the truth simulation; finer than the diagnosis uses.
    measure_temperature : bool
        Include the temperature column.
    """
    rng = np.random.default_rng(seed)
    names = list(CATALOGUE)
    if effects == 'random':
        chosen = list(rng.choice(names, size=n_effects, replace=False))
    else:
        chosen = list(effects or ())
    for name in chosen:
        if name not in CATALOGUE:
            raise ValueError(f'effect {name!r}: not in the catalogue ({", ".join(names)})')
    chosen = [n for n in names if n in chosen]
    values = draw_effect_values(rng, chosen)
    time = np.arange(int(round(duration * sample_rate)) + 1) / sample_rate
    for _ in range(MAX_PROFILE_DRAWS):
        mass = rng.uniform(*(CONTACT_MASS_RANGE_KG if 'coil_contact' in chosen
                             else MASS_RANGE_KG))
        power = random_power_profile(rng, time)
        load = random_load_profile(rng, time, mass)
        params = load_params(config, **{'dynamics.mass': mass,
                                        'dynamics.load': float(load[0])}).with_values(**values)
        if 'coil_contact' not in chosen:
            break
        angle = contact_angle_for_record(params, time, power, load, model, physics_rate, rng)
        if angle is not None:
            values['coil.min_pitch_angle_deg'] = angle
            params = params.with_values(**{'coil.min_pitch_angle_deg': angle})
            break
    else:
        raise RuntimeError(f'seed {seed}: no profile in {MAX_PROFILE_DRAWS} draws lets coil '
                           'contact bind')
    truth = simulate(params, time, power, load, model=model, physics_rate=physics_rate)
    noise = {'displacement': _draw(rng, *DISPLACEMENT_NOISE_M, True),
             'temperature': _draw(rng, *TEMPERATURE_NOISE_K, False),
             'resistance': RESISTANCE_NOISE_OHM}
    n = time.size
    record = Record(
        time=time, power=power, load=load,
        displacement=truth.displacement + noise['displacement'] * rng.standard_normal(n),
        temperature=(truth.temperature + noise['temperature'] * rng.standard_normal(n)
                     if measure_temperature else None),
        resistance=truth.resistance + noise['resistance'] * rng.standard_normal(n),
        meta={'tca': config, 'mass_kg': round(float(mass), 6),
              'sample_rate_hz': float(sample_rate)},
        source=f'synthetic seed {seed}')
    return SyntheticRecord(record=record, effects=chosen, values=values, noise=noise,
                           seed=seed)
