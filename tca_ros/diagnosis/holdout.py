"""Which parts of a record train a fit and which are held out to judge it.

Two layouts (docs/diagnosis_method.md, "Held-out part"):

- ``'blocks'`` (the default): the record is cut into N_BLOCKS blocks of equal
  duration; the last one is held out (a prediction beyond the training data, as
  a tail tests it) and the others held out are spread over the record (never the
  first block: the initial rest trains). A record with one heating step and one
  cooling then trains on part of both and is judged on part of both: a tail
  split trains such a record on its heating alone and asks it to predict the
  cooling, where friction, hysteresis and a slower cooling show first.
- ``'tail'``: the last ``1 - train_fraction`` of the record is held out.

``choose_validation`` resolves ``'auto'`` (the diagnosis's default) from the
inputs alone: the tail when its training part holds at least two coolings in
every record, else the blocks.

The model is simulated from the inputs over the whole record either way (an
output-error model: no measured output enters a prediction), so a held-out block
is predicted from the state the simulation carries into it. Times are fractions
of the record's duration, so one HoldOut serves every record of a set and a
record on a coarser grid (the calibration's 10 Hz copy) has the same parts.
"""
from dataclasses import dataclass

import numpy as np

VALIDATIONS = ('blocks', 'tail')
DEFAULT_VALIDATION = 'blocks'
N_BLOCKS = 10  # blocks of the 'blocks' layout


@dataclass(frozen=True)
class HoldOut:
    """Held-out intervals of a record, as fractions of its duration.

    Attributes
    ----------
    intervals : tuple of (float, float)
        Held-out [start, end) of each interval as fractions (-) of the record's
        duration from its first sample; the last may end past 1.
    """

    intervals: tuple

    def heldout_mask(self, time, duration=None):
        """Return the boolean mask of held-out samples of ``time`` (s, a record's grid).

        ``duration`` (s): the record's, when ``time`` is a coarser copy of it
        (default the span of ``time``).
        """
        time = np.asarray(time, dtype=float)
        if duration is None:
            duration = float(time[-1] - time[0]) if time.size else 0.0
        u = (time - time[0]) / duration if duration > 0.0 else np.zeros(time.size)
        mask = np.zeros(time.size, bool)
        for a, b in self.intervals:
            mask |= (u >= a) & (u < b)
        return mask

    def train_mask(self, time, duration=None):
        """Return the boolean mask of training samples of ``time`` (s)."""
        return ~self.heldout_mask(time, duration)

    def runs(self, time):
        """Return [(i0, i1)]: index ranges of the contiguous held-out runs of ``time``."""
        return mask_runs(self.heldout_mask(time))


def mask_runs(mask):
    """Return [(i0, i1)] of the runs of True in a boolean array (i1 exclusive)."""
    m = np.concatenate(([False], np.asarray(mask, bool), [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(m))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def make_holdout(train_fraction, validation=DEFAULT_VALIDATION, n_blocks=N_BLOCKS):
    """Return the HoldOut of a layout that trains on ``train_fraction`` (0-1) of a record.

    'blocks': round(n_blocks (1 - train_fraction)) blocks held out (at least one):
    the last block, and the rest at evenly spread indices that are neither the
    first nor the last.
    Raises ValueError naming the value for an unknown layout or a fraction outside
    (0, 1).
    """
    if validation not in VALIDATIONS:
        raise ValueError(f'validation = {validation!r}: allowed '
                         + ', '.join(repr(v) for v in VALIDATIONS))
    if not 0.0 < train_fraction < 1.0:
        raise ValueError(f'train_fraction = {train_fraction!r}: allowed 0 < value < 1')
    if validation == 'tail':
        return HoldOut(((float(train_fraction), 1.0 + 1e-9),))
    held = min(n_blocks - 1, max(1, int(round(n_blocks * (1.0 - train_fraction)))))
    # the last block (a prediction beyond the training data, as a tail tests it), the
    # rest spread over blocks 1 .. n_blocks-2 (the first block, the initial rest, trains)
    inner = held - 1
    index = sorted({1 + int((j + 0.5) * (n_blocks - 2) / inner) for j in range(inner)}
                   | {n_blocks - 1})
    end = 1.0 + 1e-9  # the last sample belongs to the last block
    return HoldOut(tuple((i / n_blocks, (i + 1) / n_blocks if i < n_blocks - 1 else end)
                         for i in index))


AUTO = 'auto'
MIN_TRAINING_COOLINGS = 2  # coolings in a tail split's training part for 'auto' to keep it
COOLING_DROP = 0.25  # a power fall of this share of the record's peak starts a cooling


def coolings(time, power, end):
    """Return the number of coolings of ``power`` (W) that start before ``end`` (s).

    A cooling starts where the power falls by COOLING_DROP of its peak from one
    sample to the next.
    """
    power = np.asarray(power, dtype=float)
    peak = float(power.max()) if power.size else 0.0
    if peak <= 0.0:
        return 0
    falls = np.flatnonzero(np.diff(power) <= -COOLING_DROP * peak)
    return int(np.sum(np.asarray(time)[falls] < end))


def choose_validation(records, train_fraction, validation=AUTO):
    """Return the layout ('blocks' or 'tail') of ``validation`` for these records.

    'auto': 'tail' when the training part of a tail split holds at least
    MIN_TRAINING_COOLINGS coolings in every record (a profile of several steps, a
    PRBS: the held-out tail asks nothing the training has not shown), else
    'blocks' (a bench's one-step record: its only cooling would be held out).
    """
    if validation != AUTO:
        make_holdout(train_fraction, validation)  # names a bad layout or fraction
        return validation
    for r in records:
        end = r.time[0] + train_fraction * r.duration
        if coolings(r.time, r.power, end) < MIN_TRAINING_COOLINGS:
            return 'blocks'
    return 'tail'
