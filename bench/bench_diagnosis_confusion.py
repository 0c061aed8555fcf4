"""Confusion table of the diagnosis by how well the muscle is described (issue 25, item 6).

The records are those of bench_diagnosis_real.py (tca_ros/synthetic/realistic.py:
muscles +-30 % around a preset, rod plants on odd seeds and cst on even ones while the
fits run cst, coloured noise, quantisation, drift, nominal power, 1-100 Hz). Each
case is diagnosed three times on the same records, with the muscle described
(tca_ros/synthetic/descriptions.py)

* **exact**: the truth's values, every effect off, uncertainties of 2-5 %;
* **rough**: the truth's values off by up to s = 10-30 %, uncertainties s;
* **guessed**: the preset-like start, loose uncertainties (x/÷ 2),

each as one record and as several records of the same muscle at other loads
diagnosed together. Families: null, single catalogue effect (all but coil contact),
pairs, out-of-catalogue (a sensor scale nonlinearity, fatigue). Right: a null names
nothing; a single or a pair names exactly its effects (a power loss under a rough or
guessed description, and an effect whose size the description admits, as the diagnosis
reads a joint fit (candidates.twin_shift within 2 spreads: a power loss within the
stated delivered power, an ambient offset within the stated room and, without a
thermometer, T_z, a radiation or a convection exponent within the stated heat loss),
may also be absorbed: nothing named); an out-of-catalogue case is "unexplained" with
nothing named. Singles are also split by the record's conditions (the plant's
kinetostatic model, jittered stamps, a start not at rest: realistic.conditions draws the
last two on rod plants only) and by an oracle
(bench_diagnosis_real.effect_shows): does the truth with its effect switched off
leave structure on the records by the verdict's own test? Where it does not, the
effect left no trace the test sees (right there: nothing named, or the effect itself).
The time is CPU seconds of one process
(time.process_time) per diagnosis, reported per 240 s record at 100 Hz.

    python bench/bench_diagnosis_confusion.py [--null 2] [--per-effect 1] [--pairs 2]
        [--outside 2] [--loads 0.015,0.04] [--tightness exact,rough,guessed] [--jobs 1]
        [--save rows.json]

Printed figures, not assertions.
"""
import one_blas_thread  # noqa: F401  (before NumPy: one BLAS thread per process)
import argparse  # noqa: I100, I201
import collections
import json
import multiprocessing
import os
import sys
import tempfile
import time

from bench_diagnosis_real import effect_shows, EFFECTS, group_of, truth_structured
import numpy as np

from tca_ros.calibration import physical_priors
from tca_ros.calibration.physical_priors import prior_spreads
from tca_ros.diagnosis import diagnose
from tca_ros.diagnosis.described import admitted_effects
from tca_ros.params.files import dump_params, load_params
from tca_ros.synthetic.descriptions import describe, TIGHTNESS
from tca_ros.synthetic.realistic import conditions, OUTSIDE, realistic_case, \
    realistic_loads, truth_path

FAMILIES = ('null', 'single', 'pair', 'out-of-catalogue')
#: an effect a calibrated nominal parameter may take up within a loose enough description
ABSORBABLE = {'power_loss': ('rough', 'guessed')}
UNEXPLAINED = 'unexplained'


def cases(n_null, per_effect, n_pairs, n_outside, seed0):
    """Return [(seed, hidden effect names)]: nulls, singles, pairs, out-of-catalogue."""
    rng = np.random.default_rng(seed0)
    hidden = [[] for _ in range(n_null)]
    hidden += [[name] for name in EFFECTS for _ in range(per_effect)]
    hidden += [list(rng.choice(EFFECTS, size=2, replace=False)) for _ in range(n_pairs)]
    hidden += [[OUTSIDE[k % len(OUTSIDE)]] for k in range(n_outside)]
    return [(seed0 + k, h) for k, h in enumerate(hidden)]


def _diagnosis(paths, description):
    """Return the row's fields of ``paths`` diagnosed (found, verdict, findings, notes, ...).

    ``spreads``: each calibrated value's shift from the description in prior
    spreads ({name: z}), those a sensor's drift made marked in ``drift_shifts``;
    ``jointly``: each set of values any of its calibrations found shifted together
    (physical_priors.jointly_shifted): a row with none is decided as it was without
    that rule.
    """
    fired = []  # the sets of values judged shifted together in any calibration (G80)
    together = physical_priors.jointly_shifted

    def watched(zs):
        out = together(zs)
        if out and sorted(out) not in fired:
            fired.append(sorted(out))
        return out

    physical_priors.jointly_shifted = watched
    t0 = time.process_time()
    try:
        r = diagnose(paths if len(paths) > 1 else paths[0], description, progress=False)
    except Exception as exc:  # a failure is a row of the table, not the end of the run
        return {'found': [f'error: {type(exc).__name__}'], 'rivals': {}, 'helpful': [],
                'verdict': 'error',
                'findings': [], 'notes': [str(exc)[:200]], 'spreads': {},
                'drift_shifts': [], 'cpu': time.process_time() - t0, 'jointly': fired}
    finally:
        physical_priors.jointly_shifted = together
    cal = r.calibration
    findings = ([(n, round(z, 2), list(e)) for n, z, e in cal.findings()]
                if cal is not None else [])
    spreads = ({row.name: round(float(row.z), 2) for row in cal.plausibility()}
               if cal is not None else {})
    return {'found': list(r.effects), 'rivals': {k: list(v) for k, v in r.rivals.items()},
            'helpful': list(r.helpful), 'verdict': r.verdict,
            'explanation': r.explanation,
            'findings': findings, 'notes': list(r.notes), 'spreads': spreads,
            'drift_shifts': sorted(cal.drift_shifts) if cal is not None else [],
            'cpu': time.process_time() - t0, 'jointly': fired}


def run_case(args):
    """Write one case's records and diagnose them under each description; return rows."""
    seed, hidden, directory, masses, tightnesses = args
    case_dir = os.path.join(directory, f'{seed}_{len(masses)}')
    os.makedirs(case_dir, exist_ok=True)
    try:
        if masses:
            paths, start_path = realistic_loads(seed, hidden, case_dir, masses)
        else:
            path, start_path = realistic_case(seed, hidden, case_dir)
            paths = [path]
    except (ValueError, ArithmeticError) as exc:  # the plant itself cannot be simulated
        return [{'seed': seed, 'hidden': hidden, 'records': max(len(masses), 1),
                 'skipped': str(exc).splitlines()[0]}]
    truth, start = load_params(truth_path(case_dir, seed)), load_params(start_path)
    structured = truth_structured(paths[0], truth_path(case_dir, seed))
    shows = (effect_shows(paths, [truth_path(case_dir, seed, k) for k in range(len(paths))])
             if group_of(hidden) in ('single', 'pair') else None)
    rows = []
    for tightness in tightnesses:
        rng = np.random.default_rng([seed, TIGHTNESS.index(tightness)])
        description = os.path.join(case_dir, f'{tightness}.yaml')
        described = describe(truth, start, tightness, rng)
        dump_params(described, description)
        rows.append({'seed': seed, 'hidden': hidden, 'family': group_of(hidden),
                     'tightness': tightness, 'records': len(paths),
                     **_diagnosis(paths, description), 'truth_structured': structured,
                     'effect_shows': shows,
                     'admitted': admitted_by(hidden, truth, described, conditions(seed)),
                     **conditions(seed)})
    return rows


def admitted_by(hidden, truth, described, condition):
    """Return the hidden effects whose size the description ``described`` admits.

    described.admitted_effects on the truth, as the diagnosis reads a joint fit: a power
    loss within 2 prior spreads of the stated delivered power, an ambient offset
    within 2 of the room's stated uncertainty (and, without a thermometer, T_z's), a
    radiation whose linearised loss keeps the heat loss within 2 of its stated spread.
    Naming nothing is then right too.
    """
    return list(admitted_effects(hidden, truth, described, prior_spreads(described),
                                 condition['temperature']))


def right(row):
    """Return True when a row's diagnosis is what its truth calls for."""
    hidden, found, family = row['hidden'], set(row['found']), row['family']
    if family == 'out-of-catalogue':
        return not found and row['verdict'] == UNEXPLAINED
    if family == 'null':
        return not found
    if found == set(hidden):
        return True
    absorbable = {h for h in hidden if row['tightness'] in ABSORBABLE.get(h, ())
                  or h in row.get('admitted', ())}
    return bool(absorbable) and found == set(hidden) - absorbable


def right_or_open(row):
    """Return True when a row is right, or right with one named effect read as its open rival.

    The diagnosis names an effect and says these records cannot tell it from a rival
    (its ``rivals``: DiagnosisResult.rivals, 'a or b' in the verdict): the row counts
    when swapping one named effect for one of its open rivals makes it right.
    """
    if right(row):
        return True
    found, rivals = list(row['found']), row.get('rivals') or {}
    return any(right({**row, 'found': found[:i] + [b] + found[i + 1:]})
               for i, a in enumerate(found) for b in rivals.get(a, ()))


def rival_noted(row):
    """Return True when a wrong single names one effect and the notes give the truth as its rival.

    The joint stage and the findings say which other effects explain the records as
    well ('also explained ...', 'also explaining ...', '... are rivals', '... is a rival
    of ...'): records that cannot tell them apart (a sensor lag from a second thermal
    lag on one load, with or without a thermometer).
    """
    if row['family'] != 'single' or len(row['found']) != 1:
        return False
    return any(('also explain' in n or ' rival' in n) and row['hidden'][0] in n
               for n in row['notes'])


#: (label, row -> bool): the record conditions the single-effect rows are split by
RECORD_CONDITIONS = (
    ('cst plant, at rest, even stamps',
     lambda r: r['plant'] == 'cst' and not r['jitter'] and not r['not_at_rest']),
    ('rod plant, jittered stamps', lambda r: r['plant'] == 'rod' and r['jitter']),
    ('rod plant, not at rest', lambda r: r['plant'] == 'rod' and r['not_at_rest']),
    ('rod plant, at rest, even stamps',
     lambda r: r['plant'] == 'rod' and not r['jitter'] and not r['not_at_rest']),
)


def named(row):
    """Return what a row's diagnosis named (or its verdict when it named nothing)."""
    return ' + '.join(row['found']) or (UNEXPLAINED if row['verdict'] == UNEXPLAINED
                                        else row['verdict'])


def print_tables(rows):
    """Print the per-family right shares by tightness, the confusion table and timings."""
    counts = sorted({r['records'] for r in rows})
    tights = [t for t in TIGHTNESS if any(r['tightness'] == t for r in rows)]
    head = ''.join(f'{f"{t}, {n} rec":>16s}' for n in counts for t in tights)
    print(f'{"right (share)":<40s}{head}')

    def line(label, keep, good=right, skip_empty=False):
        """Print one row: per (records, tightness) the rows ``keep`` selects, ``good`` of them."""
        cells = []
        for n in counts:
            for t in tights:
                sub = [r for r in rows if r['tightness'] == t and r['records'] == n and keep(r)]
                cells.append(f'{sum(map(good, sub))}/{len(sub)}' if sub else '-')
        if not skip_empty or any(c != '-' for c in cells):
            print(f'{label[:40]:<40s}' + ''.join(f'{c:>16s}' for c in cells))

    for family in FAMILIES:
        line(family, lambda r, f=family: r['family'] == f, skip_empty=True)
    line('nulls with nothing named', lambda r: r['family'] == 'null',
         good=lambda r: not r['found'])
    for name, label in (('nominal_power', 'power logged as the command'),
                        ('truth_structured', 'the truth itself structured')):
        for value in (False, True):
            line(f'single, {"" if value else "not "}{label}',
                 lambda r, k=name, v=value: r['family'] == 'single' and bool(r[k]) == v)
    # the record conditions go with the seed (realistic.conditions): jittered stamps and
    # a start not at rest are drawn on rod plants only, so a condition's row is its plant's
    for label, keep in RECORD_CONDITIONS:
        line(f'single, {label}', lambda r, k=keep: r['family'] == 'single' and k(r),
             skip_empty=True)
    line('single, right or the truth a noted rival', lambda r: r['family'] == 'single',
         good=lambda r: right(r) or rival_noted(r))
    if any('rivals' in r for r in rows):  # rows saved before the verdict said open rivals
        for family in ('single', 'pair'):
            line(f'{family}, right or the truth an open rival',
                 lambda r, f=family: r['family'] == f and 'rivals' in r, good=right_or_open,
                 skip_empty=True)
    # the oracle of effect_shows: can the verdict's test see the hidden effect at all?
    if any(r.get('effect_shows') is not None for r in rows):
        line('single, its effect shows', lambda r: r['family'] == 'single'
             and r.get('effect_shows') is True)
        line('single, no trace: nothing or it named', lambda r: r['family'] == 'single'
             and r.get('effect_shows') is False, good=lambda r: right(r) or not r['found'])
        # what a diagnosis can get wholly right: the effect leaves a trace, and the
        # plant's own parameters leave no structure the verdict could not explain
        line('single, shows, truth not structured', lambda r: r['family'] == 'single'
             and r.get('effect_shows') is True and not r['truth_structured'])
    wrong = [r for r in rows if r['family'] != 'null' and set(r['found']) - set(r['hidden'])]
    print(f'an effect named that was not hidden: {len(wrong)}/{len(rows)} diagnoses')
    print(f'\n{"hidden":<34s}{"tightness":<10s}{"rec":>4s}  named (count)')
    table = collections.defaultdict(collections.Counter)
    for r in rows:
        table[(' + '.join(r['hidden']) or 'none', r['tightness'], r['records'])][named(r)] += 1
    order = {t: k for k, t in enumerate(TIGHTNESS)}
    for key in sorted(table, key=lambda k: (k[0], k[2], order[k[1]])):
        cells = ', '.join(f'{k} ({v})' for k, v in table[key].most_common())
        print(f'{key[0]:<34s}{key[1]:<10s}{key[2]:>4d}  {cells}')
    print('\nCPU s per diagnosis (one process), 240 s records')
    for n in counts:
        for rate in sorted({r['rate'] for r in rows}, reverse=True):
            secs = [r['cpu'] / n for r in rows if r['records'] == n and r['rate'] == rate]
            if secs:
                print(f'  {n} record(s) at {rate:5.0f} Hz: per record median '
                      f'{np.median(secs):5.1f} s, worst {max(secs):5.1f} s ({len(secs)} runs)')


def print_saved(paths):
    """Print the tables of the rows saved in the JSON files ``paths`` (--save); return 0.

    Returns 2, with a one-line error, when a file cannot be read as --save writes them.
    """
    rows = {}
    for path in paths:
        try:
            with open(path) as f:
                for r in json.load(f):
                    if 'skipped' not in r:
                        rows[(r['seed'], r['records'], r['tightness'])] = r
        except (OSError, ValueError, KeyError, TypeError) as exc:
            print(f'--tables {path!r}: not a file of rows as --save writes them ({exc!r})',
                  file=sys.stderr)
            return 2
    print(f'{len(rows)} diagnoses read from {len(paths)} file(s)')
    print_tables(list(rows.values()))
    return 0


def main(argv=None):
    """Run the benchmark; print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--null', type=int, default=2)
    parser.add_argument('--per-effect', type=int, default=1)
    parser.add_argument('--pairs', type=int, default=2)
    parser.add_argument('--outside', type=int, default=2)
    parser.add_argument('--loads', default='0.015,0.04',
                        help='hanging masses (kg) of the several-record cases ("" for none)')
    parser.add_argument('--single', type=int, default=1, help='1: also one record alone')
    parser.add_argument('--tightness', default=','.join(TIGHTNESS))
    parser.add_argument('--jobs', type=int, default=1)
    parser.add_argument('--seed', type=int, default=9100)
    parser.add_argument('--only', default='', help='comma-separated seeds to run')
    parser.add_argument('--save', default='', help='write the rows as JSON to this file')
    parser.add_argument('--tables', default='',
                        help='comma-separated JSON files of --save: print their tables, run '
                             'nothing (a row of a later file replaces one of an earlier file '
                             'with the same seed, records and tightness)')
    args = parser.parse_args(argv)
    if args.tables:
        return print_saved(args.tables.split(','))
    masses = tuple(float(m) for m in args.loads.split(',') if m)
    tights = tuple(t for t in args.tightness.split(',') if t)
    todo = cases(args.null, args.per_effect, args.pairs, args.outside, args.seed)
    if args.only:
        keep = {int(s) for s in args.only.split(',')}
        todo = [c for c in todo if c[0] in keep]
    layouts = ([()] if args.single else []) + ([masses] if masses else [])
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as directory:
        work = [(seed, hidden, directory, m, tights) for m in layouts for seed, hidden in todo]
        with multiprocessing.Pool(args.jobs) as pool:
            rows = []
            for rs in pool.imap_unordered(run_case, work):
                rows += rs
                for r in rs:  # one line per diagnosis as it ends (a long run shows its progress)
                    print(f'  {r["seed"]} {"+".join(r["hidden"]) or "none":<34s} '
                          f'{r.get("tightness", "-"):<8s} {r["records"]} rec: '
                          f'{named(r) if "skipped" not in r else "skipped"} '
                          f'({"right" if "skipped" not in r and right(r) else "-"}, '
                          f'{r.get("cpu", 0):.0f} s)', file=sys.stderr, flush=True)
    skipped = [r for r in rows if 'skipped' in r]
    rows = [r for r in rows if 'skipped' not in r]
    print(f'{len(rows)} diagnoses of {len(todo)} muscles in {time.perf_counter() - start:.0f} s '
          f'wall ({args.jobs} jobs)')
    for r in skipped:
        print(f'  skipped {r["seed"]} ({"+".join(r["hidden"]) or "none"}, {r["records"]} '
              f'records): the plant cannot be simulated ({r["skipped"]})')
    print_tables(rows)
    if args.save:
        with open(args.save, 'w') as f:
            json.dump(rows, f, indent=1, default=str)
    return 0


if __name__ == '__main__':
    sys.exit(main())
