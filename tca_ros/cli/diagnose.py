"""`tca_sim diagnose`: find what the model gets wrong in a recording (docs/diagnosis.md).

The method is in tca_ros.diagnosis; this module checks the request against the
work limits, runs the diagnosis and prints its one-screen summary.
"""
import math
import os

from tca_ros.cli.common import checked_config, count, EXIT_FAILED, EXIT_OK, InputError, \
    MAX_OUTPUT_SAMPLES
from tca_ros.records.data import clip

# A diagnosis costs CPU time in proportion to its record-rate steps plus a fixed part
# (cli/main.py, the work limits): at MAX_DIAGNOSE_STEPS about 8-9 min of CPU with the rod model.
MAX_DIAGNOSE_STEPS = 400_000  # record-rate physics steps, all records (2000 s at 200 Hz)
DIAGNOSIS_PHYSICS_HZ = 200.0  # diagnose's record-rate physics rate floor (fitting.py)
DIAGNOSIS_FIT_HZ = 10.0  # diagnose's default fit-grid rate (fitting.FIT_RATE_HZ)
MIN_FIT_SAMPLES = 20  # fit-grid samples a diagnosis needs (data.MIN_SAMPLES)
EXAMPLE = """example (the shipped synthetic 240 s recording; a few minutes of CPU):
  tca_sim diagnose tca_ros/data/example_recording.csv --config free_stroke --report out/example"""


def add_parser(subparsers):
    """Register ``diagnose`` on the `tca_sim` subparsers."""
    from tca_ros.cli.common import add_config_options
    sp = subparsers.add_parser(
        'diagnose', help='find what the model gets wrong in a recording (CSV or MCAP)',
        description='Calibrate the model on part of a recording, search the catalogue of '
                    'effects for what explains the rest, and print the verdict '
                    '(docs/diagnosis.md).', epilog=EXAMPLE)
    sp.add_argument('data', nargs='+',
                    help='recording(s): CSV with # key: value header, or MCAP bag; several '
                         'records of one muscle are diagnosed together (one calibration)')
    add_config_options(sp, default=None,
                       config_help="nominal params file (default: the recording's '# tca:' "
                                   'header)',
                       model_help="kinetostatic model of the fits (default: the config's "
                                  'model)')
    sp.add_argument('--calibrated', default=None,
                    help='params file from `tca_sim calibrate`: the nominal model to judge '
                         'effects against (skips the calibration of the training part)')
    sp.add_argument('--no-calibrate', action='store_true',
                    help='judge effects against the config as it is (no calibration first)')
    sp.add_argument('--supply', choices=('power', 'voltage'), default='power',
                    help='the power column: delivered power, or the nominal power of a '
                         'constant-voltage supply set at R0')
    sp.add_argument('--validation', choices=('auto', 'blocks', 'tail'), default='auto',
                    help='held-out part: 3 of 10 blocks of each record, the last one and '
                         'two inside (a one-step record is judged on heating and '
                         'cooling), or its last 30 %%; auto: the tail when its training '
                         'part holds two coolings, else blocks (docs/diagnosis_method.md)')
    sp.add_argument('--report', default=None,
                    help='directory (DIR) for report.md, PNG plots, diagnosis.json and '
                         'the extended params YAML')
    sp.add_argument('--quiet', action='store_true', help='no progress bar')
    sp.add_argument('--max-samples', type=count, default=MAX_OUTPUT_SAMPLES,
                    help='refuse runs of more record samples (limit on memory and time)')
    sp.add_argument('--max-steps', type=count, default=MAX_DIAGNOSE_STEPS,
                    help='refuse runs of more physics steps per simulation, all records '
                         'together (limit on time)')
    sp.set_defaults(func=cmd_diagnose)


def cmd_diagnose(args, out):
    """Diagnose a recording; print the summary; write the report."""
    from tca_ros.diagnosis import diagnose, format_summary
    from tca_ros.records.data import read_record, record_config
    if args.report and os.path.exists(args.report) and not os.path.isdir(args.report):
        raise InputError(f'--report = {clip(args.report)!r}: exists and is not a directory')
    if args.config:
        checked_config(args.config)
    fit_rate, total = None, 0.0
    for data in args.data:
        is_bag = os.path.isdir(data) or str(data).endswith('.mcap')
        if not (args.config or not is_bag):
            continue  # a bag without --config is refused by diagnose
        # read once under the limits: diagnose re-reads the same file, as large as this
        record = read_record(data, max_samples=args.max_samples)
        if not args.config:
            checked_config(record_config(record), option="'# tca:' header")
        physics = max(DIAGNOSIS_PHYSICS_HZ, record.sample_rate)
        steps = record.duration * physics
        total += steps  # each fit simulates every record: the work adds up over them
        if not steps <= args.max_steps:
            raise InputError(f'{data}: {record.duration:.4g} s at {physics:.4g} Hz '
                             f'physics is {steps:.4g} steps per simulation; the limit is '
                             f'{args.max_steps} (--max-steps)')
        if not total <= args.max_steps:
            raise InputError(f'{data}: with the records before it, {total:.4g} physics steps '
                             f'per simulation; the limit is {args.max_steps} (--max-steps)')
        if record.duration * DIAGNOSIS_FIT_HZ + 1.0 < MIN_FIT_SAMPLES:
            fit_rate = record.sample_rate  # a short record is fitted at its own rate
    if args.calibrated:
        checked_config(args.calibrated, option='--calibrated')
    data = args.data[0] if len(args.data) == 1 else args.data
    result = diagnose(data, args.config, report_dir=args.report, model=args.model,
                      progress=not args.quiet, fit_rate=fit_rate,
                      calibrate_first=not args.no_calibrate, calibrated=args.calibrated,
                      supply=args.supply, validation=args.validation)
    for name, rmse in (('nominal', result.nominal_rmse), ('extended', result.extended_rmse)):
        for channel, value in rmse.items():
            if not math.isfinite(value):
                raise ValueError(f'{args.data[0]}: the {name} model gives a held-out '
                                 f'{channel} RMSE of {value!r}')
    out.write(format_summary(result) + '\n')
    return EXIT_OK if result.success else EXIT_FAILED
