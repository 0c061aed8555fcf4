"""Operations on a Record that keep its meaning: a leading part, a coarser grid."""
import dataclasses

import numpy as np

MEASURED = ('displacement', 'temperature', 'resistance')


def leading_part(record, fraction):
    """Return the first ``fraction`` (0-1] of ``record``'s duration as a Record."""
    split = int(np.searchsorted(record.time, record.time[0] + fraction * record.duration))
    return _take(record, slice(0, split))


def decimated(record, rate):
    """Return ``record`` on a grid of about ``rate`` (Hz), or itself when not faster.

    Inputs (power W, load N) are held from each sample to the next, so a coarse
    sample holds the mean of the fine ones it covers: the heat input is kept.
    Measured channels (m, degC, ohm) are averaged over a window centred on the
    coarse sample, which keeps their timing and averages sensor noise down.
    """
    k = int(round(record.sample_rate / rate)) if rate > 0.0 else 1
    if k < 2:
        return record
    n = record.time.size
    starts = np.arange(0, n, k)
    changes = {'time': record.time[starts],
               'power': _block_mean(record.power, starts),
               'load': _block_mean(record.load, starts)}
    changes['load'][0] = record.load[0]  # the initial equilibrium uses load[0]
    for name in MEASURED:
        values = getattr(record, name)
        if values is not None:
            changes[name] = _centred_mean(values, starts, k)
    meta = dict(record.meta)
    meta['sample_rate_hz'] = record.sample_rate / k
    return dataclasses.replace(record, meta=meta, **changes)


def _take(record, index):
    changes = {'time': record.time[index], 'power': record.power[index],
               'load': record.load[index]}
    for name in MEASURED:
        values = getattr(record, name)
        changes[name] = None if values is None else values[index]
    return dataclasses.replace(record, **changes)


def _block_mean(values, starts):
    sums = np.add.reduceat(np.asarray(values, dtype=float), starts)
    counts = np.diff(np.append(starts, len(values)))
    return sums / counts


def _centred_mean(values, starts, k):
    """Return the mean of ``values`` over a window of k sample intervals centred on each start.

    An odd k averages the k samples around the start; an even k the k + 1 samples
    from k/2 before to k/2 after it, the two ends at half weight (the trapezoid
    rule), so the mean sits at the start's own time either way. A window the
    record's ends cut is narrowed to the samples on both sides that it has. A
    window of k whole samples from k/2 before the start would sit half a sample
    early: a 20 Hz record decimated to 10 Hz would read 25 ms late against the
    model, which a calibration takes up as a slower mechanical response (decisions
    G79).
    """
    values = np.asarray(values, dtype=float)
    n = values.size
    cum = np.concatenate(([0.0], np.cumsum(values)))
    reach = np.minimum(np.minimum(starts, n - 1 - starts), k // 2)  # samples each side
    sums = cum[starts + reach + 1] - cum[starts - reach]
    counts = (2 * reach + 1).astype(float)
    if k % 2 == 0:
        whole = reach == k // 2
        ends = values[starts[whole] - reach[whole]] + values[starts[whole] + reach[whole]]
        sums[whole] -= 0.5 * ends
        counts[whole] = k
    return sums / counts
