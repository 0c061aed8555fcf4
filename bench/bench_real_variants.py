"""The real records changed as other rigs and loggers would give them: does the diagnosis hold?

For a few records of ../shared/realdata/salp_tca/records (skipped when absent), each
diagnosed (rod model, calibrated first) as it is and in variants a user's muscle
and logger may produce that these files do not show:

- ``1 Hz``: block-averaged to 1 Hz (a slow logger);
- ``two cycles``: the record followed by itself, the second cycle starting where
  the first ended (a test with repeated steps);
- ``analog sensor``: white noise (20 um), AR(1) noise (30 um, 2 s) and a linear
  drift of 0.3 mm over the record on top (a laser or potentiometer, not an encoder);
- ``description 30 g``: the record's header says 30 g where the muscle carried 10 g
  (the header's mass is the moving mass of eq. (18); the load column still carries
  the 10 g weight): a wrong description that must not crash or change the verdict;
- ``cst``: diagnosed with the cst model instead of the rod model.

Printed: verdict, what is named and helpful, the held-out RMSE, CPU time; an
error is a row. What a variant should not do is crash or name an effect it does
not need (compare with ``as is``).

    python bench/bench_real_variants.py [DIR] [--jobs 2] [--records N ...]
"""
import one_blas_thread  # noqa: F401  (before NumPy: one BLAS thread per process)
import argparse  # noqa: I100, I201
import dataclasses
import os
import sys
import tempfile
import time

from bench_diagnosis_real import _length, _mandrel, REAL_DIR, timed_pool_map
from bench_real import SALP_MUSCLE
import numpy as np

from tca_ros.diagnosis.identification import diagnose
from tca_ros.model.muscle import describe_muscle
from tca_ros.params.files import dump_params
from tca_ros.params.thread_presets import load_thread_presets
from tca_ros.records.data import read_record, write_csv_record
from tca_ros.records.record_ops import decimated
from tca_ros.synthetic.realistic import ar1

DEFAULT_RECORDS = ('1W_encoder_4', '2W_encoder_1.csv', '3W_encoder_2a')
VARIANTS = ('as is', '1 Hz', 'two cycles', 'analog sensor', 'description 30 g', 'cst')


def variant_record(record, variant, rng):
    """Return (record, model) of ``variant`` of a real record."""
    if variant == '1 Hz':
        return decimated(record, 1.0), 'rod'
    if variant == 'two cycles':
        period = record.time[1] - record.time[0]
        shift = record.time[-1] - record.time[0] + period
        return dataclasses.replace(
            record, time=np.concatenate([record.time, record.time + shift]),
            power=np.tile(record.power, 2), load=np.tile(record.load, 2),
            displacement=np.concatenate([record.displacement, record.displacement
                                         + record.displacement[-1]])), 'rod'
    if variant == 'analog sensor':
        n, rate = record.time.size, record.sample_rate
        x = (record.displacement + 20e-6 * rng.standard_normal(n)
             + ar1(rng, n, rate, 30e-6, tau=2.0)
             + 0.3e-3 * (record.time - record.time[0]) / np.ptp(record.time))
        return dataclasses.replace(record, displacement=x - x[0]), 'rod'
    if variant == 'description 30 g':
        return dataclasses.replace(record, meta={**record.meta, 'mass_kg': 0.03}), 'rod'
    return record, 'cst' if variant == 'cst' else 'rod'


def run_case(args):
    """Diagnose one variant of one record; return a dict row."""
    path, variant, work = args
    rng = np.random.default_rng(7)
    record, model = variant_record(read_record(path), variant, rng)
    name = os.path.basename(path).replace('encoder_0.8mm_', '').replace('.csv', '')
    tag = f'{name}_{variant.replace(" ", "_")}'
    rec_path = os.path.join(work, f'{tag}.csv')
    write_csv_record(record, rec_path)
    start_path = os.path.join(work, f'{tag}.yaml')
    spec = dataclasses.replace(SALP_MUSCLE, loaded_length=_length(path),
                               mandrel_diameter=_mandrel(path))
    dump_params(describe_muscle(spec, load_thread_presets()).params, start_path)
    t0 = time.process_time()
    row = {'record': name, 'variant': variant}
    try:
        r = diagnose(rec_path, start_path, model=model, progress=False)
    except Exception as exc:  # a failure is a row of the table
        row.update(verdict=f'{type(exc).__name__}: {str(exc).splitlines()[0]}'[:90])
    else:
        row.update(verdict=r.verdict, named='+'.join(r.effects) or '-',
                   helpful='+'.join(r.helpful) or '-',
                   rmse=(r.nominal_rmse['displacement'] * 1e3,
                         r.extended_rmse['displacement'] * 1e3))
    row['cpu'] = time.process_time() - t0
    return row


def main(argv=None):
    """Run the variants; return the exit status (0, or 0 with a note when skipped)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('dir', nargs='?', default=REAL_DIR)
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--records', nargs='*', default=list(DEFAULT_RECORDS),
                        help='parts of file names to pick')
    args = parser.parse_args(argv)
    if not os.path.isdir(args.dir):
        print(f'real records: {args.dir} absent; skipped')
        return 0
    names = sorted(os.listdir(args.dir))
    paths = [os.path.join(args.dir, next(n for n in names if key in n))
             for key in args.records if any(key in n for n in names)]
    with tempfile.TemporaryDirectory() as work:
        cases = [(p, v, work) for p in paths for v in VARIANTS]
        rows, wall = timed_pool_map(run_case, cases, args.jobs)
    print(f'{len(rows)} diagnoses of {len(paths)} real records in variants, {wall:.0f} s wall, '
          f'{args.jobs} jobs (rod model unless cst; calibrated first)')
    print(f'{"record":<18s} {"variant":<17s} {"verdict":<12s} {"named":<20s} '
          f'{"helpful":<20s} {"held-out RMSE":<22s} {"CPU s":>6s}')
    for row in rows:
        if 'rmse' not in row:
            print(f'{row["record"]:<18s} {row["variant"]:<17s} {row["verdict"]}')
            continue
        a, b = row['rmse']
        print(f'{row["record"]:<18s} {row["variant"]:<17s} {row["verdict"]:<12s} '
              f'{row["named"]:<20s} {row["helpful"]:<20s} {a:6.2f} -> {b:5.2f} mm'
              f'{"":<6s} {row["cpu"]:6.0f}')
    errors = [r for r in rows if 'rmse' not in r]
    print(f'errors: {len(errors)} of {len(rows)}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
