"""Calibration on real recordings: leave-one-condition-out against two baselines.

    python bench/bench_real.py [DIR] [--model rod|cst|love] [--supply power|voltage]

DIR defaults to ../shared/realdata/salp_tca/records (a mandrel-coiled TCA of an
independent lab, isotonic steps at 1-3 W, 10 g; see its README). The muscle is
described as its maker would (`tca_sim config new` with the README's facts),
calibrated on every record (parameters printed with their standard errors and
the wall time), then scored leave-one-condition-out: calibrated on all powers
but one, the held-out power predicted by the calibrated physics model, by the
uncalibrated description and by the lumped first-order-plus-dead-time model
fitted on the same records. Printed figures, not assertions; skips cleanly when
DIR is absent.
"""
import argparse
import glob
import os
import sys
import time

import numpy as np

from tca_ros.calibration.calibration import calibrate
from tca_ros.calibration.calibration_report import format_summary
from tca_ros.calibration.validation import format_table, leave_one_condition_out
from tca_ros.model.muscle import describe_muscle, MuscleSpec
from tca_ros.params.files import load_params
from tca_ros.params.thread_presets import load_thread_presets
from tca_ros.records.data import read_record

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_DIR = os.path.normpath(os.path.join(HERE, '..', '..', 'shared', 'realdata',
                                            'salp_tca', 'records'))

#: The salp muscle as its README describes it: 4-ply silver-plated nylon 6,6 (about
#: 0.45 mm twisted), coiled on a 0.8 mm mandrel at 22.5 deg, ~140 mm loaded, 13.3 ohm,
#: 10 g hanging weight.
SALP_MUSCLE = MuscleSpec(thread='nylon66_silver', thread_diameter=0.45e-3, coil='mandrel',
                         mandrel_diameter=0.8e-3, pitch_angle_deg=22.5, loaded_length=0.14,
                         resistance=13.3, mass=0.01)


def main(argv=None):
    """Run the benchmark; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('dir', nargs='?', default=DEFAULT_DIR, help='records directory')
    parser.add_argument('--config', default=None,
                        help='params file of the muscle (default: the salp description)')
    parser.add_argument('--model', default='rod', choices=('rod', 'cst', 'love'))
    parser.add_argument('--supply', default='power', choices=('power', 'voltage'))
    args = parser.parse_args(argv)
    paths = sorted(glob.glob(os.path.join(args.dir, '*.csv')))
    if not paths:
        print(f'bench_real: no records in {args.dir}; skipped')
        return 0
    records = [read_record(p) for p in paths]
    params = (load_params(args.config) if args.config
              else describe_muscle(SALP_MUSCLE, load_thread_presets()).params)
    print(f'{len(records)} records from {args.dir}; model {args.model}, supply {args.supply}')
    start = time.perf_counter()
    cal = calibrate(records, params, model=args.model, supply=args.supply, check=False)
    seconds = time.perf_counter() - start
    print(format_summary(cal))
    n_rows = sum(r.time.size for r in records)
    print(f'calibration on {len(records)} records ({n_rows} samples): {seconds:.1f} s wall, '
          f'{cal.report.nfev} quasi-static simulations of the record set')
    start = time.perf_counter()
    rows, _ = leave_one_condition_out(records, params, model=args.model, supply=args.supply)
    print(f'\nleave-one-condition-out ({time.perf_counter() - start:.0f} s), normalised '
          'RMSE = RMSE / peak measured stroke of each held-out record:')
    print(format_table(rows))
    wins = np.mean([h.calibrated < h.lumped for h in rows])
    print(f'calibrated beats lumped on {wins:.0%} of held-out records')
    return 0


if __name__ == '__main__':
    sys.exit(main())
