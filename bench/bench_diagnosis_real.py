"""Diagnosis on records the nominal model did not make: a confusion table (issue 9).

Each record comes from a random muscle (geometry and thermal constants +-30 %,
time constant, rise, actuation gain and damping drawn independently; see
tca_ros/diagnosis/realistic.py), a random power profile (steps, ramps, PRBS,
cooling) under a hanging mass, simulated with the full central-difference
dynamics at 500 Hz by the rod model for odd seeds and cst for even ones (the
diagnosis fits cst: half the records are kinetostatically mismatched), sampled
at 100, 5, 2, 1 or 20 Hz, with coloured noise (AR(1), 2 s) + white noise +
encoder quantisation on every record, and on a share of them a linear drift,
jittered time stamps, a power logged as the nominal command while the plant
got +-3 % slow variation, white noise on the logged power, and a start that
is not at rest (a heating 30-60 s before the record). Temperature is measured
on half. The diagnosis sees the record and the muscle's description (geometry
known, the rest nominal, model cst) and calibrates first. Cases: null, each
catalogue effect but coil contact, random pairs, and two out-of-catalogue
defects (a sensor scale nonlinearity; an actuation gain that fades by 25 %
over the record, fatigue) that must give "unexplained" with no effect named.
With ``--real DIR`` the shared real records are diagnosed together too.

    python bench/bench_diagnosis_real.py [--null 12] [--per-effect 3] [--pairs 8]
                                          [--outside 8] [--jobs 2] [--real DIR]

Printed figures, not assertions.
"""
import argparse
import collections
import glob
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
#: effects whose signature is a nominal parameter that calibration fits (the
#: delivered power ratio): naming nothing after calibration is the right answer
ABSORBED = ('power_loss',)
OUTSIDE = ('sensor_nonlinearity', 'fatigue')
RATES = (100.0, 5.0, 2.0, 1.0, 20.0)
NULL = 'none'
UNEXPLAINED = 'unexplained'
HERE = os.path.dirname(os.path.abspath(__file__))
REAL_DIR = os.path.normpath(os.path.join(HERE, '..', '..', 'shared', 'realdata', 'salp_tca',
                                         'records'))


def ar1(rng, n, rate, sigma, tau=2.0):
    """Return AR(1) noise of std ``sigma`` and correlation time ``tau`` (s) at ``rate`` Hz."""
    a = math.exp(-1.0 / (rate * tau))
    out = np.zeros(n)
    shocks = rng.standard_normal(n) * sigma * math.sqrt(1.0 - a * a)
    for k in range(1, n):
        out[k] = a * out[k - 1] + shocks[k]
    return out


def conditions(seed):
    """Return the record conditions of ``seed`` (each a different share of the seeds)."""
    return {'rate': RATES[seed % len(RATES)], 'plant': 'rod' if seed % 2 else 'cst',
            'temperature': seed % 4 < 2, 'drift': seed % 3 == 0,
            'nominal_power': seed % 3 == 1, 'noisy_power': seed % 3 == 2,
            'jitter': seed % 4 == 1, 'not_at_rest': seed % 4 == 3}


def make_case(seed, hidden, directory, duration=240.0):
    """Write one record and its muscle description; return (record path, start path)."""
    rng = np.random.default_rng(seed)
    cond = conditions(seed)
    start, truth, _, _ = draw_muscle(rng)
    rate = cond['rate']
    pre = 60.0 if cond['not_at_rest'] else 0.0
    time_s = np.arange(int(round((duration + pre) * rate)) + 1) / rate - pre
    power = random_power_profile(rng, time_s + pre)
    if pre:  # heat 30-60 s before the record, then let it cool: it starts warm
        power[time_s < 0.0] = np.where(time_s[time_s < 0.0] < -30.0, 0.5, 0.0)
        power[(time_s >= 0.0) & (time_s < 3.0)] = 0.0
    mass = rng.uniform(0.015, 0.04)
    load = np.full_like(time_s, mass * GRAVITY)
    truth = truth.with_values(**{'dynamics.mass': mass, 'dynamics.load': mass * GRAVITY})
    inside = [h for h in hidden if h in CATALOGUE]
    truth = truth.with_values(**draw_effect_values(rng, inside))
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
    if cond['jitter']:  # +-20 % of the period; the reader resamples onto the grid
        stamps[1:-1] += rng.uniform(-0.2, 0.2, n - 2) / rate
    temperature = (temperature + 0.2 * rng.standard_normal(n)) if cond['temperature'] else None
    start_path = os.path.join(directory, f'start_{seed}.yaml')
    dump_params(start.with_values(model='cst'), start_path)
    record = Record(time=stamps, power=logged, load=load, displacement=x - x[0],
                    temperature=temperature,
                    meta={'tca': os.path.basename(start_path), 'mass_kg': round(mass, 6),
                          'sample_rate_hz': rate})
    path = os.path.join(directory, f'record_{seed}.csv')
    write_csv_record(record, path)
    return path, start_path


def run_case(args):
    """Diagnose one case; return a dict row of the table."""
    seed, hidden, directory = args
    path, start = make_case(seed, hidden, directory)
    t0 = time.perf_counter()
    try:
        result = diagnose(path, start, progress=False)
        found, helpful, verdict = list(result.effects), list(result.helpful), result.verdict
    except Exception as exc:  # a failure is a row of the table, not the end of the run
        found, helpful, verdict = [f'error: {type(exc).__name__}'], [], 'error'
    return {'seed': seed, 'hidden': hidden, 'found': found, 'helpful': helpful,
            'verdict': verdict, 'seconds': time.perf_counter() - t0, **conditions(seed)}


def group_of(hidden):
    """Return the case group of a hidden-effect list."""
    if not hidden:
        return 'null'
    if hidden[0] in OUTSIDE:
        return 'out-of-catalogue'
    return 'pair' if len(hidden) > 1 else 'single'


def right(row):
    """Return True when the diagnosis of a row is what its truth calls for."""
    hidden, found, group = row['hidden'], row['found'], group_of(row['hidden'])
    if group == 'out-of-catalogue':
        return not found and row['verdict'] == UNEXPLAINED
    if group == 'null':
        return not found
    expected = {h for h in hidden if h not in ABSORBED}
    return set(found) == expected


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
    parser.add_argument('--null', type=int, default=12)
    parser.add_argument('--per-effect', type=int, default=3)
    parser.add_argument('--pairs', type=int, default=8)
    parser.add_argument('--outside', type=int, default=8)
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--seed', type=int, default=9000)
    parser.add_argument('--real', default=REAL_DIR,
                        help='directory of real records diagnosed together ("" to skip)')
    args = parser.parse_args(argv)
    todo = cases(args.null, args.per_effect, args.pairs, args.outside, args.seed)
    rows = []
    if todo:
        with tempfile.TemporaryDirectory() as directory:
            work = [(seed, hidden, directory) for seed, hidden in todo]
            start = time.perf_counter()
            with multiprocessing.Pool(args.jobs) as pool:
                rows = pool.map(run_case, work, chunksize=1)
            wall = time.perf_counter() - start
        print_table(rows, wall, args.jobs)
    if args.real:
        real_records(args.real)
    return 0


def print_table(rows, wall, jobs):
    """Print the confusion table, the per-group scores and the timings."""
    table = collections.defaultdict(collections.Counter)
    score = collections.Counter()
    for row in rows:
        key = ' + '.join(row['hidden']) or NULL
        named = ' + '.join(row['found']) or (UNEXPLAINED if row['verdict'] == UNEXPLAINED
                                             else NULL)
        table[key][named] += 1
        group = group_of(row['hidden'])
        score[group] += int(right(row))
        score[group + ' n'] += 1
    print(f'{len(rows)} records diagnosed in {wall:.0f} s wall ({jobs} jobs)')
    print(f'{"hidden":<44s} named (count)')
    for key in sorted(table):
        named = ', '.join(f'{k} ({v})' for k, v in table[key].most_common())
        print(f'{key:<44s} {named}')
    print(f'(absorbed by calibration, nothing to name: {", ".join(ABSORBED)})')
    for group in ('null', 'single', 'pair', 'out-of-catalogue'):
        if score[group + ' n']:
            print(f'{group:<18s} right: {score[group]}/{score[group + " n"]}')
    null_named = sum(1 for r in rows if group_of(r['hidden']) == 'null' and r['found'])
    outside = [r for r in rows if group_of(r['hidden']) == 'out-of-catalogue']
    print(f'null records with an effect named: {null_named}; out-of-catalogue named: '
          f'{sum(1 for r in outside if r["found"])}, unexplained: '
          f'{sum(1 for r in outside if r["verdict"] == UNEXPLAINED)}/{len(outside)}')
    for name in ('plant', 'drift', 'nominal_power', 'noisy_power', 'jitter', 'not_at_rest',
                 'temperature'):
        for value in sorted({r[name] for r in rows}, key=str):
            sub = [r for r in rows if r[name] == value]
            print(f'  {name}={value}: right {sum(right(r) for r in sub)}/{len(sub)}')
    for rate in RATES:
        secs = [r['seconds'] for r in rows if r['rate'] == rate]
        ok = [right(r) for r in rows if r['rate'] == rate]
        if secs:
            print(f'{rate:5.0f} Hz, 240 s: right {sum(ok)}/{len(ok)}; median '
                  f'{np.median(secs):.1f} s, max {max(secs):.1f} s per record')


def real_records(directory):
    """Diagnose the real records of one muscle together; print what is named."""
    from bench_real import SALP_MUSCLE
    from tca_ros.diagnosis import format_summary
    from tca_ros.model.muscle import describe_muscle
    paths = sorted(glob.glob(os.path.join(directory, '*.csv')))
    if not paths:
        print(f'real records: none in {directory}; skipped')
        return
    with tempfile.TemporaryDirectory() as work:
        start_path = os.path.join(work, 'salp.yaml')
        dump_params(describe_muscle(SALP_MUSCLE).params, start_path)
        t0 = time.perf_counter()
        result = diagnose(paths, start_path, progress=False)
        seconds = time.perf_counter() - t0
    print(f'\nreal records ({len(paths)} from {directory}), diagnosed together in '
          f'{seconds:.0f} s ({seconds / len(paths):.1f} s per record):')
    print(format_summary(result))


if __name__ == '__main__':
    sys.exit(main())
