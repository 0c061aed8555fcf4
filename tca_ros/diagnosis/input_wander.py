"""A noise model for a record whose power column is the command, not the power delivered.

A supply that is commanded but not measured delivers P (1 + w(t)), with w a
slow relative wander of a few per cent (regulation, contact resistance, the
heater's resistance with temperature). The thermal lag passes it on: the
response moves by about its own level times w. So the residual of a correct
model is

    e(t) = s(t) w(t) + v(t)

with s(t) the response's sensitivity to the delivered power (d y / d ln P)
and v(t) the sensor's noise. The wander reaches the channel through the
muscle's lags (the thermal time constant, then a second thermal lag and a
sensor lag for the stroke, after the drive's dead time: WanderPath), so w(t) is
the wander of the heat the lags still hold, weighted by the power that carried
it; with the lags left out, a cooling muscle would move with a wander of a
supply that is off (G63). That residual follows the
inputs (it is zero when the muscle is cold and grows with the stroke), so a
test that takes the noise as stationary calls it model error. Here both
parts are Gaussian processes in time: w an Ornstein-Uhlenbeck process
(relative std sigma_w, correlation time tau_w), v an exponentially
correlated one (std sigma_v, correlation time tau_v up to the stationary
model's memory cap). The four are estimated by maximum likelihood on the
residual; generalised least squares then whitens by the Cholesky factor of
the covariance (one block per record: its held-out runs share w and v), which
is what the AR prewhitening of noise.py does for a stationary noise.

Only records whose header says ``power_logged: command`` get this model: on a
measured power there is no unlogged input, and the wander would absorb part of
a real effect (a static nonlinearity looks like a wander that follows the
power level).
"""
from dataclasses import dataclass
import math

import numpy as np
from scipy import linalg, optimize, signal

# relative std of the delivered power's wander (-): a bench supply holds its power
# within a few per cent; more, and the wander would take up a real effect's residual
WANDER_SHARE_RANGE = (1e-4, 0.05)
WANDER_TAU_RANGE_S = (2.0, 120.0)  # s, its correlation time
SENSOR_TAU_MIN_S = 0.05  # s, shortest correlation time of the sensor noise
#: s, the wander is resolved in windows this long: its shortest correlation time
WANDER_WINDOW_S = WANDER_TAU_RANGE_S[0]
JITTER = 1e-9  # relative diagonal loading of the covariance (numerical)


@dataclass
class WanderNoise:
    """Sensor noise plus an unlogged relative wander of the input (channel units, s)."""

    sigma_v: float  # std of the sensor noise of the block means (channel units)
    tau_v: float  # s, its correlation time
    sigma_w: float  # relative std of the delivered power's wander (-)
    tau_w: float  # s, its correlation time

    def covariance(self, group):
        """Return the covariance (channel units^2) of a WanderGroup's block means."""
        cov = self.sigma_v ** 2 * group.decay(self.tau_v) + self.wander_covariance(group)
        cov[np.diag_indices_from(cov)] *= 1.0 + JITTER
        return cov

    def wander_covariance(self, group):
        """Return the wander's part of a WanderGroup's covariance (channel units^2).

        G K G^T with G the group's response to the wander in each window
        (WanderPath) and K the wander's covariance between windows; without a
        path, the wander at each block itself: s_i s_j K(t_i, t_j).
        """
        if group.response is None:
            return group.outer * (self.sigma_w ** 2 * group.decay(self.tau_w))
        g = group.response
        return self.sigma_w ** 2 * (g @ np.exp(-group.window_lag / self.tau_w) @ g.T)


@dataclass(frozen=True, eq=False)
class WanderPath:
    """How a wander of the delivered power reaches one channel of one record.

    ``power`` (W): the record's commanded power at its samples, ``sample_rate``
    (Hz) their rate; ``lags`` (s): the first-order lags in series from the heat
    input to the channel (the thermal time constant, eq. 8; for the stroke also
    a second thermal lag and a sensor lag); ``dead_time`` (s): the drive's delay.
    """

    power: np.ndarray
    sample_rate: float
    lags: tuple
    dead_time: float = 0.0

    def response(self, times, block_rate):
        """Return (R, window centres in s) of the channel at block centres ``times``.

        R[i, m] (-): the share of the heat the lags hold at ``times[i]`` (s since
        the record's zero) that entered during wander window m (WANDER_WINDOW_S
        long): the power there, delayed by the dead time and passed through each
        lag, over the same of the whole power. Rows sum to one where the thread
        holds heat (a constant wander w moves the channel by its sensitivity
        times w) and are zero where it holds none. ``block_rate`` (Hz): the rate
        of the blocks the times belong to.
        """
        step = max(1, int(round(self.sample_rate / block_rate)))
        dt = step / self.sample_rate
        n = self.power.size // step
        p = np.asarray(self.power[:n * step], dtype=float).reshape(n, step).mean(axis=1)
        shift = min(int(round(self.dead_time / dt)), n)
        source = np.arange(n - shift)  # the block whose power heats block k + shift
        window = (source * dt // WANDER_WINDOW_S).astype(int)
        heat = np.zeros((n, int(window.max()) + 1 if window.size else 1))
        heat[source + shift, window] = p[source]
        for tau in self.lags:
            if tau > 0.0:
                a = math.exp(-dt / tau)
                heat = signal.lfilter([1.0 - a], [1.0, -a], heat, axis=0)
        total = heat.sum(axis=1)
        held = total > 1e-9 * max(float(np.max(np.abs(total))), 1e-300)
        heat[held] /= total[held, None]
        heat[~held] = 0.0
        rows = heat[np.clip((np.asarray(times) / dt).astype(int), 0, n - 1)]
        return rows, (np.arange(heat.shape[1]) + 0.5) * WANDER_WINDOW_S


class WanderGroup:
    """The block means of one record's segments: where they are and how loud.

    ``times`` (s): block centres since the record's zero; ``scale``: the response's
    sensitivity to the power at the blocks (channel units); ``index``: their
    positions in the stacked vector of every segment's block means; ``response``:
    (R, window centres) of WanderPath.response at the blocks, or None (the
    wander at each block acts unlagged).
    """

    def __init__(self, times, scale, index, response=None):  # noqa: D107 -- on the class
        self.times, self.scale, self.index = times, scale, index
        self.outer = np.outer(scale, scale) if response is None else None
        self.response, self.window_lag = None, None
        if response is not None:  # (R, window centres): the lagged wander (WanderPath)
            rows, centres = response
            g = scale[:, None] * rows
            used = np.any(g != 0.0, axis=0)  # windows before the group's end that heat it
            self.response = g[:, used]
            self.window_lag = np.abs(centres[used][:, None] - centres[used][None, :])
        # the lags on a grid of the shortest block interval: exp(-lag / tau) is then
        # a power of one number per lag, looked up rather than computed per entry
        lag = np.abs(times[:, None] - times[None, :])
        step = float(np.min(np.diff(np.sort(times)))) if times.size > 1 else 1.0
        steps = lag / step if step > 0.0 else lag
        on_grid = step > 0.0 and float(np.max(np.abs(steps - np.rint(steps)))) < 1e-6
        self._lag, self._step = (np.rint(steps).astype(int), step) if on_grid else (lag, None)

    def decay(self, tau):
        """Return exp(-|t_i - t_j| / tau) (-) for the blocks' times, tau in s."""
        if self._step is None:
            return np.exp(-self._lag / tau)
        return np.exp(-np.arange(self._lag.max() + 1) * (self._step / tau))[self._lag]


def groups_of(items, scales, paths=None):
    """Return [WanderGroup] of stacked segments.

    ``items``: (size, block rate in Hz, start in s or None, group or None) per
    segment, as regressors.nuisance_design; ``scales``: the block means of the
    response's sensitivity per segment; ``paths``: a WanderPath per segment (or
    None: the wander unlagged). Segments of one group are one record's runs.
    """
    paths = paths or [None] * len(items)
    out, at = {}, 0
    for i, ((size, rate, start, group), scale, path) in enumerate(zip(items, scales, paths)):
        key = ('own', i) if group is None else ('group', group)
        t0 = 0.0 if start is None else float(start)
        t = t0 + (np.arange(size) + 0.5) / rate
        entry = out.setdefault(key, ([], [], [], path, rate))
        entry[0].append(t)
        entry[1].append(np.asarray(scale, dtype=float)[:size])
        entry[2].append(np.arange(at, at + size))
        at += size
    groups = []
    for t, s, ix, path, rate in out.values():
        t = np.concatenate(t)
        groups.append(WanderGroup(t, np.concatenate(s), np.concatenate(ix),
                                  None if path is None else path.response(t, rate)))
    return groups


def fit_wander_noise(resid, groups, max_sensor_tau, start=None, supply=None):
    """Return the maximum-likelihood WanderNoise of the stacked residual ``resid``.

    ``groups`` from :func:`groups_of`; ``max_sensor_tau`` (s) caps the sensor
    noise's memory (a longer one would call slow model error noise); ``start``
    a WanderNoise to start from (default: half the residual's variance each to the
    sensor and to a 1 %, 10 s wander); ``supply``: (sigma_w, tau_w s) of the
    wander held fixed (another channel's estimate of the same supply), only the
    sensor noise fitted.
    Bounded (L-BFGS-B on logarithms; the wander within WANDER_SHARE_RANGE).
    """
    resid = np.asarray(resid, dtype=float)
    rms = math.sqrt(max(float(np.mean(resid ** 2)) if resid.size else 0.0, 1e-300))
    start = start or WanderNoise(rms / math.sqrt(2.0), 1.0, 0.01, 10.0)
    bounds = [(math.log(rms * 1e-3), math.log(rms * 10.0)),
              (math.log(SENSOR_TAU_MIN_S), math.log(max(max_sensor_tau, SENSOR_TAU_MIN_S))),
              tuple(math.log(v) for v in WANDER_SHARE_RANGE),
              tuple(math.log(v) for v in WANDER_TAU_RANGE_S)]
    x0 = [min(max(math.log(v), lo), hi) for v, (lo, hi) in zip(
        (start.sigma_v, start.tau_v, start.sigma_w, start.tau_w), bounds)]
    fixed = () if supply is None else tuple(math.log(v) for v in supply)
    if fixed:
        x0, bounds = x0[:2], bounds[:2]

    def cost(x):
        noise = WanderNoise(*np.exp(np.concatenate([x, fixed])))
        logdet, quad = _logdet_and_quadratic(noise, groups, resid)
        return 0.5 * (logdet + quad)

    best = optimize.minimize(cost, x0, method='L-BFGS-B', bounds=bounds,
                             options={'maxiter': 40, 'ftol': 1e-7})
    x = best.x if np.isfinite(best.fun) else np.array(x0)
    sigma_v, tau_v, *wander = (float(v) for v in np.exp(np.concatenate([x, fixed])))
    return WanderNoise(sigma_v, tau_v, *(supply or wander))


def chance_projection(noise, groups, full, nuisance):
    """Return the wander's expected mean square in the input terms' span (channel units^2).

    trace((P_full - P_nuisance) C_w) / n: C_w the covariance of the wander's part
    of the stacked block means under ``noise`` (the sensor's left out), P the
    orthogonal projectors on the columns of ``full`` (nuisance and input terms,
    unwhitened) and of ``nuisance``. What an unweighted least-squares fit of the
    input terms takes up of the wander by chance: its mean level over a short
    held-out part times the response, most of all. C_w is one block per group.
    """
    wander = [(g.index, noise.wander_covariance(g)) for g in groups]
    taken = _projected_trace(wander, full) - _projected_trace(wander, nuisance)
    return max(taken, 0.0) / full.shape[0]


def _projected_trace(blocks, columns):
    """Return trace(P C) of the projector P on the span of ``columns``, C of ``blocks``.

    ``blocks``: (row indices, covariance) of C's diagonal blocks.
    """
    if columns.shape[1] == 0:
        return 0.0
    q, r, _ = linalg.qr(columns, mode='economic', pivoting=True)
    d = np.abs(np.diag(r))
    q = q[:, :int(np.sum(d > 1e-10 * d[0]))] if d.size and d[0] > 0.0 else q[:, :0]
    return float(sum(np.sum(q[index] * (cov @ q[index])) for index, cov in blocks))


def _logdet_and_quadratic(noise, groups, resid):
    """Return (log det C, r^T C^-1 r) of the residual under ``noise`` (inf if singular)."""
    try:
        factors = cholesky_factors(noise, groups)
    except linalg.LinAlgError:
        return math.inf, math.inf
    z = whiten(factors, groups, resid)
    logdet = sum(2.0 * float(np.sum(np.log(np.diag(chol)))) for chol in factors)
    return logdet, float(z @ z)


def cholesky_factors(noise, groups):
    """Return the lower Cholesky factor L of each group's covariance under ``noise``."""
    return [linalg.cholesky(noise.covariance(g), lower=True) for g in groups]


def whiten(factors, groups, columns):
    """Return ``columns`` (stacked vector or matrix) whitened by the groups' ``factors``.

    Per group the rows are L^-1 rows (:func:`cholesky_factors`); the groups are
    stacked in the order of ``groups``.
    """
    return np.concatenate([linalg.solve_triangular(chol, columns[g.index], lower=True)
                           for chol, g in zip(factors, groups)], axis=0)
