"""Benchmark the diagnosis on seeded synthetic records (issue 5, item 5).

Prints a confusion table (true hidden effects vs effects found, including the
null case and two-effect cases), verdict counts, held-out gains and the wall and
CPU time of ``diagnose`` per record (one BLAS thread per process). Printed figures,
not assertions.

    python bench/bench_diagnosis.py                      # 54 records, 240 s at 100 Hz
    python bench/bench_diagnosis.py --per-effect 1 --null 2 --pairs 2 --jobs 2
"""
import one_blas_thread  # noqa: F401  (before NumPy: one BLAS thread per process)
import argparse  # noqa: I100, I201
import collections
import multiprocessing
import os
import sys
import tempfile
import time

import numpy as np

from tca_ros.diagnosis import diagnose
from tca_ros.model.effects import CATALOGUE
from tca_ros.records.data import write_csv_record
from tca_ros.synthetic.generator import make_synthetic_record

NULL = 'none'


def cases(per_effect, n_null, n_pairs, seed0):
    """Return [(seed, effects spec, n_effects)]: each effect, null, random pairs."""
    out = []
    seed = seed0
    for name in CATALOGUE:
        for _ in range(per_effect):
            out.append((seed, [name], 1))
            seed += 1
    for _ in range(n_null):
        out.append((seed, None, 0))
        seed += 1
    for _ in range(n_pairs):
        out.append((seed, 'random', 2))
        seed += 1
    return out


def run_case(args):
    """Generate one record, diagnose it; return a result row (dict)."""
    (seed, spec, n_effects), duration, rate, model, workdir = args
    synth = make_synthetic_record(seed, effects=spec, n_effects=max(n_effects, 1),
                                  duration=duration, sample_rate=rate)
    path = os.path.join(workdir, f'record_{seed}.csv')
    write_csv_record(synth.record, path)
    start, cpu = time.perf_counter(), time.process_time()
    result = diagnose(path, 'free_stroke', model=model, progress=False)
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    return {'seed': seed, 'truth': synth.effects, 'found': result.effects,
            'verdict': result.verdict, 'gain': result.gain_percent, 'time': elapsed,
            'cpu': cpu,
            'values': synth.values, 'fitted': result.extended_values,
            'sims': result.n_simulations}


def print_confusion(rows):
    """Print the single-effect confusion table: true effect x first effect named."""
    labels = list(CATALOGUE) + [NULL]
    short = {n: n[:6] for n in labels}
    short.update({'nonlinear_convection': 'nconv', 'modulus_softening': 'modsft',
                  'coil_contact': 'contct', 'sensor_lag': 'lag', 'ambient_offset': 'ambofs',
                  'power_loss': 'ploss', 'hysteresis': 'hyster', 'radiation': 'radiat'})
    table = collections.defaultdict(collections.Counter)
    extra = collections.Counter()
    for row in rows:
        if len(row['truth']) > 1:
            continue
        truth = row['truth'][0] if row['truth'] else NULL
        found = row['found']
        table[truth][found[0] if found else NULL] += 1
        if len(found) > 1:
            extra[truth] += 1
    print('\nsingle hidden effect (rows: truth; columns: first effect named; '
          '+extra: further effects also named)')
    print(f'{"truth":<21s}' + ''.join(f'{short[c]:>7s}' for c in labels) + '  correct  +extra')
    total = right = 0
    for truth in labels:
        if truth not in table:
            continue
        counts = table[truth]
        n = sum(counts.values())
        ok = counts[truth]
        total, right = total + n, right + ok
        print(f'{truth:<21s}' + ''.join(f'{counts[c] or ".":>7}' for c in labels)
              + f'  {ok:>3d}/{n:<3d} {extra[truth]:>5d}')
    share = 100.0 * right / max(total, 1)
    print(f'single-effect and null accuracy: {right}/{total} = {share:.0f} %')


def print_pairs(rows):
    """Print the two-effect cases: truth, found, verdict."""
    pairs = [r for r in rows if len(r['truth']) == 2]
    if not pairs:
        return
    print('\ntwo hidden effects')
    both = 0
    for r in pairs:
        hit = set(r['truth']) <= set(r['found'])
        exact = set(r['truth']) == set(r['found'])
        both += hit
        print(f'  seed {r["seed"]:4d}  truth {" + ".join(r["truth"]):<38s} found '
              f'{" + ".join(r["found"]) or NULL:<45s} {r["verdict"]:<11s} '
              f'{"both" if hit else "missed"}{"" if exact or not hit else " (+extra)"}')
    print(f'both effects found: {both}/{len(pairs)}')


def main(argv=None):
    """Run the benchmark; print the tables; return 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument('--per-effect', type=int, default=4, help='records per effect (-)')
    parser.add_argument('--null', type=int, default=8, help='records with no effect (-)')
    parser.add_argument('--pairs', type=int, default=10, help='records with two effects (-)')
    parser.add_argument('--duration', type=float, default=240.0, help='record length (s)')
    parser.add_argument('--rate', type=float, default=100.0, help='sample rate (Hz)')
    parser.add_argument('--model', default='cst', help='kinetostatic model of the fits')
    parser.add_argument('--seed', type=int, default=1000, help='first seed (-)')
    parser.add_argument('--jobs', type=int, default=1,
                        help='parallel processes (time per record is per process)')
    args = parser.parse_args(argv)
    todo = cases(args.per_effect, args.null, args.pairs, args.seed)
    print(f'{len(todo)} records of {args.duration:g} s at {args.rate:g} Hz, model '
          f'{args.model}, {args.jobs} process(es)', flush=True)
    with tempfile.TemporaryDirectory() as workdir:
        work = [(c, args.duration, args.rate, args.model, workdir) for c in todo]
        start = time.perf_counter()
        if args.jobs > 1:
            with multiprocessing.Pool(args.jobs) as pool:
                rows = []
                for row in pool.imap_unordered(run_case, work):
                    rows.append(row)
                    print(f'  seed {row["seed"]}: truth {row["truth"]} found {row["found"]} '
                          f'{row["verdict"]} {row["time"]:.1f} s', flush=True)
        else:
            rows = []
            for w in work:
                row = run_case(w)
                rows.append(row)
                print(f'  seed {row["seed"]}: truth {row["truth"]} found {row["found"]} '
                      f'{row["verdict"]} {row["time"]:.1f} s', flush=True)
        wall = time.perf_counter() - start
    rows.sort(key=lambda r: r['seed'])
    print_confusion(rows)
    print_pairs(rows)
    verdicts = collections.Counter(r['verdict'] for r in rows)
    print('\nverdicts: ' + ', '.join(f'{k} {v}' for k, v in sorted(verdicts.items())))
    gains = np.array([r['gain'] for r in rows if r['truth']])
    if gains.size:
        print(f'held-out displacement gain with hidden effects: median '
              f'{np.median(gains):.1f} %, min {gains.min():.1f} %')
    for key, what in (('time', 'wall'), ('cpu', 'CPU')):
        times = np.array([r[key] for r in rows])
        print(f'diagnose {what} time per {args.duration:g} s / {args.rate:g} Hz record: median '
              f'{np.median(times):.1f} s, mean {times.mean():.1f} s, max {times.max():.1f} s '
              f'(target: median <= 20 s, max <= 60 s on one core)')
    print(f'{wall:.0f} s in all, one BLAS thread per process (one_blas_thread.py)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
