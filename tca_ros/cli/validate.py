"""`tca_sim validate`: predict records with a calibrated params file, beside the baselines.

The method is in tca_ros.calibration.transfer (docs/calibration.md, "Transfer").
"""
import argparse


def add_parser(subparsers):
    """Register ``validate`` on the `tca_sim` subparsers."""
    from tca_ros.cli.common import add_config_options
    sp = subparsers.add_parser(
        'validate', formatter_class=argparse.RawDescriptionHelpFormatter,
        help='predict records (any power, load, rig) with a calibrated params file, '
             'beside the lumped model and the repeat floor',
        description='Predict every given record with the calibrated params file (full '
                    'dynamics), print its normalised RMSE beside the lumped model fitted '
                    'on the calibration records and the repeat floor, and warn where a '
                    'record extrapolates (power, load, rig or temperature outside the '
                    'calibration).',
        epilog='example:\n  tca_sim calibrate rec_1W.csv rec_2W.csv --config my_tca.yaml '
               '--out my_tca_cal.yaml\n  tca_sim validate rec_3W.csv --config '
               'my_tca_cal.yaml')
    sp.add_argument('records', nargs='+', help='recordings (CSV with # header, or MCAP)')
    add_config_options(sp, required=True,
                       config_help='calibrated params file (from `tca_sim calibrate`)',
                       model_help="kinetostatic model (default: the params file's)")
    sp.set_defaults(func=cmd_validate)


def cmd_validate(args, out):
    """Predict the records; print the transfer table; return the exit status."""
    from tca_ros.calibration.conditions import held_strength
    from tca_ros.calibration.transfer import format_validation, read_trained_range, validate
    from tca_ros.cli.common import checked_config
    from tca_ros.params.files import load_params
    from tca_ros.records.data import read_record
    path = checked_config(args.config)
    params = load_params(path)
    records = [read_record(p) for p in args.records]
    from tca_ros.cli.common import warn_reading
    warn_reading('validate', records)
    params, warning = held_strength(params, records)
    if warning:
        out.write(warning + '\n')
    trained = read_trained_range(path)
    model = args.model or params.model
    rows = validate(records, params, model, trained)
    label = 'lumped'
    if trained is None:
        out.write(f'note: {args.config} has no calibrated_on header (not written by '
                  '`tca_sim calibrate`): the lumped model is fitted on these records '
                  'themselves (optimistic) and extrapolation is not checked\n')
        label = 'lumped*'
    out.write(format_validation(rows, label) + '\n')
    return 0
