"""When a record's samples were taken: at their stamps, or on a clock they scatter around.

Two loggers write jittered stamps. One reads its sensors when it is polled and
stamps each row when it reads it: the stamps are the sample times, unevenly
spaced. The other samples on a steady clock (a microcontroller's timer) and the
host stamps each row when it arrives: the samples are evenly spaced and the
stamps carry the transport's latency. Read at its stamps, the second logger's
record moves each sample by its latency, an error of the latency times the
signal's rate of change: during a heating at 2 Hz with latencies of +-0.1 s, a
tenth of a millimetre.

The outputs tell the two apart. Each inner sample of a measured output
(displacement, temperature, resistance, force) is predicted from its two
neighbours by linear interpolation at its time, once at the stamps and once on
the clock (:func:`slot_clock`); sensor noise and the signal's curvature enter
both alike, the timing error only the wrong one. The per-sample difference of
the squared errors (each output in units of its mean squared error), summed over
the record, is weighed by its standard error (:func:`clock_evidence`): the clock
is taken when the outputs read smoother on it (z > CLOCK_Z = 0), the stamps
otherwise, and the note says how strongly. The two losses are alike (a sample
moved by a latency either way), so the record's own evidence decides, however
weak: on records of one muscle sampled both ways from a 100 Hz simulation (ten
muscles, stamps scattered by up to 20 % of a period), it chose right in 18 of 20
at 1 Hz and 19 of 20 at 2 Hz, and in every case from 5 Hz, where |z| > 2
(decisions G81). A record whose outputs do not vary keeps its stamps.
"""
import math

import numpy as np

#: standard errors by which the outputs must read smoother on the clock than at the
#: stamps for the clock to replace the stamps (-): the better of the two, however weakly
CLOCK_Z = 0.0
#: |z| below which the note calls the evidence weak (-)
WEAK_Z = 2.0
#: outputs whose samples carry the evidence (a Record's optional channels included)
OUTPUTS = ('displacement', 'temperature', 'resistance', 'force')
#: standard errors of the stamps' period within which the clock keeps the header's (-)
SLOPE_Z = 3.0
SHARED_LAGS = 2  # samples apart whose interpolation errors share a sample


def slot_clock(time, rate):
    """Return the ticks (s) of the steady clock the stamps ``time`` (s) scatter around, or None.

    ``rate`` (Hz): the header's sample rate. Each interval between stamps is
    counted in ticks of the median interval (one, or more where the logger lost
    samples: a gap stays a gap); the clock's period and phase are the
    least-squares line of the stamps on those tick numbers, the period 1 / rate
    where the line's is within SLOPE_Z standard errors of it (a clock the
    stamps cannot tell from the header's runs at the header's rate). None when
    a stamp is half a period or more from its tick: the stamps are not one
    clock's ticks read with a latency.
    """
    time = np.asarray(time, dtype=float)
    steps = np.diff(time)
    period = float(np.median(steps)) if steps.size else 1.0 / rate
    if not period > 0.0 or time.size < 3:
        return None
    slots = np.concatenate(([0.0], np.cumsum(np.maximum(1.0, np.round(steps / period)))))
    period, phase = np.polyfit(slots, time, 1)
    spread = np.sum((slots - slots.mean()) ** 2)
    late = time - (phase + period * slots)
    error = math.sqrt(float(late @ late) / max(time.size - 2, 1) / spread)
    if abs(period - 1.0 / rate) <= SLOPE_Z * error:  # the header's rate, as far as they tell
        period = 1.0 / rate
        phase = float(np.mean(time - period * slots))
    ticks = phase + period * slots
    if not period > 0.0 or np.max(np.abs(time - ticks)) >= 0.5 * period:
        return None
    return ticks


def interpolation_errors(time, values):
    """Return each inner sample less the line through its two neighbours, at its time.

    ``time`` (s) and ``values`` (any unit), n samples: n - 2 errors (same unit
    as ``values``), of samples 1 to n - 2.
    """
    t = np.asarray(time, dtype=float)
    y = np.asarray(values, dtype=float)
    share = (t[1:-1] - t[:-2]) / (t[2:] - t[:-2])
    return y[1:-1] - (y[:-2] + share * (y[2:] - y[:-2]))


def clock_evidence(record, ticks):
    """Return the z by which ``record``'s outputs read smoother on ``ticks`` than at the stamps.

    Per inner sample, the sum over the measured outputs of (e_stamps^2 -
    e_clock^2) / (the output's mean of both), e the interpolation error
    (:func:`interpolation_errors`); z is their mean over its standard error, with
    the covariance of neighbours that share samples (lags 1 and 2, Bartlett
    weights: Newey and West 1987). Positive: the clock predicts the samples
    better. 0.0 when no output varies.
    """
    total = None
    for name in OUTPUTS:
        y = getattr(record, name, None)
        if y is None or np.ptp(y) == 0.0:
            continue
        at_stamps = interpolation_errors(record.time, y) ** 2
        on_clock = interpolation_errors(ticks, y) ** 2
        scale = 0.5 * float(np.mean(at_stamps + on_clock))
        if not scale > 0.0:
            continue
        d = (at_stamps - on_clock) / scale
        total = d if total is None else total + d
    if total is None or total.size < 3 * SHARED_LAGS:
        return 0.0
    centred = total - np.mean(total)
    variance = float(centred @ centred)
    for lag in range(1, SHARED_LAGS + 1):
        variance += 2.0 * (1.0 - lag / (SHARED_LAGS + 1)) * float(centred[lag:] @ centred[:-lag])
    if not variance > 0.0:
        return 0.0
    return float(np.sum(total)) / math.sqrt(variance)


def sampled_on_clock(record, rate):
    """Return (the clock's ticks (s) or None, the note saying which times were taken).

    ``rate`` (Hz): the header's sample rate (:func:`slot_clock`). The ticks
    when the stamps of ``record`` scatter around a steady clock
    (:func:`slot_clock`) and its outputs read smoother on it (:func:`clock_evidence`
    above CLOCK_Z); else None and the stamps stand. The note (None when the
    stamps are no clock's) says what was decided, the stamps' largest distance
    from the clock and the evidence.
    """
    ticks = slot_clock(record.time, rate)
    if ticks is None:
        return None, None
    rate = 1.0 / float(np.median(np.diff(ticks)))  # the clock's own rate (Hz)
    late = float(np.max(np.abs(record.time - ticks)) * rate)
    z = clock_evidence(record, ticks)
    how = 'weakly, ' if abs(z) < WEAK_Z else ''
    where = (f'stamps scatter up to {100.0 * late:.0f} % of a period around a steady '
             f'{rate:.4g} Hz clock')
    if z > CLOCK_Z:
        return ticks, (f'{where}; the outputs read smoother on it ({how}z = {z:.1f}): samples '
                       'taken on the clock, the scatter as stamping latency (docs/records.md, '
                       '"Jittered stamps")')
    return None, (f'{where}; the outputs read no smoother on it ({how}z = {z:.1f}): samples '
                  'taken at their stamps (docs/records.md, "Jittered stamps")')
