"""Prediction bands of a calibrated config for `tca_sim simulate` (--compare and --plot).

A params file written by `tca_sim calibrate` keeps its posterior in a
``# posterior:`` header (calibration/posterior.py). These helpers draw ``--draws``
parameter sets from it, simulate each with the full dynamics (18) on the same
inputs, and return the 5-95 % band per output; ``--compare`` prints per record
the share of measured samples inside the band and inside it widened by the
calibration's residual RMS (``# band:`` lines, ``DIR/band.csv``).
"""
import argparse

import numpy as np

from tca_ros.cli.common import InputError
from tca_ros.records.data import clip

DEFAULT_DRAWS = 20  # posterior draws of a prediction band (each a full simulation)
MAX_DRAWS = 1000
BAND_CHANNELS = ('displacement', 'temperature', 'resistance')
BAND_COLUMNS = ('record', 'draws') + tuple(
    f'{c}_{kind}_percent' for c in BAND_CHANNELS for kind in ('in_band', 'in_band_residual'))


def draws_count(text):
    """Return the --draws count of ``text``: 0 (no band) or 2 to MAX_DRAWS."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not (value == 0 or 2 <= value <= MAX_DRAWS):
        raise argparse.ArgumentTypeError(f'{text!r}: allowed 0 (no band) or an integer 2 to '
                                         f'{MAX_DRAWS}')
    return value


def posterior_of_config(config, draws):
    """Return the ``# posterior:`` of params file ``config`` (None: none, or draws 0)."""
    from tca_ros.calibration.posterior import PosteriorError, read_posterior
    from tca_ros.cli.common import checked_config
    if not draws:
        return None
    try:
        return read_posterior(checked_config(config))
    except PosteriorError as exc:
        raise InputError(f'--config = {clip(config)!r}: {exc}') from None


def band_rate(physics_rate, sample_rate):
    """Return the physics rate (Hz) of the band's draws.

    The calibration's own full-dynamics rate (MIN_PHYSICS_RATE_HZ, or the record's
    sample rate if higher), unless ``physics_rate`` is lower: each draw is a full
    simulation, and the spread between draws at one rate is what the band needs.
    """
    from tca_ros.calibration.predictions import MIN_PHYSICS_RATE_HZ
    return min(physics_rate, max(MIN_PHYSICS_RATE_HZ, sample_rate))


def band_of(samples, simulate_one, centre, params, rate, physics_rate):
    """Return ({column: (low, high)}, draws used) of the draws ``samples`` about ``centre``.

    ``simulate_one(params, rate)`` returns {column: array}; ``centre`` is that of
    the calibrated ``params`` at ``physics_rate`` (the model line). The draws run
    at ``rate`` (:func:`band_rate`): their BAND percentiles of the deviation from
    ``params`` simulated at the same rate are laid about ``centre``, so the band
    carries the calibration's spread, not the rates' discretisation difference.
    A draw that cannot be simulated (ValueError, ArithmeticError) is left out.
    """
    from tca_ros.calibration.posterior import band
    runs = []
    for p in samples:
        try:
            runs.append(simulate_one(p, rate))
        except (ValueError, ArithmeticError):
            continue
    if len(runs) < 2:
        return {}, len(runs)
    reference = centre if rate == physics_rate else simulate_one(params, rate)
    out = {}
    for c in runs[0]:
        low, high = band([r[c] - reference[c] for r in runs])
        out[c] = (centre[c] + low, centre[c] + high)
    return out, len(runs)


def profile_band(text, params, posterior, args):
    """Return {column: (low, high)} of the posterior band of a dead-weight profile run.

    ``text``: the CSV ``simulate`` printed (its time, power and load columns are
    the inputs held between rows, its outputs the model line); {} without a
    posterior or on another rig.
    """
    if posterior is None or params.rig.mode != 'dead_weight':
        return {}
    from tca_ros.calibration.posterior import draw_params
    from tca_ros.model.rig_simulation import simulate_rig
    names, table = csv_table(text)
    t, power, load = (table[:, names.index(c)] for c in ('time', 'power', 'load'))
    centre = {c: table[:, names.index(c)] for c in BAND_CHANNELS}

    def run(p, rate):
        columns = simulate_rig(p, t, power, load, physics_rate=rate).columns
        return {c: np.asarray(columns[c]) for c in BAND_CHANNELS}
    rate = band_rate(args.physics_rate, args.rate)
    limits, _ = band_of(draw_params(params, posterior, args.draws, seed=0), run, centre,
                        params, rate, args.physics_rate)
    return limits


def band_row(name, record, drawn, posterior):
    """Return (name, draws, then per channel % of samples in the band and in it widened).

    The widened band adds the calibration's residual RMS (posterior.with_residual);
    None where the record lacks the channel or the calibration has no residual of it.
    """
    from tca_ros.calibration.posterior import share_inside, with_residual
    limits, used = drawn
    rms = posterior.get('residual_rms') or {}
    shares = []
    for column in BAND_CHANNELS:
        measured = getattr(record, column)
        if measured is None or column not in limits:
            shares += [None, None]
            continue
        shares.append(100.0 * share_inside(measured, *limits[column]))
        shares.append(100.0 * share_inside(measured, *with_residual(
            *limits[column], rms[column])) if column in rms else None)
    return (name, used, *shares)


def band_line(row, posterior):
    """Return the ``# band:`` line of one record (a comment line beside the CSV)."""
    from tca_ros.calibration.posterior import UNMEASURED_NOTE, unmeasured
    name, used = row[:2]
    if used < 2:
        return f'# band: {name}: no band ({used} of the posterior draws could be simulated)'
    parts = []
    for k, column in enumerate(BAND_CHANNELS):
        share, wide = row[2 + 2 * k:4 + 2 * k]
        if share is None:
            continue
        note = f' {UNMEASURED_NOTE}' if column in unmeasured(posterior) else ''
        more = f' ({wide:.0f} % with the residual)' if wide is not None else ''
        parts.append(f'{column} {share:.0f} %{more}{note}')
    return (f'# band: {name}: measured samples inside the model 90 % band of {used} '
            f'posterior draws: {", ".join(parts)}')


def csv_table(text):
    """Return (column names, 2-D array) of a CSV ``text`` with one header row."""
    lines = text.splitlines()
    return lines[0].split(','), np.array([[float(v) for v in line.split(',')]
                                          for line in lines[1:]], ndmin=2)
