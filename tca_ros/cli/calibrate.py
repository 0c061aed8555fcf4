"""`tca_sim calibrate`: fit a muscle's unmeasurable parameters on its recordings.

The method is in tca_ros.calibration.calibration (docs/calibration.md); this module
reads the records, checks the request, prints the one-screen summary and writes
the calibrated params file (and, with ``--report``, plots and calibration.json).
"""
import json
import os

SUPPLIES = ('power', 'voltage')
CALIBRATED_BY = 'Calibrated by `tca_sim calibrate` on:'  # header line before the records
EXAMPLE = """example (the shipped synthetic recording of a free-stroke TCA; cst is the fast model):
  tca_sim calibrate tca_ros/data/example_recording.csv --config free_stroke --model cst \\
      --out my_tca_cal.yaml"""


def add_parser(subparsers):
    """Register ``calibrate`` on the `tca_sim` subparsers."""
    from tca_ros.calibration.calibration import DEFAULT_FIT
    from tca_ros.model.params_schema import MODELS
    sp = subparsers.add_parser(
        'calibrate',
        help="fit a muscle's heat loss, heat capacity, actuation gain, stiffness, damping, "
             'delivered power and resistance law on its recordings',
        description="Fit a muscle's parameters that cannot be measured at the bench on its "
                    'recordings; print a one-screen summary and write the calibrated params '
                    'file (docs/calibration.md).', epilog=EXAMPLE)
    sp.add_argument('records', nargs='+', help='recordings (CSV with # header, or MCAP)')
    sp.add_argument('--config', default=None,
                    help="start params file (default: the first record's '# tca:' header); "
                         'describe your muscle with `tca_sim config new`')
    sp.add_argument('--out', required=True, help='calibrated params file to write (YAML)')
    sp.add_argument('--force', action='store_true', help='overwrite --out if it exists')
    sp.add_argument('--fit', default='',
                    help='comma-separated calibration parameters to fit (default: '
                         + ', '.join(DEFAULT_FIT) + ', and initial_temperature_rise on one '
                         'record whose logged temperature falls before any power); also '
                         'friction_force, initial_temperature_rise, '
                         'expansion_plateau_temperature (degC, where the stroke-temperature '
                         'curvature stops) or a catalogue effect '
                         'parameter (e.g. effects.creep_compliance), fitted with the '
                         'nominal ones')
    sp.add_argument('--model', choices=MODELS, default=None,
                    help="kinetostatic model (default: the config's model)")
    sp.add_argument('--supply', choices=SUPPLIES, default=None,
                    help="what the power column is: 'power' delivered, or the nominal power "
                         "of a constant-voltage supply set at R0 ('voltage'); default: the "
                         "records' '# supply:' header, else power")
    sp.add_argument('--report', default=None,
                    help='directory for calibration.json and a plot of every record')
    sp.add_argument('--loco', action='store_true',
                    help='also score leave-one-condition-out against the start config and '
                         'the lumped model (one calibration per condition)')
    sp.add_argument('--quiet', action='store_true', help='no progress bar')
    sp.set_defaults(func=cmd_calibrate)


def _supply(args, records):
    from tca_ros.cli.common import InputError
    if args.supply:
        return args.supply
    found = {str(r.meta.get('supply', 'power')).strip() for r in records}
    bad = sorted(found - set(SUPPLIES))
    if bad:
        raise InputError(f"'# supply:' header = {bad[0]!r}: must be one of "
                         f"{', '.join(SUPPLIES)}")
    if len(found) > 1:
        raise InputError(f"'# supply:' headers differ between records ({sorted(found)}); "
                         'pass --supply')
    return found.pop()


def _calibrated_on(path):
    """Return the absolute paths of the records a params file says it was calibrated on."""
    out, inside = [], False
    with open(path, encoding='utf-8') as fh:
        for line in fh:
            if not line.startswith('#'):
                break
            text = line[1:].rstrip('\n')
            if text.strip().startswith(CALIBRATED_BY):
                inside = True
            elif inside and text.startswith('   '):
                out.append(os.path.abspath(text.strip()))
            else:
                inside = False
    return out


def cmd_calibrate(args, out):
    """Calibrate; print the summary; write the params file and the report."""
    from tca_ros.calibration.calibration import calibrate, CalibrationError
    from tca_ros.calibration.calibration_report import format_summary
    from tca_ros.cli.common import checked_config, InputError
    from tca_ros.model.tca_params import muscle_at_rest
    from tca_ros.params.files import dump_params, load_params
    from tca_ros.records.data import read_record, record_config
    if os.path.exists(args.out) and not args.force:
        raise InputError(f'--out = {args.out!r}: exists (pass --force to overwrite)')
    if args.report and os.path.exists(args.report) and not os.path.isdir(args.report):
        raise InputError(f'--report = {args.report!r}: exists and is not a directory')
    folder = os.path.dirname(args.out)
    if folder and os.path.exists(folder) and not os.path.isdir(folder):
        raise InputError(f'--out = {args.out!r}: {folder!r} is not a directory')
    records = [read_record(path) for path in args.records]
    from tca_ros.cli.common import warn_reading
    warn_reading('calibrate', records)
    config = args.config or record_config(records[0])
    params = load_params(checked_config(config))
    again = sorted(set(_calibrated_on(checked_config(config)))
                   & {os.path.abspath(p) for p in args.records})
    if again:
        from tca_ros.cli.common import warn
        warn('calibrate', f'--config {config} was calibrated on {len(again)} of these records '
             f"({os.path.basename(again[0])}...): its uncertainty section is that fit's "
             'posterior, so their evidence counts twice; calibrate from the description '
             '(docs/calibration.md, "A calibrated file is a measured description")')
    names = [n.strip() for n in args.fit.split(',') if n.strip()]
    supply = _supply(args, records)
    try:
        cal = calibrate(records, params, model=args.model, fit=names or None,
                        progress=not args.quiet, supply=supply)
    except CalibrationError as exc:
        raise InputError(str(exc)) from None
    out.write(format_summary(cal) + '\n')
    header = [CALIBRATED_BY] + [f'  {os.path.abspath(p)}' for p in args.records]
    header += [f'start config: {config}; model {cal.model}; supply {supply}']
    for est in cal.report.estimates.values():
        state = 'fitted' if est.determined else 'NOT determined: mostly its prior'
        header.append(f'{est.name} = {est.value:.5g} +- {est.stderr:.2g} {est.unit} ({state})')
    from tca_ros.calibration.transfer import header_line, trained_range
    header.append(header_line(trained_range(cal)))
    from tca_ros.calibration.posterior import calibrated_uncertainty, posterior_of, write_line
    posterior = posterior_of(cal)
    header.append(write_line(posterior))  # docs/own_muscle.md, "Uncertainty"
    muscle, start_note = muscle_at_rest(calibrated_uncertainty(cal.params, posterior))
    if folder:
        os.makedirs(folder, exist_ok=True)
    dump_params(muscle, args.out, header='\n'.join(header) + start_note)
    out.write(f'wrote {args.out}\n')
    loco = None
    if args.loco:
        from tca_ros.calibration.validation import format_table, leave_one_condition_out
        try:
            rows, _ = leave_one_condition_out(records, params, model=args.model,
                                              progress=not args.quiet, supply=supply)
        except CalibrationError as exc:
            raise InputError(str(exc)) from None
        out.write(format_table(rows) + '\n')
        loco = [row.__dict__ for row in rows]
    if args.report:
        from tca_ros.calibration.calibration_report import write_calibration_report
        os.makedirs(args.report, exist_ok=True)
        data = cal.to_json()
        data['leave_one_condition_out'] = loco
        with open(os.path.join(args.report, 'calibration.json'), 'w', encoding='utf-8') as fh:
            json.dump(data, fh, indent=2, default=str)
        figure = write_calibration_report(cal, args.report)
        out.write(f'wrote {args.report}/calibration.json and {figure}\n')
    return 0 if cal.report.success else 1
