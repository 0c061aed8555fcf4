"""Where in the records the model's residual sits: a calibration's fit, a verdict's residual.

A calibration that fits badly somewhere, or an ``unexplained`` verdict, says the model
misses something; a reader then wants to look at the records where it misses most. A
model error the muscle makes everywhere (a wrong stroke law, a missing lag) spreads its
residual over every heating and cooling; an event of one moment (a reading that jumps, a
mass that touches, a clamp that slips, a first heating unlike the later ones) puts much
of it into a few seconds. ``residual_window`` finds the window of WINDOW_SHARE of the
records' time whose residual, less each record's offset and linear drift (the
verdict's nuisance), carries the largest share of the squared residual, and
``window_note`` says it when that share is at least CONCENTRATION times the window's
share of the samples.
"""
import math

import numpy as np

#: the window's length as a share of all the records' time together (-); at least
#: MIN_WINDOW_SAMPLES samples
WINDOW_SHARE = 0.05
MIN_WINDOW_SAMPLES = 3
#: a window is reported when its share of the squared residual is at least this many
#: times its share of the samples (-): 45 % in 5 %. Records with no event of one moment
#: reached 21-40 % (their largest steps), a 2 mm reading jump 91 %, the filmed muscle's
#: reading dip 53 % (docs/diagnosis_method.md, "Where the residual sits")
CONCENTRATION = 9.0
#: the reported span is the window's samples whose residual exceeds this many times the
#: RMS of the rest of their record (-)
TRIM_FACTOR = 4.0


def detrended(residual, time, fitted=None):
    """Return ``residual`` less its least-squares offset and linear drift over ``time`` (s).

    ``fitted``: a boolean mask of the samples the offset and drift are fitted on
    (default all); they are taken out of every sample.
    """
    design = np.column_stack([np.ones_like(time), time - time[0]])
    keep = slice(None) if fitted is None else fitted
    coef, *_ = np.linalg.lstsq(design[keep], residual[keep], rcond=None)
    return residual - design @ coef


def residual_window(records, residuals):
    """Return (record index, t0 s, t1 s, share of the squared residual, share of samples).

    ``records``: Records (time in s); ``residuals``: per record, the measured less the
    predicted channel (channel unit), on each record's samples. None when the
    residual is zero or the records are too short for a window.
    """
    parts = [detrended(np.asarray(r, float), rec.time) for rec, r in zip(records, residuals)]
    total = sum(float(p @ p) for p in parts)
    n_all = sum(p.size for p in parts)
    span = WINDOW_SHARE * sum(rec.duration for rec in records)
    if total <= 0.0 or not math.isfinite(total):
        return None
    best = None
    for k, (rec, part) in enumerate(zip(records, parts)):
        width = max(MIN_WINDOW_SAMPLES, int(round(span * rec.sample_rate)))
        if part.size < width:
            continue
        energy = np.convolve(part ** 2, np.ones(width), mode='valid')
        i = int(np.argmax(energy))
        if best is None or energy[i] > best[0]:
            best = (float(energy[i]), k, i, width)
    if best is None:
        return None
    energy, k, i, width = best
    time = records[k].time
    return k, float(time[i]), float(time[i + width - 1]), energy / total, width / n_all


def window_note(records, residuals, channel, unit_scale, unit):
    """Return the note on a concentrated residual of ``channel``, or None.

    ``unit_scale`` and ``unit``: how the note prints the RMS (1e3, 'mm' for metres).
    """
    found = residual_window(records, residuals)
    if found is None:
        return None
    k, t0, t1, share, samples = found
    if share < CONCENTRATION * samples:
        return None
    rec = records[k]
    inside = (rec.time >= t0) & (rec.time <= t1)
    # the record's offset and drift from the rest of it: the moment would pull them
    part = detrended(np.asarray(residuals[k], float), rec.time,
                     ~inside if (~inside).sum() >= 2 else None)
    rms_out = float(np.sqrt(np.mean(part[~inside] ** 2))) if (~inside).any() else 0.0
    # the window's span where the residual stands out from the rest of its record
    loud = np.flatnonzero(inside & (np.abs(part) > TRIM_FACTOR * rms_out))
    if loud.size:
        t0, t1 = float(rec.time[loud[0]]), float(rec.time[loud[-1]])
        inside = (rec.time >= t0) & (rec.time <= t1)
    rms_in = float(np.sqrt(np.mean(part[inside] ** 2))) * unit_scale
    rms_out *= unit_scale
    name = rec.source or f'record {k + 1}'
    return (f'the {channel} residual is concentrated: {share:.0%} of its square lies in '
            f'{samples:.0%} of the samples, {name} at t = {t0:.4g}-{t1:.4g} s (RMS '
            f'{rms_in:.3g} {unit} there, {rms_out:.3g} {unit} in the rest of that record, '
            'less its offset and drift): one moment carries much of what the model '
            "misses (a reading's jump, a touch, a slip, a first heating unlike the "
            'others); look at the record there (docs/diagnosis_method.md, "Where the '
            'residual sits")')


#: how the notes print each channel's residual (scale, unit)
PRINTED = {'displacement': (1e3, 'mm'), 'temperature': (1.0, 'K')}


def where_notes(records, sims, channels):
    """Return the notes of :func:`window_note` for ``channels`` (names) of ``records``.

    ``records``: Records; ``sims``: per record the simulation judged (an object
    with the channels as attributes, SI units), on the records' samples.
    """
    out = []
    for c in dict.fromkeys(channels):
        scale, unit = PRINTED.get(c, (1.0, ''))
        note = window_note(records, [getattr(r, c) - getattr(s, c)
                                     for r, s in zip(records, sims)], c, scale, unit)
        if note:
            out.append(note)
    return out
