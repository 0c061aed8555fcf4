"""Diagnosis on records the nominal model did not make: a confusion table (issue 9).

Each record comes from a random muscle (geometry and thermal constants +-30 %,
time constant, rise, actuation gain and damping drawn independently; see
tca_ros/diagnosis/realistic.py), a random power profile (steps, ramps, PRBS,
cooling) under a hanging mass, simulated with the full central-difference
dynamics at 500 Hz by the rod model for odd seeds and cst for even ones, sampled
at 100, 20 or 5 Hz, with AR(1) coloured + white noise and encoder quantisation;
temperature measured on half of them. The diagnosis sees the record and the
muscle's description (geometry known, the rest nominal, model cst) and
calibrates first. Cases: null, each catalogue effect but coil contact, random
pairs, and two out-of-catalogue defects (a slow sensor drift, a sensor scale
nonlinearity) that must give "unexplained" with no effect named.

    python bench/bench_diagnosis_real.py [--null 8] [--per-effect 3] [--pairs 6]
                                          [--outside 6] [--jobs 2]

Printed figures, not assertions.
"""
import argparse
import collections
import math
import multiprocessing
import os
import sys
import tempfile
import time

import numpy as np

from tca_ros.diagnosis import diagnose
from tca_ros.diagnosis.data import Record, write_csv_record
from tca_ros.diagnosis.generator import draw_effect_values, random_power_profile
from tca_ros.diagnosis.realistic import draw_muscle
from tca_ros.model.dynamics import simulate
from tca_ros.model.effects import CATALOGUE
from tca_ros.model.params import dump_params, GRAVITY

EFFECTS = [name for name in CATALOGUE if name != 'coil_contact']
OUTSIDE = ('sensor_drift', 'sensor_nonlinearity')
RATES = (100.0, 20.0, 5.0)
NULL = 'none'
UNEXPLAINED = 'unexplained'


def make_case(seed, hidden, directory, duration=240.0):
    """Write one record and its muscle description; return (record path, start path)."""
    rng = np.random.default_rng(seed)
    start, truth, _, _ = draw_muscle(rng)
    rate = RATES[seed % len(RATES)]
    time_s = np.arange(int(round(duration * rate)) + 1) / rate
    power = random_power_profile(rng, time_s)
    mass = rng.uniform(0.015, 0.04)
    load = np.full_like(time_s, mass * GRAVITY)
    truth = truth.with_values(**{'dynamics.mass': mass, 'dynamics.load': mass * GRAVITY})
    inside = [h for h in hidden if h in CATALOGUE]
    truth = truth.with_values(**draw_effect_values(rng, inside))
    model = 'rod' if seed % 2 else 'cst'
    sim = simulate(truth, time_s, power, load, model=model, physics_rate=500.0)
    n = time_s.size
    a = math.exp(-1.0 / (rate * 2.0))
    ar = np.zeros(n)
    shocks = rng.standard_normal(n) * 20e-6 * math.sqrt(1.0 - a * a)
    for k in range(1, n):
        ar[k] = a * ar[k - 1] + shocks[k]
    x = sim.displacement
    if 'sensor_nonlinearity' in hidden:
        x = x + 8.0 * x ** 2  # 8 /m: 0.8 mm read extra at 10 mm
    x = x + ar + 3e-6 * rng.standard_normal(n)
    if 'sensor_drift' in hidden:
        x = x + rng.choice([-1.0, 1.0]) * 0.4e-3 * time_s / time_s[-1]
    x = np.round(x / 2e-6) * 2e-6
    temperature = (sim.temperature + 0.2 * rng.standard_normal(n)) if seed % 4 < 2 else None
    start_path = os.path.join(directory, f'start_{seed}.yaml')
    dump_params(start.with_values(model='cst'), start_path)
    record = Record(time=time_s, power=power, load=load, displacement=x - x[0],
                    temperature=temperature,
                    meta={'tca': os.path.basename(start_path), 'mass_kg': round(mass, 6),
                          'sample_rate_hz': rate})
    path = os.path.join(directory, f'record_{seed}.csv')
    write_csv_record(record, path)
    return path, start_path


def run_case(args):
    """Diagnose one case; return (hidden, found, verdict, seconds, rate, temperature)."""
    seed, hidden, directory = args
    path, start = make_case(seed, hidden, directory)
    t0 = time.perf_counter()
    try:
        result = diagnose(path, start, progress=False)
        found, verdict = list(result.effects), result.verdict
    except Exception as exc:  # a failure is a row of the table, not the end of the run
        found, verdict = [f'error: {type(exc).__name__}'], 'error'
    return hidden, found, verdict, time.perf_counter() - t0, RATES[seed % len(RATES)], \
        seed % 4 < 2


def cases(n_null, per_effect, n_pairs, n_outside, seed0):
    """Return [(seed, hidden names)]."""
    rng = np.random.default_rng(seed0)
    out, seed = [], seed0
    for _ in range(n_null):
        out.append((seed, []))
        seed += 1
    for name in EFFECTS:
        for _ in range(per_effect):
            out.append((seed, [name]))
            seed += 1
    for _ in range(n_pairs):
        out.append((seed, list(rng.choice(EFFECTS, size=2, replace=False))))
        seed += 1
    for k in range(n_outside):
        out.append((seed, [OUTSIDE[k % len(OUTSIDE)]]))
        seed += 1
    return out


def main(argv=None):
    """Run the benchmark; print the confusion table and timings."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--null', type=int, default=8)
    parser.add_argument('--per-effect', type=int, default=3)
    parser.add_argument('--pairs', type=int, default=6)
    parser.add_argument('--outside', type=int, default=6)
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--seed', type=int, default=9000)
    args = parser.parse_args(argv)
    todo = cases(args.null, args.per_effect, args.pairs, args.outside, args.seed)
    with tempfile.TemporaryDirectory() as directory:
        work = [(seed, hidden, directory) for seed, hidden in todo]
        start = time.perf_counter()
        with multiprocessing.Pool(args.jobs) as pool:
            rows = pool.map(run_case, work, chunksize=1)
        wall = time.perf_counter() - start
    table = collections.defaultdict(collections.Counter)
    exact = collections.Counter()
    for hidden, found, verdict, _, _, _ in rows:
        key = ' + '.join(hidden) or NULL
        group = ('out-of-catalogue' if hidden and hidden[0] in OUTSIDE else
                 'null' if not hidden else 'pair' if len(hidden) > 1 else 'single')
        table[key][' + '.join(found) or (UNEXPLAINED if verdict == UNEXPLAINED else NULL)] += 1
        if group == 'out-of-catalogue':
            exact[group] += int(not found and verdict == UNEXPLAINED)
        elif group == 'null':
            exact[group] += int(not found)
        else:
            exact[group] += int(set(hidden) == set(found))
        exact[group + ' n'] += 1
    print(f'{len(rows)} records diagnosed in {wall:.0f} s wall ({args.jobs} jobs)')
    print(f'{"hidden":<42s} found (count)')
    for key in sorted(table):
        found = ', '.join(f'{k} ({v})' for k, v in table[key].most_common())
        print(f'{key:<42s} {found}')
    for group in ('null', 'single', 'pair', 'out-of-catalogue'):
        if exact[group + ' n']:
            print(f'{group:<18s} right: {exact[group]}/{exact[group + " n"]}')
    for rate in RATES:
        secs = [r[3] for r in rows if r[4] == rate]
        if secs:
            print(f'{rate:5.0f} Hz, 240 s: median {np.median(secs):.1f} s, max {max(secs):.1f} s '
                  f'per record ({len(secs)} records)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
