"""`tca_sim`: statics, dynamics, diagnosis and benchmarks of a TCA from the shell.

Exit status: 0 ok, 1 a solver or fit failed, 2 bad input or usage (one-line message
on stderr naming the subcommand, and the file, row, column, flag or parameter, the
value and what is allowed), 3 a `simulate` run ended on a physical event (the thread
broke or melted: the rows before it are written, then one error line). Work is
bounded before it starts: a request needing more samples or physics steps than
``--max-samples`` / ``--max-steps`` allow is refused with exit status 2. Flags are
never abbreviated. A value printed outside the model's valid range (e.g. ``statics
--tmax`` past the melt) comes with a one-line warning on stderr.
"""
import os
import sys
import time as wallclock
import warnings

import numpy as np

from tca_ros.cli.common import add_config_options, check_finite, CliParser, count, \
    EXIT_BAD_INPUT, EXIT_FAILED, EXIT_OK, finite_float, InputError, MESSAGE_CHARS, \
    package_version, params_from_args as _params, warn
from tca_ros.cli.profile import read_profile  # noqa: F401 (tca_ros.cli.main's API)
from tca_ros.cli.simulate import MAX_SIM_STEPS, RIG_PROFILE_COLUMNS  # noqa: F401 (API)
from tca_ros.model.params_schema import GRAVITY, MODELS, ParameterError
from tca_ros.records.data import ABSOLUTE_ZERO_DEGC, clip, DataError, MAX_LOAD_N, \
    MAX_POWER_W, MAX_TEMPERATURE_DEGC  # noqa: F401 (MAX_POWER_W: the limit cli users see)

# Work limits, overridable per run with --max-samples / --max-steps (simulate's:
# cli_simulate.MAX_SIM_STEPS). A diagnosis costs CPU
# time in proportion to its record-rate steps plus a fixed part (rod tables, ~600
# simulations): the shipped 240 s example at 200 Hz physics (48 k steps, rod model)
# took 246 s of CPU and 825 simulations; a 3 s record 4-20 s with cst, 11-84 s with the
# rod model. At the 100 k steps of cli_diagnose.MAX_DIAGNOSE_STEPS that is about 8-9 min of CPU
# with the rod model (measured under load average ~15; a quiet machine is faster).
MAX_TEMPERATURES = 10_000  # statics rows of a helix (each a nonlinear solve): 13 s CPU
# A conical TCA's statics solves one rod shape per temperature, about 0.11 s of CPU each
# (101 temperatures: 13.6 s on the 2-core machine), so its default limit is far lower.
MAX_CONICAL_SHAPES = 250
CHECKED_COMMANDS = ('statics', 'simulate', 'diagnose')  # outputs checked finite, so
# numpy's RuntimeWarnings (multi-line, on stderr) are silenced for them


# -- subcommands ---------------------------------------------------------------------
def range_warning(params, tmin, tmax):
    """Return a one-line warning when [tmin, tmax] (degC) leaves the model's range, or ''.

    The range is limits.temperature_range: from 20 K under the ambient (the fiber
    never cools below the air) to the melt of nylon 6,6 (260 degC).
    """
    from tca_ros.model.limits import temperature_range
    low, high = temperature_range(params)
    parts = []
    if tmax > high:
        parts.append(f'--tmax = {tmax:g} degC is past the melt of the thread ({high:g} degC): '
                     f'the rows above {high:g} degC describe no muscle')
    if tmin < low:
        parts.append(f'--tmin = {tmin:g} degC is more than 20 K below the ambient: the rows '
                     f'below {low:g} degC are extrapolated')
    if not parts:
        return ''
    return f"{'; '.join(parts)} (the model's temperature range is {low:g} to {high:g} degC)"


def cmd_statics(args, out):
    """Print CSV temperature,displacement (degC, m) for a hanging mass."""
    from tca_ros.model.reference_state import crept_under
    from tca_ros.model.simulation import static_displacement
    if args.tstep <= 0.0 or args.tmax < args.tmin:
        raise InputError(f'--tstep = {args.tstep:g}, --tmin = {args.tmin:g}, --tmax = '
                         f'{args.tmax:g}: need tstep > 0 and tmax >= tmin (degC)')
    if args.tmin < ABSOLUTE_ZERO_DEGC or args.tmax > MAX_TEMPERATURE_DEGC:
        raise InputError(f'--tmin = {args.tmin:g}, --tmax = {args.tmax:g} degC: allowed '
                         f'{ABSOLUTE_ZERO_DEGC:g} to {MAX_TEMPERATURE_DEGC:g} degC')
    if args.mass is not None and not 0.0 <= args.mass * GRAVITY <= MAX_LOAD_N:
        raise InputError(f'--mass = {args.mass:g} kg: allowed 0 to '
                         f'{MAX_LOAD_N / GRAVITY:.4g} kg (load 0 to {MAX_LOAD_N:g} N)')
    if args.shape:
        folder = os.path.dirname(os.path.abspath(args.shape))
        if not os.path.isdir(folder):
            raise InputError(f'--shape = {clip(args.shape)!r}: directory {clip(folder)!r} '
                             'does not exist')
    p = _params(args)
    limit = args.max_samples or (MAX_CONICAL_SHAPES if p.coil.shape == 'conical'
                                 else MAX_TEMPERATURES)
    rows = (args.tmax - args.tmin) / args.tstep + 1.0
    if not rows <= limit:
        what = 'rod shapes (conical)' if p.coil.shape == 'conical' else 'temperatures'
        raise InputError(f'--tmin {args.tmin:g} --tmax {args.tmax:g} --tstep {args.tstep:g} '
                         f'give {rows:.4g} {what}; the limit is {limit} (--max-samples)')
    temps = np.arange(args.tmin, args.tmax + 0.5 * args.tstep, args.tstep)
    load = p.dynamics.load if args.mass is None else args.mass * GRAVITY
    if p.coil.shape == 'conical':
        return _conical_statics(p, temps, load, args, out)
    if args.shape:
        raise InputError(f'--shape = {args.shape!r}: only for a conical TCA '
                         f'(coil.shape: conical), this config is a {p.coil.shape}')
    # coil.crept_reference: the reference is the one crept under this weight (Sec. V-D1)
    disp = static_displacement(crept_under(p, load), load, temps)
    check_finite({'displacement': disp}, temps, 'degC')
    _warn_range(p, args)
    out.write('temperature,displacement\n')
    for temp, x in zip(temps, disp):
        out.write(f'{temp:.6g},{x:.9g}\n')
    return EXIT_OK


def _conical_statics(p, temps, load, args, out):
    """Print CSV temperature,end_height (degC, m); optionally write the shapes."""
    from tca_ros.model.conical import conical_shapes
    if p.model != 'rod':
        raise InputError(f'--model = {p.model!r}: a conical TCA needs the rod model '
                         '(Love and CST assume a uniform helix)')
    shapes = conical_shapes(p, temps, load=load)
    check_finite({'end height': [xyz[2, -1] for _, xyz in shapes]}, temps, 'degC')
    _warn_range(p, args)
    out.write('temperature,end_height\n')
    for temp, (_, xyz) in zip(temps, shapes):
        out.write(f'{temp:.6g},{xyz[2, -1]:.9g}\n')
    if args.shape:
        write_shapes(args.shape, temps, shapes)
    return EXIT_OK


def _warn_range(params, args):
    text = range_warning(params, args.tmin, args.tmax)
    if text:
        warn('statics', text)


def write_shapes(path, temps, shapes):
    """Write centrelines as CSV temperature,s,x,y,z (degC, m) and a PNG beside it."""
    with open(path, 'w', encoding='utf-8') as fh:
        fh.write('temperature,s,x,y,z\n')
        for temp, (s, xyz) in zip(temps, shapes):
            for j in range(s.size):
                fh.write(f'{temp:.6g},{s[j]:.9g},{xyz[0, j]:.9g},{xyz[1, j]:.9g},'
                         f'{xyz[2, j]:.9g}\n')
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(9, 4.5))
    ax3 = fig.add_subplot(1, 2, 1, projection='3d')
    ax2 = fig.add_subplot(1, 2, 2)
    picks = sorted(set(np.linspace(0, len(temps) - 1, min(5, len(temps))).astype(int)))
    for k, i in enumerate(picks):
        xyz = shapes[i][1] * 1e3
        color = plt.cm.coolwarm(k / max(len(picks) - 1, 1))
        ax3.plot(xyz[0], xyz[1], xyz[2], color=color, lw=0.8, label=f'{temps[i]:.0f} degC')
        ax2.plot(xyz[0], xyz[2], color=color, lw=0.8, label=f'{temps[i]:.0f} degC')
        ax2.plot(xyz[0, -1], xyz[2, -1], 'o', color=color)
    ax2.plot(0.0, 0.0, 'k^', label='clamp')
    ax3.set_xlabel('x (mm)')
    ax3.set_ylabel('y (mm)')
    ax3.set_zlabel('z (mm)')
    ax2.set_xlabel('x (mm)')
    ax2.set_ylabel('z (mm)')
    ax2.set_aspect('equal')
    ax2.legend(fontsize=7)
    ax2.set_title('side view: the free end (o) passes the clamp')
    fig.tight_layout()
    fig.savefig(os.path.splitext(path)[0] + '.png', dpi=110)
    plt.close(fig)


def cmd_bench(args, out):
    """Print steps per second and wall time per simulated minute for each model."""
    from tca_ros.model.dynamics import TcaSimulator
    p = _params(args)
    models = MODELS
    out.write(f'# thermal + kinetostatic dynamics, {p.tca_type}, physics at 1 kHz, '
              f'{args.seconds:g} s simulated, one core\n')
    out.write('# f_rod solve: eq. (11) fixed point from scratch (statics); f_rod step: one\n'
              "# pass from the previous step's tension, as the dynamics does\n")
    out.write(f'{"model":<6} {"f_rod solve (us)":>17} {"f_rod step (us)":>16} '
              f'{"steps/s":>10} {"wall (s)":>9} {"x real time":>12}\n')
    for name in models:
        sim = TcaSimulator(p, model=name, dt=1e-3)
        km = sim.kinetostatics
        n_eval = 2000
        t0 = wallclock.perf_counter()
        for i in range(n_eval):
            km.tension(0.005 + 1e-6 * i, 60.0 + 0.01 * i)
        t_eval = (wallclock.perf_counter() - t0) / n_eval
        t0 = wallclock.perf_counter()
        for i in range(n_eval):
            km.tension(0.005 + 1e-6 * i, 60.0 + 0.01 * i, 0.3)
        t_step = (wallclock.perf_counter() - t0) / n_eval
        steps = int(args.seconds * 1000)
        t0 = wallclock.perf_counter()
        for i in range(steps):
            sim.step(1.0 if (i // 5000) % 2 == 0 else 0.0)
        wall = wallclock.perf_counter() - t0
        out.write(f'{name:<6} {t_eval * 1e6:>17.1f} {t_step * 1e6:>16.1f} '
                  f'{steps / wall:>10.0f} {wall:>9.2f} {args.seconds / wall:>12.1f}\n')
    return EXIT_OK


def cmd_demo(args, out):
    """Run the main job: statics table and plot, dynamics run, closed-loop demo."""
    from tca_ros.cli.demo_statics import run_statics_demo
    os.makedirs(args.out, exist_ok=True)
    run_statics_demo(args.config, args.out, out)
    if not args.no_node:
        from tca_ros.cli.demo import run_demo
        run_demo(args.out, sim_seconds=args.seconds, config=args.config)
    return EXIT_OK


# -- parser ---------------------------------------------------------------------------
STATICS_EXAMPLE = """example (the free-stroke TCA under 30 g, 25 to 160 degC):
  tca_sim statics --config free_stroke --mass 0.03 --tmin 25 --tmax 160 --tstep 5

A temperature range past the melt (260 degC) or far below the ambient is printed with a
one-line warning on stderr."""
BENCH_EXAMPLE = """example (2 s of simulated time per model):
  tca_sim bench --config self_coiled --seconds 2"""
DEMO_EXAMPLE = """example (statics and dynamics only, no ROS node):
  tca_sim demo --config free_stroke --out out --no-node"""


def build_parser():
    """Return the argparse parser of `tca_sim`."""
    parser = CliParser(prog='tca_sim', description=__doc__.splitlines()[0],
                       epilog='`tca_sim COMMAND --help` describes a command, with an example.')
    parser.add_argument('--version', action='version',
                        version=f'%(prog)s {package_version()} (tca_ros)')
    sub = parser.add_subparsers(dest='command', metavar='COMMAND')

    sp = sub.add_parser(
        'statics', help='displacement (m) vs temperature (degC) under a hanging mass',
        description='Print CSV temperature,displacement (degC, m): the loaded equilibrium '
                    'contraction from --tmin under a hanging mass; a conical TCA prints '
                    'temperature,end_height (m) and can write its shapes (--shape).',
        epilog=STATICS_EXAMPLE)
    add_config_options(sp)
    sp.add_argument('--mass', type=finite_float, default=None,
                    help="hanging mass (kg); default: the config's dynamics.load / g")
    sp.add_argument('--tmin', type=finite_float, default=25.0, help='first temperature (degC)')
    sp.add_argument('--tmax', type=finite_float, default=160.0, help='last temperature (degC)')
    sp.add_argument('--tstep', type=finite_float, default=5.0, help='temperature step (K)')
    sp.add_argument('--shape', default=None,
                    help='conical TCA: write the centreline CSV temperature,s,x,y,z (m) '
                         'here, and a PNG of the shapes beside it')
    sp.add_argument('--max-samples', type=count, default=None,
                    help='refuse runs of more temperatures (limit on memory and time; '
                         f'default {MAX_TEMPERATURES}, conical {MAX_CONICAL_SHAPES})')
    sp.set_defaults(func=cmd_statics)

    from tca_ros.cli.simulate import add_parser as add_simulate_parser
    add_simulate_parser(sub)

    sp = sub.add_parser(
        'bench', help='benchmark the dynamics of each model (printed figures)',
        description='Time the kinetostatic solve and the dynamics of every model on this '
                    'machine (1 kHz physics, one core) and print the figures.',
        epilog=BENCH_EXAMPLE)
    add_config_options(sp, model=False)
    sp.add_argument('--seconds', type=finite_float, default=60.0, help='simulated time (s)')
    sp.set_defaults(func=cmd_bench)

    from tca_ros.cli.diagnose import add_parser as add_diagnose_parser
    add_diagnose_parser(sub)

    from tca_ros.cli.config import add_parser as add_config_parser
    add_config_parser(sub)
    from tca_ros.cli.calibrate import add_parser as add_calibrate_parser
    add_calibrate_parser(sub)
    from tca_ros.cli.validate import add_parser as add_validate_parser
    add_validate_parser(sub)
    from tca_ros.cli.toolkit import add_parser as add_toolkit_parser
    add_toolkit_parser(sub)

    sp = sub.add_parser(
        'demo', help='the main job of `make demo`',
        description='Statics of the TCA with every model and a 1 W dynamics run (tables and '
                    'statics_dynamics.png in --out), then the closed-loop demo: simulator '
                    'node and PID controller over ROS topics (demo_tracking.png).',
        epilog=DEMO_EXAMPLE)
    add_config_options(sp, model=False)
    sp.add_argument('--out', default='out', help='output directory')
    sp.add_argument('--seconds', type=finite_float, default=30.0, help='closed-loop sim time (s)')
    sp.add_argument('--no-node', action='store_true', help='skip the ROS closed-loop demo')
    sp.set_defaults(func=cmd_demo)
    return parser


def main(argv=None, out=None):
    """Run `tca_sim`; return the exit status."""
    out = out or sys.stdout
    args = build_parser().parse_args(argv)

    command = ' '.join(filter(None, (args.command, getattr(args, 'config_command', None))))

    def fail(status, text):
        line = ' '.join(str(text).split()) or 'unknown error'
        sys.stderr.write(f'tca_sim {command}: error: {clip(line, MESSAGE_CHARS)}\n')
        return status

    try:
        with warnings.catch_warnings():
            if args.command in CHECKED_COMMANDS:  # outputs are checked finite instead
                warnings.simplefilter('ignore', RuntimeWarning)
            return args.func(args, out)
    except (InputError, DataError, ParameterError) as exc:
        return fail(EXIT_BAD_INPUT, exc)
    except BrokenPipeError:
        return EXIT_OK
    except OSError as exc:  # a path given on the command line: missing, unwritable, ...
        where = f'{exc.filename}: ' if exc.filename else ''
        return fail(EXIT_BAD_INPUT, f'{where}{exc.strerror or exc}')
    except (ValueError, ArithmeticError) as exc:  # a solver or the model failed
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return fail(EXIT_FAILED, first)
    except MemoryError:
        return fail(EXIT_FAILED, 'out of memory; lower --max-samples or --max-steps')
    except Exception as exc:  # a bug: one line, not a traceback, but say so
        return fail(EXIT_FAILED, f'internal error ({type(exc).__name__}: {exc}); please '
                                 'report it with the command line')


if __name__ == '__main__':
    sys.exit(main())
