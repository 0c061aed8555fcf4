"""The fitting engine shared by calibration and diagnosis.

Bounded nonlinear least squares over several records with priors, standard
errors and an identifiability check (docs/calibration.md):

* Each parameter has a prior (value and spread, in log units for positive
  scale parameters) and hard physical bounds. The fit minimises

      sum_records sum_channels |(y - y_hat) / (w_r sigma_c)|^2 * n_eff / n
      + sum_params ((z - z_prior) / s_prior)^2

  (a maximum a-posteriori estimate), z the parameter in fit coordinates. The
  prior keeps a parameter the records cannot determine at its prior value
  instead of letting it wander to fit noise.
* sigma_c, the residual scale of each channel, is estimated from the data (the
  fit is repeated once with the scales of the first pass), so metres, kelvin and
  ohms share one cost. Real residuals are not white: the data rows are
  down-weighted by n_eff / n from their lag-one autocorrelation, which inflates
  the covariance accordingly.
* Standard errors come from the Gauss-Newton covariance of the stacked
  residual. A parameter whose posterior spread is more than IDENTIFIABLE_RATIO
  (1/sqrt(2)) of its prior spread, i.e. about which the records say less than its
  prior does, is reported "not determined by the records"; its value stays the
  MAP estimate, which the prior holds near the prior value. (Until 2026-12-02 the
  least determined parameter was reset to its prior and the rest refitted, one at
  a time. That threshold decision made the result jump with data changes of
  0.5 um on a real record: docs/calibration.md, "Identifiability".)

``Objective`` is what a use of the engine supplies: the records, the channels
and a ``predict(values, record)`` function.
"""
from dataclasses import dataclass, field
import math

import numpy as np
from scipy.optimize import least_squares

from tca_ros.calibration.residuals import effective_samples, lag_one_autocorrelation

# posterior / prior spread above which a parameter is undetermined: 1/sqrt(2) is where the
# records carry less information on it than its prior (data precision < prior precision)
IDENTIFIABLE_RATIO = 1.0 / math.sqrt(2.0)
FAILED_RESIDUAL = 1e3  # residual per sample (in sigma) when a prediction fails
DIFF_STEP = 1e-3  # relative finite-difference step in fit coordinates
REWEIGHT_PASSES = 2  # fits with re-estimated channel scales
#: channels a record reads from zero at its start (an encoder zeroed, a load cell tared)
RELATIVE_CHANNELS = ('displacement', 'force')


@dataclass(frozen=True)
class Parameter:
    """One fitted quantity: prior, physical bounds and fit coordinates.

    ``log``: fit ln(value) (positive scale parameters); ``spread`` is then the
    prior standard deviation of ln(value), else of the value itself (unit).
    """

    name: str
    unit: str
    prior: float
    low: float
    high: float
    spread: float
    log: bool = True
    description: str = ''

    def to_fit(self, value):
        """Return ``value`` (unit) in fit coordinates."""
        return math.log(value) if self.log else float(value)

    def from_fit(self, z):
        """Return the value (unit) at fit coordinate ``z``."""
        return math.exp(z) if self.log else float(z)

    def fit_bounds(self):
        """Return (low, high) in fit coordinates."""
        return self.to_fit(self.low), self.to_fit(self.high)


@dataclass
class Estimate:
    """A fitted (or prior-held) parameter value with its standard error (unit)."""

    name: str
    unit: str
    value: float
    stderr: float
    prior: float
    determined: bool
    note: str = ''

    def as_dict(self):
        """Return a JSON-ready dict."""
        return {'value': self.value, 'stderr': self.stderr, 'unit': self.unit,
                'prior': self.prior, 'determined': self.determined, 'note': self.note}


@dataclass
class FitReport:
    """Result of ``fit`` (scipy-style: check ``success`` and ``message``)."""

    estimates: dict  # name -> Estimate
    values: dict  # name -> value (unit), fitted and fixed
    success: bool
    message: str
    nfev: int
    channel_scale: dict  # channel -> residual RMS (channel unit)
    record_rmse: list  # per record: {channel: RMSE}
    n_samples: int
    n_effective: float
    correlation: np.ndarray = field(default=None, repr=False)
    record_samples: list = field(default_factory=list)  # per record: samples fitted
    weights: list = field(default_factory=list)  # per record: relative residual scale
    prior_cost: float = 0.0  # sum of ((z - z_prior) / spread)^2 at the values (-)

    def data_cost(self, reference=None):
        """Return the data part of the objective at the values, on ``reference``'s scales (-).

        sum_records sum_channels n_r (RMSE / (w_r sigma_c))^2 n_eff / n with the channel
        scales sigma_c and n_eff / n of ``reference`` (a FitReport of the same records
        and masks; default this one), so two fits compare on one scale.
        """
        ref = reference or self
        factor = ref.n_effective / ref.n_samples if ref.n_samples else 0.0
        return factor * sum(n * (rmse[c] / (w * ref.channel_scale[c])) ** 2
                            for rmse, n, w in zip(self.record_rmse, self.record_samples,
                                                  self.weights) for c in rmse)


class Objective:
    """Records and a prediction function: what the engine fits.

    Parameters
    ----------
    records : list of Record
    channels : list of str
        Record attributes compared with the prediction ('displacement', ...).
    predict : callable
        ``predict(values, records)`` -> list (one per record) of {channel: array},
        or raises ValueError / ArithmeticError when the values cannot be simulated.
    weights : list of float, optional
        Relative residual scale of each record (default 1).
    mask : callable, optional
        ``mask(record)`` -> boolean array of samples used (default all).
    drift : bool, optional
        Take the residual of each channel read from the record's zero
        (RELATIVE_CHANNELS) less its least-squares linear drift from that zero
        (:func:`without_drift`): a sensor's drift is a nuisance of the fit, as it is
        of the diagnosis's verdict (default False). A temperature or a resistance is
        read absolute, not from a zero, and keeps its residual.
    """

    def __init__(self, records, channels, predict, weights=None, mask=None, drift=False):
        self.records = list(records)
        self.channels = list(channels)
        self.predict = predict
        self.weights = list(weights) if weights is not None else [1.0] * len(self.records)
        self.masks = [np.ones(r.time.size, bool) if mask is None else mask(r)
                      for r in self.records]
        self.drift = bool(drift)
        self.nfev = 0

    def raw_residuals(self, values):
        """Return per record {channel: measured - predicted} (channel unit), or None."""
        self.nfev += 1
        try:
            predictions = self.predict(values, self.records)
        except (ValueError, ArithmeticError):
            return None
        out = []
        for record, pred, sel in zip(self.records, predictions, self.masks):
            res = {c: (getattr(record, c) - pred[c])[sel] for c in self.channels}
            if not all(np.all(np.isfinite(v)) for v in res.values()):
                return None
            if self.drift:
                since_zero = (record.time - record.time[0])[sel]
                res = {c: without_drift(v, since_zero) if c in RELATIVE_CHANNELS else v
                       for c, v in res.items()}
            out.append(res)
        return out

    def size(self):
        """Return the number of data residuals."""
        return sum(int(m.sum()) for m in self.masks) * len(self.channels)


def without_drift(residual, since_zero):
    """Return ``residual`` less b (t - t_0), b its least-squares drift rate (unit/s).

    ``since_zero``: the samples' times from the record's zero (s). A record reads
    zero at its start (an encoder is zeroed, a CSV made relative), so a sensor's
    drift is a line through that zero: one rate, projected out in closed form at
    every evaluation (variable projection), as the verdict's nuisance term
    (diagnosis/regressors.nuisance_columns) takes it out of a residual.
    """
    norm = float(since_zero @ since_zero)
    if norm <= 0.0:
        return residual
    return residual - (float(residual @ since_zero) / norm) * since_zero


def _stack(raw, objective, scale, factor):
    parts = [raw_r[c] / (w * scale[c]) for raw_r, w in zip(raw, objective.weights)
             for c in objective.channels]
    return np.concatenate(parts) * factor


def _channel_scale(raw, objective, floor):
    out = {}
    for c in objective.channels:
        sq = [np.mean((r[c] / w) ** 2) for r, w in zip(raw, objective.weights)]
        out[c] = max(math.sqrt(float(np.mean(sq))), floor.get(c, 0.0))
    return out


def _autocorrelation_factor(raw, objective):
    """Return (sqrt(n_eff / n), n_eff) from the mean lag-one autocorrelation."""
    rhos = [lag_one_autocorrelation(r[c]) for r in raw for c in objective.channels
            if r[c].size > 2]
    rho = float(np.clip(np.mean(rhos), 0.0, 0.99)) if rhos else 0.0
    n = objective.size()
    n_eff = effective_samples(n, rho)
    return math.sqrt(n_eff / n), n_eff


def fit(objective, parameters, fixed=None, initial_scale=None, scale_floor=None,
        max_nfev=60, progress=None, start=None):
    """Fit ``parameters`` (list of Parameter) to ``objective``; return a FitReport.

    ``fixed``: {name: value} held constant (not fitted, passed to predict).
    ``initial_scale``: {channel: residual scale} of the first pass.
    ``scale_floor``: {channel: smallest residual scale} (sensor resolution).
    ``start``: {name: value} to start from (default the priors).
    """
    fixed = dict(fixed or {})
    scale_floor = dict(scale_floor or {})
    free = list(parameters)
    scale = dict(initial_scale or {c: 1.0 for c in objective.channels})
    factor, n_eff = 1.0, float(objective.size())
    start = start or {}
    z = np.array([p.to_fit(start.get(p.name, p.prior)) for p in free])
    sol, raw = None, None
    for _ in range(REWEIGHT_PASSES):
        sol = _solve(objective, free, fixed, z, scale, factor, max_nfev, progress)
        z = sol.x
        raw = objective.raw_residuals(_values(free, z, fixed))
        if raw is None:
            break
        scale = _channel_scale(raw, objective, scale_floor)
        factor, n_eff = _autocorrelation_factor(raw, objective)
    values = _values(free, z, fixed)
    # scipy's trf returns a bound-scaled Jacobian: take a plain one for the covariance,
    # at the final values with the final scales
    cov = _covariance(_jacobian(_residual_function(objective, free, fixed, scale, factor,
                                                   progress), z, free)) if free else \
        np.zeros((0, 0))
    ratios = {p.name: math.sqrt(max(cov[i, i], 0.0)) / p.spread for i, p in enumerate(free)}
    undetermined = {k: r for k, r in ratios.items() if not r <= IDENTIFIABLE_RATIO}
    estimates = {}
    for i, p in enumerate(free):
        sd = math.sqrt(max(cov[i, i], 0.0))
        value = values[p.name]
        stderr = value * sd if p.log else sd
        if p.name in undetermined:
            estimates[p.name] = Estimate(
                p.name, p.unit, value, stderr, p.prior, False,
                f'not determined by the records (posterior/prior spread '
                f'{undetermined[p.name]:.2f}): the value is mostly its prior')
        else:
            estimates[p.name] = Estimate(p.name, p.unit, value, stderr, p.prior, True)
    record_rmse = ([{c: float(np.sqrt(np.mean(r[c] ** 2))) for c in objective.channels}
                    for r in raw] if raw is not None else [])
    sd = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    corr = cov / np.outer(sd, sd)
    prior_cost = float(sum(((p.to_fit(values[p.name]) - p.to_fit(p.prior)) / p.spread) ** 2
                           for p in free))
    return FitReport(estimates=estimates, values=values,
                     success=bool(sol is not None and sol.status > 0 and raw is not None),
                     message=sol.message if sol is not None else 'nothing to fit',
                     nfev=objective.nfev, channel_scale=scale, record_rmse=record_rmse,
                     n_samples=objective.size(), n_effective=n_eff, correlation=corr,
                     record_samples=[int(m.sum()) for m in objective.masks],
                     weights=list(objective.weights), prior_cost=prior_cost)


def _jacobian(fun, z, parameters):
    """Return the forward-difference Jacobian of ``fun`` at ``z`` (steps inside the bounds).

    A step whose simulation fails is taken the other way; a column that fails
    both ways is NaN (its parameter's standard error is then unknown, not zero).
    """
    f0 = fun(z)
    jac = np.empty((f0.size, z.size))
    for i, p in enumerate(parameters):
        h = DIFF_STEP * max(1.0, abs(z[i]))
        low, high = p.fit_bounds()
        column = None
        for step in ((h, -h) if z[i] + h <= high else (-h, h)):
            if not low <= z[i] + step <= high:
                continue
            zi = z.copy()
            zi[i] += step
            fi = fun(zi)
            if not np.any(fi == FAILED_RESIDUAL):
                column = (fi - f0) / step
                break
        jac[:, i] = np.nan if column is None else column
    return jac


def _values(free, z, fixed):
    values = dict(fixed)
    values.update({p.name: p.from_fit(zi) for p, zi in zip(free, z)})
    return values


def _residual_function(objective, free, fixed, scale, factor, progress):
    """Return fun(z): the stacked data (noise units) and prior residuals."""
    prior_z = np.array([p.to_fit(p.prior) for p in free])
    spread = np.array([p.spread for p in free])
    n_data = objective.size()

    def fun(z):
        if progress is not None:
            progress.tick()
        raw = objective.raw_residuals(_values(free, z, fixed))
        data = (np.full(n_data, FAILED_RESIDUAL) if raw is None
                else _stack(raw, objective, scale, factor))
        return np.concatenate((data, (z - prior_z) / spread))
    return fun


def _solve(objective, free, fixed, z0, scale, factor, max_nfev, progress):
    fun = _residual_function(objective, free, fixed, scale, factor, progress)
    low, high = zip(*(p.fit_bounds() for p in free))
    z0 = np.clip(z0, np.array(low) + 1e-12, np.array(high) - 1e-12)
    return least_squares(fun, z0, bounds=(np.array(low), np.array(high)), method='trf',
                         diff_step=DIFF_STEP, x_scale='jac', max_nfev=max_nfev,
                         xtol=1e-6, ftol=1e-8)


def _covariance(jac):
    """Return (J^T J)^-1 of the stacked (data + prior) residual; the prior keeps it regular.

    Rows and columns of parameters whose Jacobian column is unknown (NaN) are NaN.
    """
    known = np.all(np.isfinite(jac), axis=0)
    if not np.all(known):
        cov = np.full((jac.shape[1], jac.shape[1]), np.nan)
        if np.any(known):
            cov[np.ix_(known, known)] = _covariance(jac[:, known])
        return cov
    jtj = jac.T @ jac
    try:
        return np.linalg.inv(jtj)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(jtj)
