"""Regressors of the noise model (noise.py tests residuals against them).

The nuisance terms a sensor's drift takes, and the signals the inputs drive.
"""
import math

import numpy as np

#: share (-) of a prediction's fastest rate below which it counts as holding (last_direction)
DIRECTION_FLOOR = 0.02


def nuisance_columns(size, block_rate, start=None):
    """Return the nuisance regressors (size x 1 or 2) of one record's block means.

    ``start`` (s): time of the segment's first sample since the record's zero (a
    record reads zero at its start: an encoder is zeroed, a CSV is made
    relative). Then a sensor offset is no noise and the one nuisance term is a
    linear drift from that zero, (t - t_0) at the block centres scaled to unit
    size. ``start`` None: an offset and a linear drift over the segment.
    """
    if start is None:
        return np.column_stack([np.ones(size), np.linspace(-1.0, 1.0, size)])
    t = float(start) + (np.arange(size) + 0.5) / block_rate
    scale = float(t[-1]) if size and t[-1] > 0.0 else 1.0
    return (t / scale)[:, None]


def remove_nuisance(values, block_rate, start=None):
    """Return ``values`` (block means) minus their least-squares nuisance part."""
    values = np.asarray(values, dtype=float)
    if values.size < 3:
        return values - values.mean() if values.size and start is None else values
    basis = nuisance_columns(values.size, block_rate, start)
    coef, *_ = np.linalg.lstsq(basis, values, rcond=None)
    return values - basis @ coef


def nuisance_design(items):
    """Return one nuisance matrix per segment, over columns shared where drifts are.

    ``items``: (size, block rate in Hz, start in s or None, group or None) per
    segment. A segment with a start has a linear drift from its record's zero
    (:func:`nuisance_columns`); segments of one ``group`` (the held-out blocks of
    one record) share that drift, as a sensor's drift runs on through the blocks.
    A segment without a start has its own offset and drift.
    """
    keys, widths = [], {}
    for i, (size, _, start, group) in enumerate(items):
        key = ('own', i) if start is None or group is None else ('group', group)
        keys.append(key)
        widths[key] = 2 if start is None else 1
    offset, at = {}, 0
    for key in dict.fromkeys(keys):
        offset[key] = at
        at += widths[key]
    times = {}
    for (size, rate, start, _), key in zip(items, keys):
        if start is not None:
            t = float(start) + (np.arange(size) + 0.5) / rate
            times[key] = max(times.get(key, 0.0), float(t[-1]) if size else 0.0)
    mats = []
    for (size, rate, start, _), key in zip(items, keys):
        block = np.zeros((size, at))
        if start is None:
            block[:, offset[key]:offset[key] + 2] = nuisance_columns(size, rate)
        else:
            t = float(start) + (np.arange(size) + 0.5) / rate
            block[:, offset[key]] = t / (times[key] if times[key] > 0.0 else 1.0)
        mats.append(block)
    return mats


def remove_nuisance_jointly(blocks, items):
    """Return each of ``blocks`` (block means) minus the least-squares nuisance part.

    ``items`` as :func:`nuisance_design`; segments of one group share a drift.
    """
    if not blocks:
        return []
    mats = nuisance_design(items)
    stacked = np.concatenate(blocks)
    if stacked.size < 3:
        return [b - b.mean() if b.size and it[2] is None else b for b, it in zip(blocks, items)]
    design = np.vstack(mats)
    coef, *_ = np.linalg.lstsq(design, stacked, rcond=None)
    return [b - m @ coef for b, m in zip(blocks, mats)]


def first_order_lag(signal, sample_rate, tau):
    """Return the signal through 1 / (tau s + 1) (exact for a held input; same units)."""
    a = math.exp(-1.0 / (sample_rate * tau)) if tau > 0.0 else 0.0
    out = np.empty(len(signal))
    y = float(signal[0])
    for i, u in enumerate(signal):
        y = a * y + (1.0 - a) * u
        out[i] = y
    return out


def input_terms(predicted, rise, power, sample_rate, thermal_tau):
    """Return the regressor matrix of input-driven signals (columns scaled to unit RMS).

    predicted: model displacement or temperature (channel units); rise: predicted
    temperature rise (K); power (W); thermal_tau (s): the model's time constant.
    """
    return _scaled_columns(_input_signals(predicted, rise, power, sample_rate, thermal_tau))


def input_terms_in_runs(predicted, rise, power, sample_rate, thermal_tau, runs):
    """Return [regressor matrix] of :func:`input_terms` in each index run (i0, i1).

    The signals are formed, centred and scaled over the whole record (the power's
    lags carry their history into a run), then cut into the runs: every run has
    the same columns, and a run's level of a signal is part of it (a model
    error that follows the predicted level from block to block is predictable).
    """
    signals = _input_signals(predicted, rise, power, sample_rate, thermal_tau)
    out = []
    for c in signals:
        c = c - c.mean()
        s = float(np.sqrt(np.mean(c ** 2)))
        out.append(c / s if s > 0.0 and np.all(np.isfinite(c)) else np.zeros_like(c))
    return [np.column_stack([c[a:b] for c in out]) for a, b in runs]


def _input_signals(predicted, rise, power, sample_rate, thermal_tau):
    predicted = np.asarray(predicted, dtype=float)
    centred = predicted - predicted.mean()
    rate = np.gradient(predicted) * sample_rate
    return [centred, centred ** 2, rate, np.asarray(rise, dtype=float),
            first_order_lag(power, sample_rate, thermal_tau / 3.0),
            first_order_lag(power, sample_rate, 3.0 * thermal_tau),
            last_direction(rate)]


def last_direction(rate, floor=DIRECTION_FLOOR):
    """Return the sign (-) of the last motion of a prediction whose rate is ``rate``.

    +1 after a rise, -1 after a fall, held while the prediction moves slower than
    ``floor`` times its fastest rate (any unit per s); 0 before its first motion.
    A play between the prediction and the reading (friction holding the end, a
    hysteresis of the stroke in temperature) leaves a residual of this sign that
    it keeps while the prediction holds: the heating and cooling branches of the
    residual against temperature. Linear in no other signal here, a test on the
    rest would take it for noise (decisions G77).
    """
    rate = np.asarray(rate, dtype=float)
    fastest = float(np.max(np.abs(rate))) if rate.size else 0.0
    if not fastest > 0.0:
        return np.zeros(rate.size)
    moving = np.abs(rate) > floor * fastest
    last = np.maximum.accumulate(np.where(moving, np.arange(rate.size), -1))
    return np.where(last >= 0, np.sign(rate[np.maximum(last, 0)]), 0.0)


def _scaled_columns(cols):
    """Return the columns centred and scaled to unit RMS (constant ones dropped)."""
    out = []
    for c in cols:
        c = c - c.mean()
        s = float(np.sqrt(np.mean(c ** 2)))
        if s > 0.0 and np.all(np.isfinite(c)):
            out.append(c / s)
    return np.column_stack(out) if out else np.zeros((np.size(cols[0]), 0))
