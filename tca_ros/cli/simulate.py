"""`tca_sim simulate`: the dynamics of a TCA on its rig for a power / load profile CSV.

A run that ends on a physical event keeps what it simulated: when the thread breaks
(its tension passes ``fiber.break_force``) or melts (its temperature reaches
limits.MELT_TEMPERATURE_DEGC, 260 degC), the rows before the event are written,
then one error line naming the event, and the exit status is 3 (EXIT_EVENT).
"""
import math
import sys

import numpy as np

from tca_ros.cli.common import add_config_options, check_finite, count, EXIT_EVENT, EXIT_OK, \
    finite_float, InputError, MAX_OUTPUT_SAMPLES, MESSAGE_CHARS, params_from_args
from tca_ros.cli.profile import PROFILE_COLUMNS, read_profile_columns, resample_hold
from tca_ros.model.params_schema import RIG_MODES
from tca_ros.records.data import clip

# `simulate` with cst ran 300 k physics steps in 10-13 s on a loaded 2-core machine
# (load average 3.6), so its limit stays under the 30 s a caller may take for a hang.
MAX_SIM_STEPS = 300_000  # physics steps of one `simulate` run (5 min at 1 kHz)

#: Profile columns per load rig (rig.mode; docs/rigs.md).
RIG_PROFILE_COLUMNS = {'dead_weight': PROFILE_COLUMNS, 'spring': PROFILE_COLUMNS,
                       'isometric': ('time', 'power'),
                       'antagonistic': ('time', 'power', 'power_2')}

EXAMPLE = """example (a 1 W step for 20 s, then 40 s of cooling; CSV on stdout):
  printf 'time,power\\n0,1\\n20,0\\n60,0\\n' > step.csv
  tca_sim simulate --config free_stroke --input step.csv --rate 10 > out.csv

exit status: 0 ok; 1 the model failed; 2 bad input; 3 the thread broke or melted
(rows up to the event written, then one error line)"""


def add_parser(subparsers):
    """Register ``simulate`` on the `tca_sim` subparsers."""
    sp = subparsers.add_parser(
        'simulate', help='dynamics for a power (W) / load (N) profile CSV',
        description='Simulate the muscle on its rig for a profile of power (W) and load '
                    '(N) held between rows; print CSV of the columns of the rig (dead weight: '
                    'time,power,load,displacement,temperature,resistance; s, W, N, m, '
                    'degC, ohm) at --rate.', epilog=EXAMPLE)
    add_config_options(sp)
    source = sp.add_mutually_exclusive_group(required=True)
    source.add_argument('--input',
                        help='CSV (path or shipped name, e.g. profile_steps) with columns '
                             'time,power[,load] (W, N); isometric rig: time,power; '
                             'antagonistic rig: time,power[,power_2] (docs/rigs.md)')
    sp.add_argument('--rig', choices=RIG_MODES, default=None,
                    help="load rig (default: the config's rig.mode; its parameters rig.* "
                         'come from the config)')
    sp.add_argument('--rate', type=finite_float, default=100.0, help='output sample rate (Hz)')
    sp.add_argument('--physics-rate', type=finite_float, default=1000.0,
                    help='physics step rate (Hz)')
    sp.add_argument('--max-samples', type=count, default=MAX_OUTPUT_SAMPLES,
                    help='refuse runs of more output samples (limit on memory and time)')
    sp.add_argument('--max-steps', type=count, default=MAX_SIM_STEPS,
                    help='refuse runs of more physics steps per simulation (limit on time)')
    sp.set_defaults(func=cmd_simulate)
    from tca_ros.cli.compare import add_simulate_options  # --compare, --out, --plot
    add_simulate_options(sp, source, cmd_simulate)


def cmd_simulate(args, out):
    """Print the CSV of the rig's columns (dead weight: time,power,load,...) for a profile."""
    from tca_ros.model.rig_simulation import RIG_COLUMNS
    for name, value in (('--rate', args.rate), ('--physics-rate', args.physics_rate)):
        if not value > 0.0:
            raise InputError(f'{name} = {value:g}: must be a positive rate in Hz')
    p = params_from_args(args)
    columns = read_profile_columns(args.input, max_rows=args.max_samples + 1000,
                                   allowed=RIG_PROFILE_COLUMNS[p.rig.mode])
    t_in = columns['time']
    span = t_in[-1] - t_in[0]
    samples = span * args.rate + 1.0
    steps = span * max(args.rate, args.physics_rate)
    if not samples <= args.max_samples:
        raise InputError(f'{args.input}: {span:.4g} s at --rate {args.rate:g} Hz is '
                         f'{samples:.4g} samples; the limit is {args.max_samples} '
                         '(--max-samples)')
    if not steps <= args.max_steps:
        raise InputError(f'{args.input}: {span:.4g} s at --physics-rate '
                         f'{max(args.rate, args.physics_rate):g} Hz is {steps:.4g} physics '
                         f'steps; the limit is {args.max_steps} (--max-steps)')
    n = int(math.floor(span * args.rate + 1e-9)) + 1
    t = t_in[0] + np.arange(n) / args.rate
    if n > 1 and not np.all(np.diff(t) > 0.0):
        raise InputError(f"{args.input}: column 'time': {t_in[0]:g} s is too large for "
                         f'steps of 1/{args.rate:g} s (they vanish in rounding)')
    held = {name: resample_hold(t_in, values, t) for name, values in columns.items()
            if name != 'time'}
    names = RIG_COLUMNS[p.rig.mode]
    trained = _warn_extrapolation(args.config, p, held)
    result, event = _run(p, t, held, args.physics_rate, names)
    check_finite({name: result[name] for name in names[1:]}, result['time'], 's')
    _warn_hotter(trained, result)
    out.write(','.join(names) + '\n')
    for row in zip(*(result[name] for name in names)):
        out.write(','.join(f'{v:.9g}' for v in row) + '\n')
    if event is None:
        return EXIT_OK
    out.flush()
    line = ' '.join(event.split())
    sys.stderr.write(f'tca_sim simulate: error: {clip(line, MESSAGE_CHARS)}\n')
    return EXIT_EVENT


def _warn_hotter(trained, result):
    """Warn when the run heats the muscle past the hottest its calibration predicted."""
    from tca_ros.calibration.transfer import temperature_extrapolation
    temperature = result.get('temperature')
    if trained is None or temperature is None or not len(temperature):
        return
    line = temperature_extrapolation(trained, float(np.max(temperature)))
    if line:
        sys.stderr.write(f'tca_sim simulate: warning: extrapolates: {line}\n')


def _warn_extrapolation(config, params, held):
    """Warn (stderr, one line each) where a calibrated muscle is run past its calibration.

    Return the calibration's trained range (None: the config is not calibrated).
    """
    from tca_ros.calibration.transfer import profile_extrapolation, read_trained_range
    from tca_ros.cli.common import checked_config
    trained = read_trained_range(checked_config(config))
    if trained is None:
        return None
    load = held.get('load')
    for line in profile_extrapolation(
            trained, float(np.max(held['power'])),
            float(np.max(load)) if load is not None else params.dynamics.load,
            params.rig.mode):
        sys.stderr.write(f'tca_sim simulate: warning: extrapolates: {line}\n')
    return trained


def _run(p, t, held, physics_rate, names):
    """Return (columns up to a physical event, the event's message or None)."""
    from tca_ros.model.limits import MELT_TEMPERATURE_DEGC, ThreadBreakError
    from tca_ros.model.rig_simulation import simulate_rig
    from tca_ros.model.rod_table import RodTableError
    event = None
    try:
        columns = simulate_rig(p, t, held['power'], held.get('load'), held.get('power_2'),
                               physics_rate=physics_rate).columns
    except (ThreadBreakError, RodTableError) as exc:
        # the rod table ends at the melt: past it the thread has melted (a physical event);
        # its other refusals (no regular helix) are model failures and stay exit status 1
        if isinstance(exc, RodTableError) and 'melts' not in str(exc):
            raise
        partial = getattr(exc, 'partial', None)  # None: it broke as the load was hung
        columns = partial.columns if partial is not None else \
            {name: np.empty(0) for name in names}
        n = columns['time'].size
        first = str(exc).splitlines()[0]
        if isinstance(exc, ThreadBreakError):
            event = (f'{first}; the {n} rows before it were written (to t = '
                     f'{columns["time"][-1]:.6g} s)' if n else
                     f'{first}; no rows written (the load at t = {t[0]:g} s breaks it)')
        else:
            after = columns['time'][-1] if n else t[0]
            event = (f'the thread melts: its temperature passes {MELT_TEMPERATURE_DEGC:g} '
                     f'degC (nylon 6,6) after t = {after:.6g} s; the {n} rows before it '
                     'were written')
    hot = [name for name in ('temperature', 'temperature_2') if name in columns]
    if hot:  # cst and love have no melt of their own: the run ends there for every model
        melted = np.zeros(columns['time'].size, bool)
        for name in hot:
            melted |= np.asarray(columns[name]) >= MELT_TEMPERATURE_DEGC
        if melted.any():
            i = int(np.argmax(melted))
            temp = max(float(columns[name][i]) for name in hot)
            columns = {name: values[:i] for name, values in columns.items()}
            event = (f'the thread melts: temperature {temp:.5g} degC at t = {t[i]:.6g} s '
                     f'reaches {MELT_TEMPERATURE_DEGC:g} degC (nylon 6,6); the {i} rows '
                     'before it were written')
    return columns, event
