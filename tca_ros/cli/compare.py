"""`tca_sim simulate --compare REC... --out DIR` and `--plot FILE`: model over measurement.

``--compare`` reads each record (docs/records.md), simulates its own inputs (time,
power, load columns; the record's hanging mass ``# mass_kg:`` and ``# supply:``
header) with ``--config`` / ``--model`` on the record's time grid, writes one PNG per
record to ``--out`` (measured and modelled displacement, and temperature and
resistance when the record has them) and prints one CSV row per record: the
displacement RMSE (mm), the peak measured stroke (mm), the RMSE normalised by it
(%) and the temperature (K) and resistance (ohm) RMSE when recorded. The same
table is written to ``DIR/compare.csv``. ``--plot FILE`` on a plain ``simulate``
(``--input``) draws the simulated columns to a PNG as well as printing them.

When ``--config`` is a calibrated params file with a ``# posterior:`` header
(calibration/posterior.py), both also simulate ``--draws`` parameter sets drawn from
the calibration's posterior (full dynamics) and shade their 5-95 % band on every
modelled panel, labelled as the calibration's uncertainty; ``--compare`` prints one
``# band:`` line per record with the share of measured samples inside the band
(also ``DIR/band.csv``). A channel the calibration's records did not measure (e.g.
temperature without a thermometer) is labelled "not measured in calibration: from
the priors" on the plots and in that line.

It is an option of ``simulate`` rather than a ``plot`` subcommand because it is a
simulation (the same config, model, physics rate and work limits) whose inputs
come from records; the figure and the errors are its output.
"""
import functools
import io
import os

import numpy as np

from tca_ros.cli.band import BAND_COLUMNS, band_line, band_of, band_rate, band_row, \
    csv_table, DEFAULT_DRAWS, draws_count, posterior_of_config, profile_band
from tca_ros.cli.common import EXIT_OK, InputError
from tca_ros.records.data import clip
from tca_ros.records.examples import resolve_example, shipped_examples

SUPPLIES = ('power', 'voltage')  # the '# supply:' header values (docs/records.md)
SUMMARY_COLUMNS = ('record', 'samples', 'rmse_mm', 'peak_stroke_mm', 'nrmse_percent',
                   'temperature_rmse_k', 'resistance_rmse_ohm', 'plot')
# column -> (axis label, scale from SI to the plotted unit)
UNITS = {'power': ('power (W)', 1.0), 'power_2': ('power (W)', 1.0),
         'load': ('load (N)', 1.0), 'displacement': ('contraction (mm)', 1e3),
         'temperature': ('temperature (degC)', 1.0),
         'temperature_2': ('temperature (degC)', 1.0),
         'resistance': ('resistance (ohm)', 1.0), 'resistance_2': ('resistance (ohm)', 1.0),
         'force': ('force (N)', 1.0), 'force_2': ('force (N)', 1.0),
         'angle': ('angle (rad)', 1.0), 'angular_velocity': ('angular velocity (rad/s)', 1.0),
         'torque': ('torque (N m)', 1.0)}
INPUT_COLUMNS = ('power', 'power_2', 'load')


def add_simulate_options(sp, source, simulate):
    """Add --compare (to the ``source`` group, beside --input), --out and --plot to ``sp``.

    ``simulate`` is cli.cmd_simulate, run for a plain ``--input``.
    """
    source.add_argument('--compare', nargs='+', metavar='REC',
                        help='records (paths or shipped names, e.g. rec_1W_30g): simulate '
                             "each record's time,power,load, plot model over measurement "
                             'and print the error per record (docs/records.md)')
    sp.add_argument('--out', default=None,
                    help='with --compare: directory for one PNG per record and compare.csv '
                         '(created; if omitted: out/compare)')
    sp.add_argument('--plot', default=None, metavar='FILE',
                    help='with --input: also draw the simulated columns to this PNG')
    sp.add_argument('--draws', type=draws_count, default=DEFAULT_DRAWS, metavar='N',
                    help='with --compare or --plot and a calibrated config (# posterior: '
                         'header): parameter sets drawn from the calibration posterior for '
                         f'the 90 %% band (0: none; default {DEFAULT_DRAWS})')
    sp.set_defaults(func=functools.partial(run_simulate, simulate=simulate))


def run_simulate(args, out, simulate):
    """Dispatch ``simulate``: a comparison with records, or a profile (optionally plotted)."""
    if args.compare:
        if args.plot:
            raise InputError(f'--plot = {clip(args.plot)!r}: only with --input; --compare '
                             'writes one PNG per record to --out')
        return compare(args, out)
    if args.out:
        raise InputError(f'--out = {clip(args.out)!r}: only with --compare (with --input '
                         'the CSV goes to stdout; --plot FILE draws it)')
    args.input = _resolve(args.input, '--input', 'profile_')
    if not args.plot:
        return simulate(args, out)
    _check_folder(args.plot, '--plot')
    posterior = posterior_of_config(args.config, args.draws)
    tee = _Tee(out)
    status = simulate(args, tee)
    if status == EXIT_OK:
        from tca_ros.cli.common import params_from_args
        params = params_from_args(args)
        limits = profile_band(tee.getvalue(), params, posterior, args)
        plot_simulation(tee.getvalue(), args.plot, f'{os.path.basename(args.input)}, '
                        f'config {os.path.basename(args.config)}, model {params.model}',
                        limits, posterior)
    return status


class _Tee(io.StringIO):
    """Text sink that also forwards everything to ``out``."""

    def __init__(self, out):
        super().__init__()
        self._out = out

    def write(self, text):
        self._out.write(text)
        return super().write(text)


def _resolve(name, option, prefix):
    """Return the file of a path or shipped name; a missing path is left to its reader."""
    path = resolve_example(name)
    if path is None and os.path.basename(name) != name:
        return name  # the reader names it (cannot open / no such file)
    if path is None:
        raise InputError(f'{option} = {clip(name)!r}: no such file, and not a shipped '
                         f'example ({", ".join(shipped_examples(prefix))})')
    return path


def _check_folder(path, option):
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise InputError(f'{option} = {clip(path)!r}: directory {clip(folder)!r} does not '
                         'exist')


def compare(args, out):
    """Simulate each record's inputs; write a PNG per record; print the errors (CSV)."""
    from tca_ros.cli.common import checked_config
    from tca_ros.params.files import load_params
    from tca_ros.records.data import read_record
    if args.rig not in (None, 'dead_weight'):
        raise InputError(f'--rig = {args.rig}: --compare simulates dead-weight records '
                         '(columns time,power,load); allowed: dead_weight')
    for name, value in (('--physics-rate', args.physics_rate),):
        if not value > 0.0:
            raise InputError(f'{name} = {value:g}: must be a positive rate in Hz')
    overrides = {'model': args.model} if args.model else {}
    from tca_ros.calibration.transfer import read_trained_range
    params = load_params(checked_config(args.config), **overrides)
    if params.rig.mode != 'dead_weight':
        raise InputError(f'--config = {clip(args.config)!r}: rig.mode = {params.rig.mode}; '
                         '--compare simulates dead-weight records (pass --rig dead_weight)')
    trained = read_trained_range(checked_config(args.config))
    scales = (trained or {}).get('environment')
    paths = [_resolve(name, '--compare', 'rec_') for name in args.compare]
    posterior = posterior_of_config(args.config, args.draws)
    records = [read_record(path, max_samples=args.max_samples) for path in paths]
    from tca_ros.cli.common import warn_reading
    warn_reading('compare', records)
    for path, record in zip(paths, records):
        steps = record.duration * max(args.physics_rate, record.sample_rate)
        if not steps <= args.max_steps:
            raise InputError(f'{path}: {record.duration:.4g} s at --physics-rate '
                             f'{args.physics_rate:g} Hz is {steps:.4g} physics steps; the '
                             f'limit is {args.max_steps} (--max-steps)')
    folder = args.out or os.path.join('out', 'compare')
    os.makedirs(folder, exist_ok=True)
    label = f'config {os.path.basename(args.config)}, model {params.model}'
    rows, bands = [], []
    samples = []
    if posterior is not None:
        from tca_ros.calibration.posterior import draw_params
        samples = draw_params(params, posterior, args.draws, seed=0)
    out.write(','.join(SUMMARY_COLUMNS) + '\n')
    for name, record in zip(_unique_stems(paths), records):
        model = simulate_record(params, record, args.physics_rate, scales)
        errors = record_errors(record, model)
        png = os.path.join(folder, name + '.png')

        def run(p, rate, r=record):
            return _outputs(simulate_record(p, r, rate, scales))
        drawn = band_of(samples, run, _outputs(model), params,
                        band_rate(args.physics_rate, record.sample_rate), args.physics_rate)
        plot_comparison(record, model, errors, png, f'{name}: {label}', drawn[0], posterior)
        rows.append(_summary_row(name, record, errors, png))
        out.write(rows[-1] + '\n')
        if posterior is not None:
            bands.append(band_row(name, record, drawn, posterior))
    for row in bands:
        out.write(band_line(row, posterior) + '\n')
    with open(os.path.join(folder, 'compare.csv'), 'w', encoding='utf-8') as fh:
        fh.write(','.join(SUMMARY_COLUMNS) + '\n' + '\n'.join(rows) + '\n')
    if posterior is not None:
        with open(os.path.join(folder, 'band.csv'), 'w', encoding='utf-8') as fh:
            fh.write(','.join(BAND_COLUMNS) + '\n' + '\n'.join(
                ','.join('' if v is None else (f'{v:.3g}' if isinstance(v, float) else str(v))
                         for v in row) for row in bands) + '\n')
    return EXIT_OK


def _outputs(result):
    """Return {column: array} of a SimulationResult's displacement, temperature, resistance."""
    return {c: getattr(result, c) for c in ('displacement', 'temperature', 'resistance')}


def _unique_stems(paths):
    stems = [os.path.splitext(os.path.basename(p))[0] for p in paths]
    return [s if stems.count(s) == 1 else f'{s}_{i + 1}' for i, s in enumerate(stems)]


def simulate_record(params, record, physics_rate, scales=None):
    """Return the SimulationResult of ``record``'s inputs (its mass, load, supply, air).

    ``scales``: {environment: heat-loss scale (-)} the calibration fitted (its params
    file's ``calibrated_on`` header); an environment without one takes its prior's.
    """
    from tca_ros.calibration.conditions import in_environment
    from tca_ros.calibration.predictions import record_params
    from tca_ros.model.simulation import simulate
    supply = str(record.meta.get('supply', 'power')).strip()
    if supply not in SUPPLIES:
        row = record.meta_rows.get('supply', 1)
        raise InputError(f"{record.source}: row {row}, column 'supply': {clip(supply)!r}; "
                         f'allowed {", ".join(SUPPLIES)}')
    # the record's air flow scales the heat loss (fitted, else its prior's: a fan's 2.5x)
    result = simulate(in_environment(record_params(params, record), record, scales),
                      record.time, record.power, record.load, physics_rate=physics_rate,
                      supply=supply)
    for column in ('displacement', 'temperature', 'resistance'):
        values = getattr(result, column)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise ValueError(f'{record.source}: the model left its valid range: {column} is '
                             f'{values[bad[0]]!r} at {record.time[bad[0]]:g} s')
    return result


def record_errors(record, model):
    """Return {name: value} of the model's errors against ``record`` (SI: m, K, ohm, -).

    ``rmse`` (m) of the displacement, ``peak`` (m) the record's peak stroke (robust
    to single-sample spikes), ``nrmse`` = rmse / peak, and ``temperature`` (K) and
    ``resistance`` (ohm) RMSE when the record has the column (else None).
    """
    from tca_ros.calibration.predictions import peak_stroke

    def rmse(measured, modelled):
        return None if measured is None else float(np.sqrt(np.mean((measured - modelled) ** 2)))

    disp = rmse(record.displacement, model.displacement)
    peak = peak_stroke(record)
    return {'rmse': disp, 'peak': peak, 'nrmse': disp / peak,
            'temperature': rmse(record.temperature, model.temperature),
            'resistance': rmse(record.resistance, model.resistance)}


def _summary_row(name, record, errors, png):
    def fmt(value, scale=1.0):
        return '' if value is None else f'{value * scale:.3g}'

    return ','.join((name, str(record.time.size), fmt(errors['rmse'], 1e3),
                     fmt(errors['peak'], 1e3), fmt(errors['nrmse'], 100.0),
                     fmt(errors['temperature']), fmt(errors['resistance']), png))


def _pyplot():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def plot_comparison(record, model, errors, path, title, limits=None, posterior=None):
    """Draw inputs, then measured vs modelled displacement (temperature, resistance) to PNG.

    ``limits``: {column: (low, high)} of the posterior band (SI), shaded;
    ``posterior``: its posterior, whose unmeasured channels are labelled.
    """
    from tca_ros.calibration.posterior import BAND_LABEL, UNMEASURED_NOTE, unmeasured, \
        with_residual
    limits = limits or {}
    caveat = set(unmeasured(posterior)) if posterior is not None else set()
    plt = _pyplot()
    panels = ['displacement'] + [c for c in ('temperature', 'resistance')
                                 if getattr(record, c) is not None]
    fig, axes = plt.subplots(len(panels) + 1, 1, figsize=(8, 2.2 * (len(panels) + 1)),
                             sharex=True, squeeze=False)
    axes = axes[:, 0]
    axes[0].step(record.time, record.power, where='post', color='tab:red',
                 label='power (record input)')
    axes[0].set_ylabel('power (W)')
    twin = axes[0].twinx()
    twin.step(record.time, record.load, where='post', color='tab:gray', ls='--',
              label='load (record input)')
    twin.set_ylabel('load (N)')
    handles = axes[0].get_legend_handles_labels()
    more = twin.get_legend_handles_labels()
    axes[0].legend(handles[0] + more[0], handles[1] + more[1], fontsize=7, loc='upper right')
    for ax, column in zip(axes[1:], panels):
        label, scale = UNITS[column]
        ax.plot(record.time, scale * getattr(record, column), '.', ms=2, color='k',
                label='measured (record)')
        note = f' {UNMEASURED_NOTE}' if column in caveat else ''
        if column in limits:
            low, high = limits[column]
            rms = (posterior.get('residual_rms') or {}).get(column)
            if rms is not None:
                wide = with_residual(low, high, rms)
                ax.fill_between(model.time, scale * wide[0], scale * wide[1],
                                color='tab:blue', alpha=0.1, lw=0,
                                label='with the calibration residual (where a '
                                      'measurement should fall)')
            ax.fill_between(model.time, scale * low, scale * high, color='tab:blue',
                            alpha=0.3, lw=0, label=BAND_LABEL + note)
        ax.plot(model.time, scale * getattr(model, column), color='tab:blue', lw=1.2,
                label='modelled (tca_sim)' + note)
        ax.set_ylabel(label)
        ax.legend(fontsize=7, loc='best')
    width = ''
    if 'displacement' in limits:
        half = 0.5 * np.max(limits['displacement'][1] - limits['displacement'][0])
        width = f'; 90 % band at most +-{1e3 * half:.2g} mm'
    axes[1].set_title(f'RMSE {1e3 * errors["rmse"]:.3g} mm = {100 * errors["nrmse"]:.3g} % '
                      f'of the peak stroke {1e3 * errors["peak"]:.3g} mm{width}', fontsize=9)
    axes[-1].set_xlabel('time (s)')
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_simulation(text, path, title, limits=None, posterior=None):
    """Draw each column of ``simulate``'s CSV ``text`` against time to a PNG at ``path``.

    ``limits``: {column: (low, high)} of the posterior band (SI), shaded;
    ``posterior``: its posterior, whose unmeasured channels are labelled.
    """
    from tca_ros.calibration.posterior import BAND_LABEL, UNMEASURED_NOTE, unmeasured
    limits = limits or {}
    caveat = set(unmeasured(posterior)) if posterior is not None else set()
    names, table = csv_table(text)
    columns = [n for n in names[1:] if n in UNITS]
    plt = _pyplot()
    fig, axes = plt.subplots(len(columns), 1, figsize=(8, 1.8 * len(columns)), sharex=True,
                             squeeze=False)
    for ax, name in zip(axes[:, 0], columns):
        label, scale = UNITS[name]
        values = scale * table[:, names.index(name)]
        if name in INPUT_COLUMNS:
            ax.step(table[:, 0], values, where='post', color='tab:red',
                    label=f'{name} (profile input)')
        else:
            note = f' {UNMEASURED_NOTE}' if name in caveat else ''
            if name in limits:
                ax.fill_between(table[:, 0], scale * limits[name][0], scale * limits[name][1],
                                color='tab:blue', alpha=0.3, lw=0, label=BAND_LABEL + note)
            ax.plot(table[:, 0], values, color='tab:blue', label=f'{name} (modelled){note}')
        ax.set_ylabel(label)
        ax.legend(fontsize=7, loc='upper right')
    axes[-1, 0].set_xlabel('time (s)')
    fig.suptitle(f'simulated: {title}', fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
