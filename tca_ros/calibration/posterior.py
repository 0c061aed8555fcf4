"""A calibration's posterior kept in the params file it writes, and parameter sets drawn from it.

`tca_sim calibrate` fits by maximum a posteriori least squares (engine.py); near
the estimate the posterior of the fit coordinates z (ln(value) of a log
parameter, the value (unit) of a linear one) is Gaussian with the engine's
Gauss-Newton covariance. The calibrated params file keeps it in one header line

    # posterior: {"names": [...], "log": [...], "mean": [...], "cov": [[...]],
    #             "low": [...], "high": [...], "base": {...}, "channels": [...],
    #             "model": "...", "residual_rms": {...}, "unknown_stderr": [...]}

``mean`` and ``cov`` are in fit coordinates (order ``names``), ``low``/``high``
the fit bounds, ``channels`` the record channels the calibration fitted,
``residual_rms`` the RMS of its residual per channel (m, K, ohm, N: the sensor
noise plus what the model misses) and
``base`` the START params' values of every params-file entry the calibration
writes (``apply_calibration`` scales some relative to the start, e.g. the moduli
by stiffness_scale). A draw is ``apply_calibration(file params with base written
back, values)``: the mean reproduces the file. The node and ``load_params`` skip
comment lines, so the file stays a valid ROS params file.

Left out of the draws: the records' environment heat-loss scales (conditions of
the records, not of the muscle) and ``initial_temperature_rise`` (a record's
start; the file describes the muscle at rest). Dropping a parameter from a
Gaussian is its marginal, so the others keep their covariance with it. A
parameter whose standard error is unknown (its Jacobian column failed) is drawn
from its prior spread, uncorrelated.
"""
import json
import math

import numpy as np

from tca_ros.calibration.calibration_parameters import apply_calibration
from tca_ros.calibration.conditions import SCALE_PREFIX
from tca_ros.model.params_schema import ParameterError
from tca_ros.model.tca_params import to_flat_dict

POSTERIOR_KEY = 'posterior'  # params-file header line written by `tca_sim calibrate`
NOT_DRAWN = ('initial_temperature_rise',)  # a record's start, not the muscle's
BAND = (5.0, 95.0)  # %, the percentiles of a prediction band (90 %)
Z90 = 1.6448536269514722  # half-width of a Gaussian's central 90 %, in standard deviations
BAND_LABEL = 'model 90 % band (calibration uncertainty)'
UNMEASURED_NOTE = '(not measured in calibration: from the priors)'
OUTPUT_CHANNELS = ('displacement', 'temperature', 'resistance')
REQUIRED = ('names', 'log', 'mean', 'cov', 'low', 'high', 'base', 'channels')
#: The least uncertainty a calibrated params file states for a value it fitted (decision
#: C9): relative for the log parameters, K for T_z, s for the lag. A posterior standard
#: deviation counts only the records' noise; the same muscle logged again on another day
#: (another clamp, humidity, history) differs by more.
CALIBRATED_FLOOR = {'relative': 0.1, 'expansion_zero_temperature': 2.0, 'actuation_lag': 0.5,
                    'expansion_plateau_temperature': 5.0}


class PosteriorError(ValueError):
    """A posterior header line that cannot be used (one-line reason)."""


def posterior_of(cal):
    """Return the JSON-ready posterior of Calibration ``cal`` (fit coordinates)."""
    estimates = cal.report.estimates
    order = list(estimates)
    keep = [n for n in order if not n.startswith(SCALE_PREFIX) and n not in NOT_DRAWN
            and n in cal.priors]
    idx = [order.index(n) for n in keep]
    priors = [cal.priors[n] for n in keep]
    sd = []
    for n, p in zip(keep, priors):
        est = estimates[n]
        s = est.stderr / est.value if p.log else est.stderr
        sd.append(s if math.isfinite(s) and est.value != 0.0 else math.nan)
    sd = np.array(sd)
    corr = cal.report.correlation
    corr = np.eye(len(order)) if corr is None else np.asarray(corr, dtype=float)
    corr = corr[np.ix_(idx, idx)]
    unknown = ~np.isfinite(sd) | np.any(~np.isfinite(corr), axis=1)
    sd = np.where(unknown, [p.spread for p in priors], sd)
    corr = np.where(unknown[:, None] | unknown[None, :], 0.0, corr)
    np.fill_diagonal(corr, 1.0)
    cov = corr * np.outer(sd, sd)
    mean = [p.to_fit(estimates[n].value) for n, p in zip(keep, priors)]
    return {'names': keep, 'log': [bool(p.log) for p in priors], 'mean': mean,
            'cov': cov.tolist(), 'low': [p.fit_bounds()[0] for p in priors],
            'high': [p.fit_bounds()[1] for p in priors],
            'base': _base(cal.start, keep, priors, mean),
            'channels': list(cal.channels), 'model': cal.model,
            'residual_rms': residual_rms(cal.report),
            'unknown_stderr': [n for n, u in zip(keep, unknown) if u]}


def calibrated_uncertainty(params, posterior):
    """Return ``params`` stating, in ``uncertainty.*``, what the calibration left unknown.

    For each parameter of the ``posterior`` (posterior_of) that the uncertainty
    section describes: the posterior standard deviation (relative, exp(sd) - 1, for
    a log parameter; K or s for T_z and the lag), at least CALIBRATED_FLOOR and at
    most the description's value. The calibrated file is the next calibration's and
    diagnosis's description: a later record that moves a calibrated value beyond
    these is a finding (docs/calibration.md, "A calibrated file is a measured
    description"). Values the records left at their priors keep about the
    description's spread.
    """
    stated = params.uncertainty
    values = {}
    for i, (name, log) in enumerate(zip(posterior['names'], posterior['log'])):
        if not hasattr(stated, name):
            continue
        sd = math.sqrt(max(float(posterior['cov'][i][i]), 0.0))
        left = math.expm1(sd) if log else sd
        floor = CALIBRATED_FLOOR.get(name, CALIBRATED_FLOOR['relative'])
        described = float(getattr(stated, name))
        values[f'uncertainty.{name}'] = min(described, max(left, floor))
    return params.with_values(**values) if values else params


def residual_rms(report):
    """Return {channel: RMS (channel unit) of the fit's residual over its records}."""
    rows = report.record_rmse or []
    channels = rows[0].keys() if rows else ()
    return {c: float(np.sqrt(np.mean([r[c] ** 2 for r in rows]))) for c in channels}


def _base(start, names, priors, mean):
    """Return {dotted: start value} of every params-file entry a draw writes."""
    flat = to_flat_dict(start)
    touched = set()
    for shift in (0.0, 1e-2):
        values = {}
        for p, z in zip(priors, mean):
            low, high = p.fit_bounds()
            zz = z + shift * max(1.0, abs(z))
            zz = zz if zz <= high else z - shift * max(1.0, abs(z))
            values[p.name] = p.from_fit(min(max(zz, low), high))
        moved = to_flat_dict(apply_calibration(start, values))
        touched |= {k for k, v in moved.items() if v != flat[k]}
    return {k: flat[k] for k in sorted(touched)}


def write_line(posterior):
    """Return the params-file header line that stores ``posterior`` (one JSON line)."""
    return f'{POSTERIOR_KEY}: {json.dumps(posterior, separators=(",", ":"))}'


def header_entry(path, key):
    """Return the text after ``key:`` on a params file's leading comment lines, or None."""
    with open(path, encoding='utf-8') as fh:
        for line in fh:
            if not line.startswith('#'):
                break
            text = line.lstrip('#').strip()
            if text.startswith(key + ':'):
                return text[len(key) + 1:]
    return None


def read_posterior(path):
    """Return the posterior stored in a params file's header, or None if it has none.

    Raises PosteriorError naming the file and the field when the line is malformed.
    """
    text = header_entry(path, POSTERIOR_KEY)
    return None if text is None else check_posterior(text, path)


def check_posterior(text, path=''):
    """Return the posterior dict parsed from JSON ``text``; PosteriorError if malformed."""
    where = f'{path}: ' if path else ''
    try:
        post = json.loads(text)
    except ValueError as exc:
        raise PosteriorError(f"{where}'# {POSTERIOR_KEY}:' header is not JSON ({exc})") from None
    if not isinstance(post, dict):
        raise PosteriorError(f"{where}'# {POSTERIOR_KEY}:' header must be a JSON object")
    missing = [k for k in REQUIRED if k not in post]
    if missing:
        raise PosteriorError(f"{where}'# {POSTERIOR_KEY}:' header lacks {missing[0]!r} "
                             f'(needs {", ".join(REQUIRED)})')
    n = len(post['names'])
    for key in ('log', 'mean', 'low', 'high'):
        if len(post[key]) != n:
            raise PosteriorError(f"{where}'# {POSTERIOR_KEY}:' {key} has {len(post[key])} "
                                 f'entries: must have one per name ({n})')
    cov = np.asarray(post['cov'], dtype=float)
    if cov.shape != (n, n) or not np.all(np.isfinite(cov)):
        raise PosteriorError(f"{where}'# {POSTERIOR_KEY}:' cov must be a finite {n} x {n} "
                             f'matrix (got shape {cov.shape})')
    return post


def draw_coordinates(posterior, n, seed=0):
    """Return (n, k) fit coordinates drawn from N(mean, cov), clipped to the bounds."""
    mean = np.asarray(posterior['mean'], dtype=float)
    cov = np.asarray(posterior['cov'], dtype=float)
    rng = np.random.default_rng(seed)
    z = rng.multivariate_normal(mean, 0.5 * (cov + cov.T), size=int(n), method='eigh')
    return np.clip(z, posterior['low'], posterior['high'])


def values_of(posterior, z):
    """Return {name: value (unit)} of the fit coordinates ``z`` (one row)."""
    return {name: (math.exp(zi) if log else float(zi))
            for name, log, zi in zip(posterior['names'], posterior['log'], z)}


def draw_params(params, posterior, n, seed=0):
    """Return ``n`` TcaParams drawn from ``posterior`` around the calibrated ``params``.

    ``params``: the calibrated params file's TcaParams (the draws keep everything
    the calibration did not fit, e.g. a --model override). A draw the params
    schema refuses (a value past its allowed range) is left out, so fewer than
    ``n`` may return.
    """
    base = params.with_values(**posterior['base']) if posterior['base'] else params
    out = []
    for z in draw_coordinates(posterior, n, seed):
        try:
            out.append(apply_calibration(base, values_of(posterior, z)))
        except ParameterError:
            continue
    return out


def mean_params(params, posterior):
    """Return the params of the posterior mean (equal to the calibrated file's)."""
    base = params.with_values(**posterior['base']) if posterior['base'] else params
    return apply_calibration(base, values_of(posterior, posterior['mean']))


def unmeasured(posterior):
    """Return the output channels the calibration's records did not measure."""
    fitted = set(posterior.get('channels', ()))
    return [c for c in OUTPUT_CHANNELS if c not in fitted]


def band(samples, axis=0):
    """Return (low, high): the BAND percentiles of ``samples`` along ``axis``."""
    low, high = np.percentile(np.asarray(samples, dtype=float), BAND, axis=axis)
    return low, high


def share_inside(measured, low, high):
    """Return the share (-) of ``measured`` samples within [low, high]."""
    measured = np.asarray(measured, dtype=float)
    return float(np.mean((measured >= low) & (measured <= high)))


def with_residual(low, high, rms):
    """Return the band (low, high) widened by a Gaussian residual of ``rms``.

    The half-widths add in quadrature with the residual's 90 % half-width
    (Z90 x rms): where a measurement is expected to fall, not only the model.
    """
    centre, half = 0.5 * (high + low), 0.5 * (high - low)
    half = np.sqrt(half ** 2 + (Z90 * rms) ** 2)
    return centre - half, centre + half
