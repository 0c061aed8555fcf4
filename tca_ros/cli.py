"""`tca_sim`: statics, dynamics, diagnosis and benchmarks of a TCA from the shell.

Exit status: 0 ok, 1 a solver or fit failed, 2 bad input (one-line message on
stderr naming the file, row, column or parameter, the value and what is allowed).
"""
import argparse
import csv
import math
import os
import sys
import time as wallclock

import numpy as np

from tca_ros.diagnosis.data import DataError, parse_number
from tca_ros.model.params import GRAVITY, load_params, MODELS, ParameterError

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2


class InputError(ValueError):
    """Bad command-line input; the message is one line."""


# -- input profiles -------------------------------------------------------------------
def read_profile(path):
    """Return (time (s), power (W), load (N) or None) from a CSV with a header row.

    Columns: ``time,power`` and optionally ``load``. Raises InputError naming the
    row (1-based, header = row 1) and column of the first bad value.
    """
    try:
        fh = open(path, newline='', encoding='utf-8')
    except OSError as exc:
        raise InputError(f'{path}: cannot open ({exc.strerror})') from None
    with fh:
        rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith('#')]
    if not rows:
        raise InputError(f'{path}: empty file; expected a header row time,power[,load]')
    header = [h.strip() for h in rows[0]]
    for name in ('time', 'power'):
        if name not in header:
            raise InputError(f"{path}: row 1: missing column '{name}' "
                             f"(found {','.join(header)}; allowed time,power,load)")
    unknown = [h for h in header if h not in ('time', 'power', 'load')]
    if unknown:
        raise InputError(f"{path}: row 1: unknown column '{unknown[0]}' "
                         '(allowed time,power,load)')
    cols = {name: header.index(name) for name in header}
    data = {name: [] for name in header}
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise InputError(f'{path}: row {i}: {len(row)} fields, expected {len(header)}')
        for name, j in cols.items():
            data[name].append(parse_number(row[j], path, i, name))
    if len(data['time']) < 2:
        raise InputError(f'{path}: needs at least 2 data rows, found {len(data["time"])}')
    t = np.array(data['time'])
    bad = np.nonzero(np.diff(t) <= 0.0)[0]
    if bad.size:
        i = int(bad[0]) + 1
        raise InputError(f"{path}: row {i + 2}, column 'time': {t[i]:g} s is not after "
                         f'{t[i - 1]:g} s (time must increase)')
    load = np.array(data['load']) if 'load' in data else None
    if load is not None and np.any(load < 0.0):
        i = int(np.nonzero(load < 0.0)[0][0])
        raise InputError(f"{path}: row {i + 2}, column 'load': {load[i]:g} N is "
                         'compressive; allowed >= 0 (tensile)')
    return t, np.array(data['power']), load


def resample_hold(t_in, values, t_out):
    """Return ``values`` (sampled at t_in) held constant onto t_out (zero-order hold)."""
    idx = np.clip(np.searchsorted(t_in, t_out, side='right') - 1, 0, len(t_in) - 1)
    return np.asarray(values)[idx]


# -- subcommands ---------------------------------------------------------------------
def _params(args):
    overrides = {'model': args.model} if getattr(args, 'model', None) else {}
    return load_params(args.config, **overrides)


def cmd_statics(args, out):
    """Print CSV temperature,displacement (degC, m) for a hanging mass."""
    from tca_ros.model.dynamics import static_displacement
    p = _params(args)
    if args.tstep <= 0.0 or args.tmax < args.tmin:
        raise InputError(f'--tstep = {args.tstep:g}, --tmin = {args.tmin:g}, --tmax = '
                         f'{args.tmax:g}: need tstep > 0 and tmax >= tmin (degC)')
    if args.mass is not None and not (math.isfinite(args.mass) and args.mass >= 0.0):
        raise InputError(f'--mass = {args.mass!r}: must be a finite mass >= 0 kg')
    temps = np.arange(args.tmin, args.tmax + 0.5 * args.tstep, args.tstep)
    load = p.dynamics.load if args.mass is None else args.mass * GRAVITY
    if p.coil.shape == 'conical':
        return _conical_statics(p, temps, load, args, out)
    if args.shape:
        raise InputError(f'--shape = {args.shape!r}: only for a conical TCA '
                         f'(coil.shape: conical), this config is a {p.coil.shape}')
    disp = static_displacement(p, load, temps)
    out.write('temperature,displacement\n')
    for temp, x in zip(temps, disp):
        out.write(f'{temp:.6g},{x:.9g}\n')
    return EXIT_OK


def _conical_statics(p, temps, load, args, out):
    """Print CSV temperature,end_height (degC, m); optionally write the shapes."""
    from tca_ros.model.rod_model import conical_shapes
    if p.model != 'rod':
        raise InputError(f'--model = {p.model!r}: a conical TCA needs the rod model '
                         '(Love and CST assume a uniform helix)')
    shapes = conical_shapes(p, temps, load=load)
    out.write('temperature,end_height\n')
    for temp, (_, xyz) in zip(temps, shapes):
        out.write(f'{temp:.6g},{xyz[2, -1]:.9g}\n')
    if args.shape:
        write_shapes(args.shape, temps, shapes)
    return EXIT_OK


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


def cmd_simulate(args, out):
    """Print CSV time,power,load,displacement,temperature,resistance for a profile."""
    from tca_ros.model.dynamics import simulate
    p = _params(args)
    if not (math.isfinite(args.rate) and args.rate > 0.0):
        raise InputError(f'--rate = {args.rate!r}: must be a positive rate in Hz')
    t_in, power_in, load_in = read_profile(args.input)
    n = int(math.floor((t_in[-1] - t_in[0]) * args.rate + 1e-9)) + 1
    t = t_in[0] + np.arange(n) / args.rate
    power = resample_hold(t_in, power_in, t)
    load = None if load_in is None else resample_hold(t_in, load_in, t)
    res = simulate(p, t, power, load, physics_rate=args.physics_rate)
    out.write('time,power,load,displacement,temperature,resistance\n')
    for row in zip(res.time, res.power, res.load, res.displacement, res.temperature,
                   res.resistance):
        out.write(','.join(f'{v:.9g}' for v in row) + '\n')
    return EXIT_OK


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


def cmd_diagnose(args, out):
    """Diagnose a recording; print the summary; write the report."""
    from tca_ros.diagnosis import diagnose, format_summary
    result = diagnose(args.data, args.config, report_dir=args.report, model=args.model,
                      progress=not args.quiet)
    out.write(format_summary(result) + '\n')
    return EXIT_OK if result.success else EXIT_FAILED


def cmd_demo(args, out):
    """Run the main job: statics table and plot, dynamics run, closed-loop demo."""
    from tca_ros.demo_statics import run_statics_demo
    os.makedirs(args.out, exist_ok=True)
    run_statics_demo(args.config, args.out, out)
    if not args.no_node:
        from tca_ros.demo import run_demo
        run_demo(args.out, sim_seconds=args.seconds, config=args.config)
    return EXIT_OK


# -- parser ---------------------------------------------------------------------------
def build_parser():
    """Return the argparse parser of `tca_sim`."""
    fmt = argparse.ArgumentDefaultsHelpFormatter
    parser = argparse.ArgumentParser(prog='tca_sim', description=__doc__.splitlines()[0],
                                     formatter_class=fmt)
    sub = parser.add_subparsers(dest='command', required=True)

    def common(sp, model=True):
        sp.add_argument('--config', default='free_stroke',
                        help='params file (path or shipped name: free_stroke, self_coiled, '
                             'conical)')
        if model:
            sp.add_argument('--model', choices=MODELS, default=None,
                            help="kinetostatic model (default: the config's model)")

    sp = sub.add_parser('statics', formatter_class=fmt,
                        help='displacement (m) vs temperature (degC) under a hanging mass')
    common(sp)
    sp.add_argument('--mass', type=float, default=None,
                    help="hanging mass (kg); default: the config's dynamics.load / g")
    sp.add_argument('--tmin', type=float, default=25.0, help='first temperature (degC)')
    sp.add_argument('--tmax', type=float, default=160.0, help='last temperature (degC)')
    sp.add_argument('--tstep', type=float, default=5.0, help='temperature step (K)')
    sp.add_argument('--shape', default=None,
                    help='conical TCA: write the centreline CSV temperature,s,x,y,z (m) '
                         'here, and a PNG of the shapes beside it')
    sp.set_defaults(func=cmd_statics)

    sp = sub.add_parser('simulate', formatter_class=fmt,
                        help='dynamics for a power (W) / load (N) profile CSV')
    common(sp)
    sp.add_argument('--input', required=True, help='CSV with columns time,power[,load]')
    sp.add_argument('--rate', type=float, default=100.0, help='output sample rate (Hz)')
    sp.add_argument('--physics-rate', type=float, default=1000.0,
                    help='physics step rate (Hz)')
    sp.set_defaults(func=cmd_simulate)

    sp = sub.add_parser('diagnose', formatter_class=fmt,
                        help='find what the model gets wrong in a recording (CSV or MCAP)')
    sp.add_argument('data', help='recording: CSV with # key: value header, or MCAP bag')
    sp.add_argument('--config', default=None,
                    help="nominal params file (default: the recording's '# tca:' header)")
    sp.add_argument('--model', choices=MODELS, default='cst',
                    help='kinetostatic model of the fits (cst: fastest; rod: most exact)')
    sp.add_argument('--report', default=None,
                    help='directory (DIR) for report.md, PNG plots, diagnosis.json and '
                         'the extended params YAML')
    sp.add_argument('--quiet', action='store_true', help='no progress bar')
    sp.set_defaults(func=cmd_diagnose)

    sp = sub.add_parser('bench', formatter_class=fmt,
                        help='benchmark the dynamics of each model (printed figures)')
    common(sp, model=False)
    sp.add_argument('--seconds', type=float, default=60.0, help='simulated time (s)')
    sp.set_defaults(func=cmd_bench)

    from tca_ros.cli_config import add_parser as add_config_parser
    add_config_parser(sub)

    sp = sub.add_parser('demo', formatter_class=fmt, help='the main job of `make demo`')
    common(sp, model=False)
    sp.add_argument('--out', default='out', help='output directory')
    sp.add_argument('--seconds', type=float, default=30.0, help='closed-loop sim time (s)')
    sp.add_argument('--no-node', action='store_true', help='skip the ROS closed-loop demo')
    sp.set_defaults(func=cmd_demo)
    return parser


def main(argv=None, out=None):
    """Run `tca_sim`; return the exit status."""
    out = out or sys.stdout
    args = build_parser().parse_args(argv)
    try:
        return args.func(args, out)
    except (InputError, DataError, ParameterError) as exc:
        sys.stderr.write(f'tca_sim {args.command}: error: {exc}\n')
        return EXIT_BAD_INPUT
    except ValueError as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        sys.stderr.write(f'tca_sim {args.command}: error: {first}\n')
        return EXIT_FAILED
    except BrokenPipeError:
        return EXIT_OK


if __name__ == '__main__':
    sys.exit(main())
