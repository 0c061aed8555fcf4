"""What a record cannot see: the shortest lag its samples and noise could show (issue 25).

A lag tau much shorter than the response's own time scale delays a channel x by

    x(t - tau) = x(t) - tau dx/dt + O(tau^2)

whether it is the sensor's (a first-order lag, y' = (x - y) / tau, gives the same
first term), the drive's dead time or a second thermal lag ahead of the actuation.
The residual it leaves is tau dx/dt, of RMS tau RMS(dx/dt) over the samples, and the
verdict calls a residual structured only above its practical floor (the AR noise or
0.5 % of the swing, noise.structure_test). So a lag shorter than

    tau_min = floor / RMS(dx/dt)

leaves less than the floor on this record and cannot be seen, however long the
search; dx/dt is the calibrated nominal model's, at the record's samples (a record
sampled slower than its steps loses their slopes, and tau_min grows). The smallest
tau_min of the channels and parts (held-out, whole record) is reported when no lag
effect is named, so an `adequate` or `unexplained` verdict says which lags it leaves
open (docs/diagnosis_method.md, "One load, and what a record cannot see").
"""
import math

import numpy as np

from tca_ros.diagnosis.search import LAG_EFFECTS

UNITS = {'displacement': 'um', 'temperature': 'K'}
SCALE = {'displacement': 1e6, 'temperature': 1.0}


def lag_detection_limit(problems, sims, stats, whole_stats):
    """Return (tau_min in s, channel, floor in channel units) of the records, or None.

    ``problems``/``sims``: the FitProblems and the calibrated nominal model's
    record-rate simulations; ``stats``/``whole_stats``: its {channel: ResidualStats}
    on the held-out part and on the whole record. None when no channel has a
    structure test or a slope.
    """
    best = None
    for part, whole in ((stats, False), (whole_stats, True)):
        for channel, st in part.items():
            if st.structure is None or not st.structure.floor > 0.0:
                continue
            slopes = np.concatenate([
                np.gradient(getattr(s, channel), p.record.time)[
                    slice(None) if whole else p.full_heldout_index]
                for p, s in zip(problems, sims)])
            rms = float(np.sqrt(np.mean(slopes ** 2))) if slopes.size else 0.0
            if not rms > 0.0 or not math.isfinite(rms):
                continue
            tau = st.structure.floor / rms
            if best is None or tau < best[0]:
                best = (tau, channel, st.structure.floor)
    return best


def detectability_note(problems, sims, stats, whole_stats, effects):
    """Return the note on the lags this record cannot show ([] when a lag is named).

    Arguments as :func:`lag_detection_limit`; ``effects`` the effects named.
    """
    if set(effects) & set(LAG_EFFECTS):
        return []
    limit = lag_detection_limit(problems, sims, stats, whole_stats)
    if limit is None:
        return []
    tau, channel, floor = limit
    rate = problems[0].sample_rate
    return [f'a lag shorter than {tau:.2g} s ({", ".join(LAG_EFFECTS)}) cannot show in '
            f'these records: it moves {channel} by about the lag times its rate of change, '
            f'less than the structure floor ({floor * SCALE[channel]:.3g} '
            f'{UNITS[channel]}) at {rate:.3g} Hz; not being named says nothing about such '
            'a lag (docs/diagnosis_method.md, "One load, and what a record cannot see")']
