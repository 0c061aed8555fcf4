"""Write the shipped example inputs of tca_ros/data/examples/ (synthetic, seeded).

Power profiles (``profile_*.csv``: columns ``time,power`` and optionally ``load`` or
``power_2``, one row per change, held until the next) and example records
(``rec_*.csv``: the record format of docs/records.md) of the free-stroke TCA
(config/free_stroke.yaml), simulated by this project's own simulator
(tca_ros.model.simulation.simulate, the config's rod model, physics at 1 kHz) with
ONE hidden effect the nominal config does not have: 15 % of the logged electrical
power never heats the fiber (``effects.power_loss_fraction`` = 0.15: leads,
contacts, clamps). White Gaussian sensor noise (seeded) is added to the measured
columns. Every file says it is synthetic in its header comment.

Usage: ``python bench/make_examples.py [--out tca_ros/data/examples] [--seed 27]``.
Rerunning with the same seed rewrites identical files (the check in
test/test_compare.py).
"""
import argparse
import os

import numpy as np

from tca_ros.model.params_schema import GRAVITY
from tca_ros.model.simulation import simulate
from tca_ros.params.files import load_params
from tca_ros.records.data import write_csv_record
from tca_ros.records.record import Record

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_OUT = os.path.normpath(os.path.join(HERE, '..', 'tca_ros', 'data', 'examples'))
CONFIG = 'free_stroke'
SEED = 27
HIDDEN = {'effects.power_loss_fraction': 0.15}  # the one hidden effect (docs/records.md)
RATE_HZ = 20.0  # record sample rate (Hz)
PHYSICS_RATE_HZ = 1000.0  # truth simulation (Hz)
DURATION_S = 40.0  # s: 2 s at rest, 15 s heating, 23 s cooling
HEAT_ON_S, HEAT_OFF_S = 2.0, 17.0
NOISE = {'displacement': 5e-6, 'temperature': 0.2, 'resistance': 0.005}  # m, K, ohm (1 sigma)
# name -> (power W, hanging mass kg, temperature recorded)
RECORDS = {
    'rec_0p5W_30g': (0.5, 0.030, True),
    'rec_1W_30g': (1.0, 0.030, True),
    'rec_1p5W_30g': (1.5, 0.030, True),
    'rec_1W_50g': (1.0, 0.050, True),
}
# name -> (header, rows): each row holds from its time to the next (zero-order hold)
PROFILES = {
    'profile_steps': ('time,power', [(0, 0.0), (2, 1.0), (17, 0.0), (32, 1.5), (47, 0.0),
                                     (60, 0.0)]),
    'profile_load': ('time,power,load', [(0, 0.0, 0.2943), (2, 1.0, 0.2943),
                                         (12, 1.0, 0.4905), (22, 0.0, 0.4905),
                                         (40, 0.0, 0.4905)]),
    'profile_pair': ('time,power,power_2', [(0, 0.0, 0.0), (2, 1.0, 0.0), (17, 0.0, 0.0),
                                            (22, 0.0, 1.0), (37, 0.0, 0.0), (50, 0.0, 0.0)]),
}
SYNTHETIC = ('synthetic: yes, SYNTHETIC data simulated by tca_ros (bench/make_examples.py, '
             f'seed {SEED}), not a measurement')
EFFECT = ('hidden_effect: power_loss_fraction 0.15 (15 % of the logged power does not heat '
          'the fiber; config free_stroke has 0)')


def make_record(name, power_w, mass, with_temperature, rng):
    """Return the synthetic Record ``name``: a heating step of ``power_w`` W under ``mass`` kg."""
    time = np.arange(int(round(DURATION_S * RATE_HZ)) + 1) / RATE_HZ
    power = np.where((time >= HEAT_ON_S) & (time < HEAT_OFF_S), power_w, 0.0)
    load = np.full_like(time, mass * GRAVITY)
    params = load_params(CONFIG, **{'dynamics.mass': mass, 'dynamics.load': mass * GRAVITY})
    truth = simulate(params.with_values(**HIDDEN), time, power, load,
                     physics_rate=PHYSICS_RATE_HZ)
    noisy = {c: getattr(truth, c) + s * rng.standard_normal(time.size)
             for c, s in NOISE.items()}
    return Record(time=time, power=power, load=load, displacement=noisy['displacement'],
                  temperature=noisy['temperature'] if with_temperature else None,
                  resistance=noisy['resistance'],
                  meta={'tca': CONFIG, 'mass_kg': mass, 'sample_rate_hz': RATE_HZ},
                  source=name)


def write_profile(path, header, rows):
    """Write a power profile CSV (s, W, N) with its synthetic-data comment."""
    with open(path, 'w', encoding='utf-8') as fh:
        fh.write('# example power profile of tca_ros (hand-written steps, not a '
                 'measurement); bench/make_examples.py\n')
        fh.write(header + '\n')
        for row in rows:
            fh.write(','.join(f'{v:g}' for v in row) + '\n')


def main(argv=None):
    """Write every profile and record; print one line per file."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', default=DEFAULT_OUT, help='output directory')
    parser.add_argument('--seed', type=int, default=SEED, help='noise seed')
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    for name, (header, rows) in PROFILES.items():
        path = os.path.join(args.out, name + '.csv')
        write_profile(path, header, rows)
        print(path)
    rng = np.random.default_rng(args.seed)
    for name, (power_w, mass, with_temperature) in RECORDS.items():
        record = make_record(name, power_w, mass, with_temperature, rng)
        path = os.path.join(args.out, name + '.csv')
        write_csv_record(record, path, comments=(SYNTHETIC.replace(str(SEED), str(args.seed)),
                                                 EFFECT))
        peak = 1e3 * float(np.max(record.displacement))
        print(f'{path}: {power_w:g} W, {1e3 * mass:g} g, peak contraction {peak:.2f} mm')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
