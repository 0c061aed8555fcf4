"""A noise model estimated from the data, and tests that do not assume white residuals.

Real records carry noise that is not white: encoder quantisation, 1/f wander and
drift, stick-slip steps, slow sensor offsets. A test that compares the residual
RMS with a white-noise level calls every real record "unexplained", and one that
counts samples as independent makes every candidate "significant". Both the
verdict and the search's acceptance of a candidate (heldout_deviance_gain) are
answered with a model of the noise fitted to the data:

**Is what is left noise?** (:func:`structure_test`) Noise, however coloured,
does not depend on the inputs; missing physics does. The residual is
regressed on signals the inputs drive (the predicted displacement and its
square and rate, the predicted temperature rise, the power through faster
and slower first-order lags than the thermal one, the direction of the
prediction's last motion, which a play keeps), with a sensor drift from
the record's zero as nuisance term (an offset and a drift over the segment when
its start is not given) and an AR(p) noise model (p by BIC, its memory
capped at MAX_NOISE_TAU_S; feasible generalised least squares, Cochrane &
Orcutt, JASA 44, 1949). The F-test of
the input terms is Ljung's residual-input independence test (System
Identification, 2nd ed., Sec. 16.6) in regression form. A residual is
*structured* when the input terms are significant and what they predict is
larger than the noise (what neither they nor the nuisance terms describe:
it is not "within the noise") and than 0.5 % of the measured stroke or swing (a
model error below that is no practical error of a simulator); or when the
rest is itself larger than 5 % of the swing (no sensor is that noisy).
"""
from dataclasses import dataclass
import math

import numpy as np
from scipy import stats

from tca_ros.diagnosis.input_wander import chance_projection, cholesky_factors, \
    fit_wander_noise, groups_of, whiten
from tca_ros.diagnosis.regressors import nuisance_design, remove_nuisance_jointly

STRUCTURE_ALPHA = 1e-3  # significance level of the residual-input test
STRUCTURE_NOISE_SHARE = 1.0  # predictable residual within this many noise RMS is noise
STRUCTURE_FLOOR = 0.005  # ... and below this share of the signal swing is ignored
MAX_NOISE_SHARE = 0.05  # a "noise" above this share of the swing is no sensor's: unexplained
STRUCTURE_RATE_HZ = 2.0  # the structure test runs on block means at about this rate (Hz)
MAX_AR_ORDER = 3  # highest order of the AR noise model
MAX_NOISE_TAU_S = 5.0  # s: noise memory beyond this is drift (a nuisance term), not AR
QUANTISATION_SHARE = 0.95  # share of differences on a lattice for it to count as one


def quantisation_step(signal):
    """Return the lattice step of a quantised signal (signal units), or 0.

    An encoder or ADC reports multiples of a step q: then nearly all sample
    differences are integer multiples of the smallest non-zero one.
    """
    d = np.abs(np.diff(np.asarray(signal, dtype=float)))
    scale = float(np.max(np.abs(signal))) if np.size(signal) else 0.0
    nonzero = d[d > 1e-9 * max(scale, 1e-300)]
    if nonzero.size < 10:
        return 0.0
    q = float(np.percentile(nonzero, 1.0))
    ratio = nonzero / q
    on_lattice = np.abs(ratio - np.round(ratio)) < 0.05
    return q if on_lattice.mean() >= QUANTISATION_SHARE else 0.0


def quantisation_sigma(signal):
    """Return q / sqrt(12) (signal units): the noise of rounding to the step q."""
    return quantisation_step(signal) / math.sqrt(12.0)


def block_means(values, step):
    """Return the means of consecutive blocks of ``step`` samples (a partial tail dropped)."""
    values = np.asarray(values, dtype=float)
    n = values.size // step
    return values[:n * step].reshape(n, step).mean(axis=1) if n else values[:0]


def _segment(seg):
    """Return (residual, terms, sample rate, start, group, scale, path) (None if absent).

    A segment is (residual, terms, sample rate[, start[, group[, scale[, path]]]]).
    """
    return (*seg[:3], *(seg[k] if len(seg) > k else None for k in (3, 4, 5, 6)))


def ar_fit(e, order):
    """Return (AR coefficients, innovation variance) of ``e`` by least squares."""
    e = np.asarray(e, dtype=float)
    if order == 0:
        return np.zeros(0), float(np.mean(e ** 2))
    lagged = np.column_stack([e[order - j - 1:e.size - j - 1] for j in range(order)])
    phi, *_ = np.linalg.lstsq(lagged, e[order:], rcond=None)
    innov = e[order:] - lagged @ phi
    return phi, float(np.mean(innov ** 2))


def ar_order(e, max_order=MAX_AR_ORDER):
    """Return the AR order (0..max_order) with the lowest BIC for ``e``."""
    n = len(e)
    best, best_bic = 0, math.inf
    for p in range(0, min(max_order, n // 10) + 1):
        _, var = ar_fit(e[max_order - p:] if p < max_order else e, p)
        if var <= 0.0:
            return p
        bic = (n - max_order) * math.log(var) + p * math.log(n - max_order)
        if bic < best_bic:
            best, best_bic = p, bic
    return best


def prewhiten(x, phi):
    """Return x[t] - sum_j phi_j x[t-j-1] (rows of a vector or matrix), first p dropped."""
    p = len(phi)
    x = np.asarray(x, dtype=float)
    out = x[p:].copy()
    for j, c in enumerate(phi):
        out -= c * x[p - j - 1:x.shape[0] - j - 1]
    return out


@dataclass
class StructureTest:
    """Residual-input independence test of one channel (channel units)."""

    p_value: float  # of the input terms (F-test after prewhitening)
    predictable_rms: float  # RMS of the part of the residual the input terms predict
    noise_rms: float  # RMS at the record rate of the AR noise model (+ within blocks)
    floor: float  # practical floor on predictable_rms
    ar_order: int  # order of the AR noise model
    n: int  # samples in the test (block means)
    swing: float = math.inf  # range of the measured signal (channel units)
    wander_rms: float = 0.0  # RMS of the block means beyond offset, drift and inputs
    #: (sigma_w -, tau_w s) of the unlogged input wander (input_wander.py), or None
    supply: tuple = None

    @property
    def structured(self):
        """Return True when the residual is more than noise.

        The inputs predict a practically relevant part of it, or what neither
        they nor an offset and a drift per record describe is itself larger than
        MAX_NOISE_SHARE of the swing (no sensor is that noisy: the model misses
        something the regressors do not describe).
        """
        predicted = self.p_value < STRUCTURE_ALPHA and self.predictable_rms > self.floor
        return predicted or self.wander_rms > MAX_NOISE_SHARE * self.swing


def structure_test(segments, swing, rate_hz=STRUCTURE_RATE_HZ, floor_share=STRUCTURE_FLOOR,
                   noise_share=STRUCTURE_NOISE_SHARE, supply=None):
    """Return the StructureTest of residuals against input-driven terms.

    ``segments`` is a list of (residual, terms, sample rate in Hz[, start[, group[, scale]]]),
    one per record or per held-out run of a record
    (terms from :func:`regressors.input_terms`, same columns in every record); ``swing`` is
    the measured signal's range (channel units). The practical floor on the
    predictable part is the larger of ``noise_share`` times the noise (the
    standard deviation of the fitted AR noise model of the block means plus the
    spread within the blocks, at the record rate: "within the noise") and
    ``floor_share`` times the swing. An offset, a drift or a wander slower than
    the noise model's memory is no noise floor: a defect whose residual is mostly
    an offset (fatigue) or a slow settling (creep under a constant load) would
    otherwise hide the rest of it.
    Both are averaged over blocks to about ``rate_hz`` (white sensor noise
    averages out, the structure stays). Nuisance terms per record
    (:func:`regressors.nuisance_columns`): a linear drift from the record's zero when the
    segment's start (s since that zero) is given as a 4th element, else an
    offset and a linear drift over the segment; segments of one group (a 5th
    element: the held-out runs of one record) share one drift. The AR(p) noise model is
    fitted to the full regression's
    residual and both regressions are prewhitened with it (each record on its
    own) before the F-test. A 6th element ``scale`` (the response level at the
    residual's samples, channel units; None for a measured power) marks a
    record whose power column is the command: the noise model is then the
    sensor noise plus the unlogged input wander of input_wander.py, and its
    wander counts in the noise floor; a 7th element ``path`` (input_wander.WanderPath)
    passes the wander through the muscle's lags to the channel; ``supply``
    (sigma_w, tau_w in s) holds the wander at another channel's estimate of it (one
    supply feeds every channel).
    """
    parts, blocked, scales, paths = [], [], [], []
    segments = [_segment(seg) for seg in segments]
    native = np.concatenate([np.asarray(r, dtype=float) for r, *_ in segments])
    native_ms = float(np.mean(native ** 2)) if native.size else 0.0
    items = []
    wander = any(seg[5] is not None for seg in segments)
    for residual, terms, sample_rate, start, group, scale, path in segments:
        step = max(1, int(round(sample_rate / rate_hz)))
        e = block_means(residual, step)
        blocked.append(e)
        if e.size < 6 or terms.shape[1] == 0:
            continue
        x = np.column_stack([block_means(c, step) for c in terms.T])
        block_rate = sample_rate / step
        parts.append((e, x))
        items.append((e.size, block_rate, start, group))
        scales.append(np.zeros(e.size) if scale is None else block_means(scale, step))
        paths.append(path)
    # the nuisance terms of each segment, zero elsewhere (shared within a group)
    parts = [(e, x, u) for (e, x), u in zip(parts, nuisance_design(items))]
    n = sum(e.size for e, _, _ in parts)
    if n < 12 or not parts:
        e = np.concatenate(blocked) if blocked else np.zeros(0)
        floor = max(floor_share * swing, noise_share * math.sqrt(native_ms))
        return StructureTest(1.0, 0.0, math.sqrt(native_ms), floor, 0, e.size, swing)
    cols = min(x.shape[1] for _, x, _ in parts)
    es = [e for e, _, _ in parts]
    xs = [x[:, :cols] for _, x, _ in parts]
    k = parts[0][2].shape[1]
    nuis = [u for _, _, u in parts]
    noise = (_WanderWhitener(items, scales, supply, paths) if wander
             else _ArWhitener(math.exp(-1.0 / (block_rate * MAX_NOISE_TAU_S))))
    full = [np.column_stack([u, x]) for u, x in zip(nuis, xs)]
    # the unwhitened least-squares fit: the feasible GLS's start, and below the size of
    # the predictable part
    raw, *_ = np.linalg.lstsq(np.vstack(full), np.concatenate(es), rcond=None)
    beta = raw
    for _ in range(2):  # feasible GLS: noise model from the residual, refit whitened
        noise.fit(np.concatenate([e - f @ beta for e, f in zip(es, full)]))
        ew, nw, fw = noise.apply(es), noise.apply(nuis), noise.apply(full)
        beta, *_ = np.linalg.lstsq(fw, ew, rcond=None)
    q = np.linalg.matrix_rank(fw) - np.linalg.matrix_rank(nw)
    dof = ew.size - np.linalg.matrix_rank(fw)
    beta0, *_ = np.linalg.lstsq(nw, ew, rcond=None)
    ssr0 = float(np.sum((ew - nw @ beta0) ** 2))
    ssr1 = float(np.sum((ew - fw @ beta) ** 2))
    if q <= 0 or dof <= 0 or ssr1 <= 0.0:
        p = 1.0 if ssr0 <= ssr1 * (1.0 + 1e-12) else 0.0
    else:
        f = max((ssr0 - ssr1) / q / (ssr1 / dof), 0.0)
        p = float(stats.f.sf(f, q, dof))
    # the size of the predictable part from the unwhitened least-squares projection
    # (at most the residual itself); the GLS fit above only decides significance
    predictable = np.concatenate([x @ raw[k:] - np.mean(x @ raw[k:]) for x in xs])
    rest = np.concatenate([e - f @ raw for e, f in zip(es, full)])
    predictable_ms = float(np.mean(predictable ** 2))
    # the noise by the model of the noise (an offset, a drift or a wander slower than
    # its memory is not in it), plus the spread within the blocks
    innovation_var = ssr1 / dof if dof > 0 else 0.0
    design = (np.vstack(full), np.vstack(nuis)) if wander else None
    noise_rms = math.sqrt(noise.variance(innovation_var, design)
                          + _within_block_ms(segments, rate_hz))
    floor = max(floor_share * swing, noise_share * noise_rms)
    return StructureTest(p_value=p, predictable_rms=math.sqrt(predictable_ms),
                         noise_rms=noise_rms, floor=floor, ar_order=noise.order, n=n,
                         swing=swing, wander_rms=math.sqrt(float(np.mean(rest ** 2))),
                         supply=noise.supply)


class _ArWhitener:
    """Stationary AR(p) noise (p by BIC, memory capped): prewhitens each segment."""

    supply = None  # no input wander

    def __init__(self, rho_max):
        self.rho_max, self.phi = rho_max, np.zeros(0)

    @property
    def order(self):
        """Return p."""
        return len(self.phi)

    def fit(self, resid):
        """Fit the AR model to the stacked residual of every segment."""
        phi, _ = ar_fit(resid, ar_order(resid))
        # the AR noise model may not remember longer than MAX_NOISE_TAU_S: an AR near a
        # unit root would call any slow model error "noise" (slow wander is the drift term)
        self.phi = phi * (self.rho_max / phi.sum()) if phi.sum() > self.rho_max else phi

    def apply(self, blocks):
        """Return the segments' rows prewhitened, stacked (first p of each dropped)."""
        return np.concatenate([prewhiten(b, self.phi) for b in blocks], axis=0)

    def variance(self, innovation_var, design=None):
        """Return the process variance of the block means (channel units^2; ``design`` unused)."""
        return innovation_var * ar_variance_gain(self.phi)


class _WanderWhitener:
    """Sensor noise plus an unlogged input wander (input_wander.py): GLS by Cholesky."""

    order = 1

    def __init__(self, items, scales, supply=None, paths=None):
        self.groups = groups_of(items, scales, paths)
        self.noise, self.factors, self.fixed = None, None, supply

    @property
    def supply(self):
        """Return (sigma_w -, tau_w s) of the fitted or given wander."""
        return (self.noise.sigma_w, self.noise.tau_w)

    def fit(self, resid):
        """Fit the WanderNoise to the stacked residual by maximum likelihood."""
        self.noise = fit_wander_noise(resid, self.groups, MAX_NOISE_TAU_S, self.noise,
                                      self.fixed)
        self.factors = cholesky_factors(self.noise, self.groups)

    def apply(self, blocks):
        """Return the stacked segments' rows whitened by the covariance's Cholesky factor."""
        return whiten(self.factors, self.groups, np.concatenate(blocks, axis=0))

    def variance(self, innovation_var, design=None):
        """Return the noise's mean square that may pass for structure (channel units^2).

        The sensor noise's variance, and of the wander what falls by chance in
        the input terms' span beyond the nuisance terms (``design``: the
        unwhitened stacked (full, nuisance) matrices; input_wander.chance_projection).
        The wander's whole variance would hide any model error smaller than the
        supply's effect on the response, which the GLS test itself tells from the
        wander (G62).
        """
        full, nuisance = design
        return self.noise.sigma_v ** 2 + chance_projection(self.noise, self.groups, full,
                                                           nuisance)


def ar_variance_gain(phi, terms=2000):
    """Return var(x) / var(innovation) (-) of the stationary AR process with ``phi``."""
    p = len(phi)
    if p == 0:
        return 1.0
    psi = np.zeros(terms)
    psi[0] = 1.0
    for j in range(1, terms):
        k = min(p, j)
        psi[j] = float(np.dot(phi[:k], psi[j - 1::-1][:k]))
    return float(np.sum(psi ** 2))


def _within_block_ms(segments, rate_hz):
    """Return the mean square of the residuals about their block means (record rate)."""
    total, count = 0.0, 0
    for residual, _, sample_rate, *_ in segments:
        step = max(1, int(round(sample_rate / rate_hz)))
        r = np.asarray(residual, dtype=float)
        n = r.size // step
        if n == 0 or step == 1:
            continue
        blocks = r[:n * step].reshape(n, step)
        total += float(np.sum((blocks - blocks.mean(axis=1, keepdims=True)) ** 2))
        count += n * step
    return total / count if count else 0.0


def heldout_deviance_gain(pairs, rate_hz=STRUCTURE_RATE_HZ):
    """Return (deviance gain, samples) of a candidate over a base on held-out data.

    ``pairs``: one list per channel of (base residual, candidate residual, sample
    rate in Hz[, start[, group]]), one per record or held-out run (channel
    units). The noise model is the verdict's (:func:`structure_test`): per
    record its nuisance terms (a drift from the record's zero when a 4th element
    gives the start in s, shared by the runs of one group, else an offset and a
    linear drift) are noise and removed, the rest is
    block-averaged to about ``rate_hz`` and
    AR(p) (p by BIC, memory capped at MAX_NOISE_TAU_S) fitted to the
    candidate's residual; both residuals are prewhitened with it. An unlogged
    input wander (a record whose power is the command, input_wander.py) is in
    both residuals alike: it is left to this stationary model (the gain is a
    comparison on the same data; the wander's likelihood fit would cost a
    second per candidate). Then

        D = sum_channels n_c ln(S_base,c / S_cand,c)

    with S the sums of squared prewhitened residuals and n_c their count: twice
    the log-likelihood gain under Gaussian innovations (each channel its own
    innovation variance). Returns (-inf, n) when a residual is missing or not
    finite.
    """
    total, count = 0.0, 0
    for channel in pairs:
        base, cand, items = [], [], []
        block_rate = rate_hz
        for r0, r1, sample_rate, *rest in channel:
            if r0 is None or r1 is None:
                return -math.inf, count
            start, group = (list(rest) + [None] * 2)[:2]
            step = max(1, int(round(sample_rate / rate_hz)))
            block_rate = sample_rate / step
            base.append(block_means(r0, step))
            cand.append(block_means(r1, step))
            items.append((base[-1].size, block_rate, start, group))
        base = remove_nuisance_jointly(base, items)
        cand = remove_nuisance_jointly(cand, items)
        joined = np.concatenate(cand) if cand else np.zeros(0)
        if joined.size < 12 or not np.all(np.isfinite(joined)):
            return (-math.inf if joined.size and not np.all(np.isfinite(joined)) else 0.0,
                    count)
        noise = _ArWhitener(math.exp(-1.0 / (block_rate * MAX_NOISE_TAU_S)))
        noise.fit(joined)
        s0 = float(np.sum(noise.apply(base) ** 2))
        s1 = float(np.sum(noise.apply(cand) ** 2))
        n = sum(max(e.size - noise.order, 0) for e in cand)
        if not (s0 > 0.0 and s1 > 0.0 and math.isfinite(s0)):
            return -math.inf, count
        total += n * math.log(s0 / s1)
        count += n
    return total, count
