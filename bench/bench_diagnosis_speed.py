"""CPU time of `tca_sim diagnose` per 240 s / 100 Hz record (issue 9 speed target).

The records are the 100 Hz ones of bench_diagnosis_real.py's default case list
(realistic.realistic_case: random muscles, cst and rod plants, coloured noise,
drift, jitter, noisy or nominal power, null, single, pair and out-of-catalogue
cases). Each record is diagnosed in a worker process and timed by that
process's CPU time (time.process_time, user + system): the machine is shared,
and wall time measures the other jobs as much as this one. Target: median
<= 20 s, worst <= 60 s per record on one core.

``--save FILE`` writes what each diagnosis found (verdict, effects, helpful,
fitted values with standard errors); ``--compare FILE`` prints, per record,
whether the verdict and named effects are identical to the saved ones and how
far each fitted value moved in units of its standard error.

    python bench/bench_diagnosis_speed.py [--jobs 2] [--seeds 9000 9005 ...]
                                          [--model rod] [--save F.json] [--compare F.json]

``--model rod`` fits with the rod model instead of the descriptions' cst.

Printed figures, not assertions.
"""
import one_blas_thread  # noqa: F401  (before NumPy: one BLAS thread per process)
import argparse  # noqa: I100, I201
import json
import math
import multiprocessing
import sys
import tempfile
import time

import numpy as np

from tca_ros.diagnosis import diagnose
from tca_ros.synthetic.realistic import conditions, realistic_case

TARGET_MEDIAN_S = 20.0  # CPU s per 240 s / 100 Hz record
TARGET_WORST_S = 60.0


def default_cases(seed0=9000):
    """Return [(seed, hidden)] of the 100 Hz records of bench_diagnosis_real's defaults."""
    from bench_diagnosis_real import cases
    return [(s, [str(h) for h in hidden])
            for s, hidden, masses, overrides in cases(12, 3, 8, 8, seed0, n_warm=0)
            if not masses and conditions(s)['rate'] == 100.0]


def _stderrs(result):
    """Return {dotted name: standard error} of the fitted values (NaN when unknown)."""
    out = {}
    if result.calibration is not None:
        for name, e in result.calibration.report.estimates.items():
            out[name] = e.stderr
    for rnd in result.rounds:
        if rnd is None:
            continue
        for score in rnd.scores:
            if score.name == rnd.accepted:
                out.update(score.fit.stderr)
    return out


def run_one(args):
    """Diagnose one case in this process; return a JSON-ready row with its CPU time."""
    seed, hidden, model = args
    with tempfile.TemporaryDirectory() as directory:
        path, start = realistic_case(seed, hidden, directory)
        t0, w0 = time.process_time(), time.perf_counter()
        result = diagnose(path, start, progress=False, model=model)
        cpu, wall = time.process_time() - t0, time.perf_counter() - w0
    stderr = _stderrs(result)
    values = {k: float(v) for k, v in result.extended_values.items()}
    return {'seed': seed, 'hidden': hidden, 'cpu_s': cpu, 'wall_s': wall,
            'verdict': result.verdict, 'effects': list(result.effects),
            'helpful': list(result.helpful), 'values': values,
            'stderr': {k: float(stderr.get(k, math.nan)) for k in values},
            'simulations': result.n_simulations,
            'plant': conditions(seed)['plant']}


def compare(row, old):
    """Return (same verdict and effects, largest |change| / stderr, its name)."""
    same = (row['verdict'] == old['verdict'] and row['effects'] == old['effects']
            and row['helpful'] == old['helpful'])
    worst, where = 0.0, ''
    for name, value in row['values'].items():
        if name not in old['values']:
            return False, math.inf, name
        errs = [e for e in (row['stderr'].get(name), old['stderr'].get(name))
                if e is not None and math.isfinite(e) and e > 0.0]
        scale = max(errs) if errs else 1e-3 * max(abs(value), 1e-12)
        z = abs(value - old['values'][name]) / scale
        if z > worst:
            worst, where = z, name
    return same, worst, where


def main(argv=None):
    """Run the records; print CPU time per record, median and worst."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--jobs', type=int, default=1)
    parser.add_argument('--seeds', type=int, nargs='*')
    parser.add_argument('--save')
    parser.add_argument('--compare')
    parser.add_argument('--model', choices=('rod', 'cst', 'love'),
                        help="fit with this kinetostatic model (default the description's: "
                             'cst)')
    args = parser.parse_args(argv)
    todo = default_cases()
    if args.seeds:
        todo = [(s, h) for s, h in todo if s in args.seeds]
    todo = [(s, h, args.model) for s, h in todo]
    with multiprocessing.Pool(args.jobs) as pool:
        rows = pool.map(run_one, todo, chunksize=1)
    old = {}
    if args.compare:
        with open(args.compare) as f:
            old = {r['seed']: r for r in json.load(f)}
    print(f'{"seed":>5s} {"plant":5s} {"hidden":34s} {"verdict":12s} {"named / helpful":34s} '
          f'{"sims":>5s} {"CPU s":>6s}' + ('  vs saved: same?  max|d|/se' if old else ''))
    for r in rows:
        named = '+'.join(r['effects']) or ('(' + '+'.join(r['helpful']) + ')'
                                           if r['helpful'] else '-')
        line = (f'{r["seed"]:5d} {r["plant"]:5s} {"+".join(r["hidden"]) or "none":34s} '
                f'{r["verdict"]:12s} {named:34s} {r["simulations"]:5d} {r["cpu_s"]:6.1f}')
        if r['seed'] in old:
            o = old[r['seed']]
            same, z, where = compare(r, o)
            line += (f'  {"yes" if same else "NO":>4s} {z:6.2f} {where}'
                     f' (was {o["cpu_s"]:.1f} s)')
        print(line)
    cpu = np.array([r['cpu_s'] for r in rows])
    print(f'CPU time per 240 s / 100 Hz record over {cpu.size} records: median '
          f'{np.median(cpu):.1f} s, mean {cpu.mean():.1f} s, worst {cpu.max():.1f} s '
          f'(target median <= {TARGET_MEDIAN_S:g} s, worst <= {TARGET_WORST_S:g} s)')
    if old:
        before = np.array([old[r['seed']]['cpu_s'] for r in rows if r['seed'] in old])
        print(f'saved run: median {np.median(before):.1f} s, worst {before.max():.1f} s')
    if args.save:
        with open(args.save, 'w') as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == '__main__':
    sys.exit(main())
