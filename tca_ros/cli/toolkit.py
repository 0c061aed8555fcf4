"""`tca_sim linearize` and `tca_sim score`: tools for the controller developer.

The methods are in tca_ros.toolkit (docs/toolkit.md); ``linearize`` checks the
request, prints poles, gains, bandwidths and transfer functions and, with ``--out
DIR``, writes the Bode plot and the matrices; ``score`` is in cli_score.
"""
import json
import math
import os

import numpy as np

from tca_ros.cli.band import draws_count, posterior_of_config
from tca_ros.cli.common import checked_config, finite_float, InputError
from tca_ros.cli.score import add_parser as add_score_parser

CHANNELS = (('power', 'displacement'), ('power', 'temperature'), ('power', 'resistance'),
            ('load', 'displacement'), ('voltage', 'displacement'))
LINEARIZE_DRAWS = 40  # posterior draws of the uncertainty (each a linearisation)
THERMAL_POLE_MATCH = 1e-6  # relative distance at which a pole is A[0, 0] itself
EXAMPLE = """example (the free-stroke TCA at 1 W under its config's load; Bode plot in out/lin):
  tca_sim linearize --config free_stroke --power 1 --out out/lin"""


def add_parser(subparsers):
    """Register ``linearize`` on the `tca_sim` subparsers."""
    from tca_ros.cli.common import add_config_options
    sp = subparsers.add_parser(
        'linearize',
        help='small-signal plant (power or voltage -> displacement, temperature, '
             'resistance) at an operating point: poles, DC gain, bandwidth, Bode plot',
        description='Linearize the muscle at a constant power and load; print the operating '
                    'point, poles, DC gains, bandwidths and transfer functions '
                    '(docs/toolkit.md).', epilog=EXAMPLE)
    add_config_options(sp)
    sp.add_argument('--power', type=finite_float, required=True,
                    help='operating power P0 (W), held constant')
    sp.add_argument('--load', type=finite_float, default=None,
                    help="external tensile load F (N); default: the config's dynamics.load")
    sp.add_argument('--out', default=None,
                    help='directory (DIR) for bode.png and linear_model.json (A, B, C, D)')
    sp.add_argument('--draws', type=draws_count, default=LINEARIZE_DRAWS, metavar='N',
                    help='with a calibrated config (# posterior: header): parameter sets '
                         'drawn from the calibration posterior for the uncertainty of the DC '
                         f'gains and time constants (0: none; default {LINEARIZE_DRAWS})')
    sp.set_defaults(func=cmd_linearize)
    add_score_parser(subparsers)


def _check(args):
    from tca_ros.records.data import MAX_LOAD_N, MAX_POWER_W
    if not 0.0 <= args.power <= MAX_POWER_W:
        raise InputError(f'--power = {args.power:g} W: allowed 0 to {MAX_POWER_W:g} W')
    if args.load is not None and not 0.0 <= args.load <= MAX_LOAD_N:
        raise InputError(f'--load = {args.load:g} N: allowed 0 to {MAX_LOAD_N:g} N (tensile)')
    if args.out and os.path.exists(args.out) and not os.path.isdir(args.out):
        raise InputError(f'--out = {args.out!r}: exists and is not a directory')


def cmd_linearize(args, out):
    """Print the linear plant at (--power, --load); write the plot and matrices."""
    from tca_ros.params.files import load_params
    from tca_ros.toolkit.linearize import linearize, OperatingPointError
    _check(args)
    overrides = {'model': args.model} if args.model else {}
    params = load_params(checked_config(args.config), **overrides)
    posterior = posterior_of_config(args.config, args.draws)
    if params.coil.shape != 'helix':
        raise InputError(f'--config = {args.config!r}: linearize needs a helical TCA (this '
                         f'one is {params.coil.shape}; tca_sim simulate runs it)')
    try:
        plants = {drive: linearize(params, args.power, args.load, drive=drive)
                  for drive in ('power', 'voltage')}
    except OperatingPointError as exc:
        raise InputError(str(exc)) from None
    spread = None
    if posterior is not None:
        from tca_ros.calibration.posterior import draw_params
        from tca_ros.toolkit.linearize import drawn_figures
        spread = drawn_figures(draw_params(params, posterior, args.draws, seed=0),
                               args.power, args.load)
        spread['requested'] = args.draws  # draws the params schema refused count as failed
    write_summary(params, plants, out, posterior, spread)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        from tca_ros.toolkit.plots import save_bode
        p = plants['power']
        title = (f'{params.tca_type}, {p.model}: P0 = {p.point.power:g} W, '
                 f'F = {p.point.load:g} N, T = {p.point.temperature:.1f} degC')
        curves = [(plants['power'], 'displacement', 'power'),
                  (plants['power'], 'temperature', 'power'),
                  (plants['power'], 'resistance', 'power'),
                  (plants['voltage'], 'displacement', 'voltage')]
        save_bode(curves, os.path.join(args.out, 'bode.png'), title)
        record = {d: plant_record(pl) for d, pl in plants.items()}
        if spread is not None and spread['draws'] >= 2:
            record['uncertainty'] = spread_record(spread)
        with open(os.path.join(args.out, 'linear_model.json'), 'w', encoding='utf-8') as fh:
            json.dump(record, fh, indent=1)
        out.write(f'wrote {os.path.join(args.out, "bode.png")} and linear_model.json\n')
    return 0


def plant_record(plant):
    """Return a JSON-ready dict of a LinearPlant: matrices, names, units, point."""
    from dataclasses import asdict
    point = {k: (list(v) if isinstance(v, tuple) else v)
             for k, v in asdict(plant.point).items()}
    return {'drive': plant.drive, 'model': plant.model, 'states': list(plant.states),
            'inputs': list(plant.inputs), 'outputs': ['displacement', 'temperature',
                                                      'resistance'],
            'units': 'SI; temperature in K as a deviation, degC in the operating point',
            'A': plant.A.tolist(), 'B': plant.B.tolist(), 'C': plant.C.tolist(),
            'D': plant.D.tolist(), 'dead_time': plant.dead_time, 'operating_point': point}


def _pole_lines(plant):
    import control
    thermal = plant.A[0, 0]
    lines = []
    for pole in sorted(control.poles(plant.system()), key=lambda z: -z.real):
        if pole.imag < 0.0:
            continue
        if pole.imag > 0.0:
            wn = abs(pole)
            lines.append(f'  {pole.real:.5g} +- {pole.imag:.5g}j   wn {wn:.5g} rad/s, '
                         f'zeta {-pole.real / wn:.3g}')
            continue
        tag = ' (eq. (1), thermal)' if abs(pole.real - thermal) <= THERMAL_POLE_MATCH * abs(
            thermal) else ''
        tau = -1.0 / pole.real if pole.real != 0.0 else math.inf
        lines.append(f'  {pole.real:.5g}   tau {tau:.5g} s{tag}')
    return lines


def write_summary(params, plants, out, posterior=None, spread=None):
    """Print operating point, poles, gains, bandwidths and transfer functions.

    ``posterior`` (a calibrated config's, or None) labels the outputs its records
    did not measure; ``spread`` (linearize.drawn_figures) adds their uncertainty.
    """
    from tca_ros.calibration.posterior import UNMEASURED_NOTE, unmeasured
    from tca_ros.toolkit.linearize import INPUT_UNITS, OUTPUT_UNITS
    caveat = set(unmeasured(posterior)) if posterior is not None else set()
    p = plants['power']
    op = p.point
    out.write(f'# linear plant of {params.tca_type} (model {p.model}) at P0 = {op.power:g} W, '
              f'F = {op.load:g} N\n')
    if caveat:
        out.write(f'# {" and ".join(sorted(caveat))} {UNMEASURED_NOTE}: the calibration\'s '
                  'records had no such channel\n')
    out.write(f'# operating point: T {op.temperature:.5g} degC'
              + (f' {UNMEASURED_NOTE}' if 'temperature' in caveat else '') + ', displacement '
              f'{op.displacement * 1e3:.5g} mm, R {op.resistance:.5g} ohm (V0 '
              f'{op.voltage:.5g} V), axial stiffness {op.stiffness:.5g} N/m\n')
    out.write(f'# states: {", ".join(p.states)} (K, m, m/s deviations)\n')
    for drive, plant in plants.items():
        out.write(f'poles (1/s), {drive} drive:\n')
        out.write('\n'.join(_pole_lines(plant)) + '\n')
    out.write(f'{"channel":<24} {"dc_gain":>12} {"unit":>7} {"bandwidth_rad_s":>16} '
              f'{"bandwidth_hz":>13} {"mean_delay_s":>13}\n')
    for inp, output in CHANNELS:
        plant = plants['voltage' if inp == 'voltage' else 'power']
        gain = plant.dc_gain(output, inp)
        bandwidth = plant.bandwidth(output, inp)
        unit = f'{OUTPUT_UNITS[output]}/{INPUT_UNITS[inp]}'
        note = f' {UNMEASURED_NOTE}' if output in caveat else ''
        out.write(f'{inp + "->" + output:<24} {gain:>12.5g} {unit:>7} {bandwidth:>16.5g} '
                  f'{bandwidth / (2.0 * math.pi):>13.5g} '
                  f'{plant.mean_delay(output, inp):>13.5g}{note}\n')
    tau, delay = p.thermal_time_constant(), p.mean_delay()
    out.write(f'thermal time constant {tau:.5g} s = {100.0 * tau / delay:.4g} % of the mean '
              f'delay {delay:.5g} s of power->displacement (dead time {p.dead_time:g} s)\n')
    if spread is not None and spread['draws'] >= 2:
        write_spread(plants, spread, caveat, out)
    elif spread is not None:
        out.write(f'uncertainty: only {spread["draws"]} of {spread["requested"]} posterior '
                  'draws could be linearised: none given\n')
    for drive in ('power', 'voltage'):
        tf = plants[drive].transfer_function()
        text = '\n'.join(line for line in str(tf).splitlines()[3:] if line.strip())
        out.write(f'transfer function {drive}->displacement (m/{INPUT_UNITS[drive]}):\n'
                  f'{text}\n')


def _nominal(plants, key):
    """Return the figure ``key`` (linearize.drawn_figures' names) of the calibrated plants."""
    if key == 'thermal_time_constant':
        return plants['power'].thermal_time_constant()
    inp, output = key.split('->')
    return plants['voltage' if inp == 'voltage' else 'power'].dc_gain(output, inp)


def write_spread(plants, spread, caveat, out):
    """Print each DC gain and the thermal time constant +- its posterior spread."""
    from tca_ros.calibration.posterior import UNMEASURED_NOTE
    from tca_ros.toolkit.linearize import figure_unit
    out.write(f'uncertainty from the calibration posterior ({spread["draws"]} of '
              f'{spread["requested"]} draws linearised; the value +- the draws\' standard '
              'deviation (their 5-95 %)):\n')
    for key, values in spread['figures'].items():
        low, high = np.percentile(values, (5.0, 95.0))
        note = f' {UNMEASURED_NOTE}' if key.split('->')[-1] in caveat else ''
        name = 'thermal time constant' if key == 'thermal_time_constant' else \
            f'{key} dc_gain'
        out.write(f'  {name} {_nominal(plants, key):.5g} +- {np.std(values, ddof=1):.2g} '
                  f'{figure_unit(key)} ({low:.5g} to {high:.5g}){note}\n')


def spread_record(spread):
    """Return a JSON-ready dict of ``spread``: per figure its draws' mean, std, 5 and 95 %."""
    out = {'draws': spread['draws'], 'requested': spread['requested']}
    for key, values in spread['figures'].items():
        low, high = np.percentile(values, (5.0, 95.0))
        out[key] = {'mean': float(np.mean(values)), 'std': float(np.std(values, ddof=1)),
                    'p5': float(low), 'p95': float(high)}
    return out
