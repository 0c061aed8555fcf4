"""Results of the candidate fits (fitting.py): a fit, its score, its uncertainties.

``FitResult`` holds one bounded fit of a candidate's parameters, ``CandidateScore``
that fit scored on the held-out part of the record, and ``standard_errors`` the
parameter uncertainties from the Gauss-Newton covariance of the fit.
"""
from dataclasses import dataclass, field
import math

import numpy as np


@dataclass
class FitResult:
    """Result of fitting one candidate's parameters (STYLE.md section 6).

    ``params``, ``units`` and ``stderr`` are keyed by dotted parameter name, in
    schema units; ``residual_rms`` is the training residual RMS in noise units
    (1 = the sensor noise); ``n_samples`` counts training residuals.
    """

    name: str
    params: dict
    units: dict
    stderr: dict
    residual_rms: float
    n_samples: int
    success: bool
    message: str


@dataclass
class CandidateScore:
    """A fitted candidate scored on the held-out part of the record."""

    fit: FitResult
    heldout_cost: float  # sum of squared noise-normalised residuals
    heldout_score: float  # RMS of the noise-normalised residuals (-)
    heldout_rmse: dict  # channel -> RMSE (m or K)
    n_heldout: int
    lag_one: float  # autocorrelation of the held-out residuals (coarse grid)
    refined: bool
    criterion: float = -math.inf  # penalised log-likelihood gain over the base
    significant: bool = False
    values: dict = field(default_factory=dict)  # base + this candidate's parameters

    @property
    def name(self):
        """Return the candidate's effect name."""
        return self.fit.name


def standard_errors(spaces, z, residual, jac):
    """Return {name: stderr} (schema units) from the Gauss-Newton covariance.

    cov(z) = s^2 (J^T J)^-1 with s^2 = SSE / (n - p); mapped to parameter units by
    the derivative of each space's scaling. Residual autocorrelation makes these
    optimistic; NaN when the Jacobian is singular or unavailable.
    """
    out = {s.name: math.nan for s in spaces}
    if jac is None:
        return out
    n, p = jac.shape
    if n <= p:
        return out
    s2 = float(residual @ residual) / (n - p)
    try:
        cov = np.linalg.inv(jac.T @ jac) * s2
    except np.linalg.LinAlgError:
        return out
    for i, s in enumerate(spaces):
        h = 1e-6
        slope = (s.from_unit(z[i] + h) - s.from_unit(z[i] - h)) / (2.0 * h)
        var = cov[i, i]
        out[s.name] = abs(slope) * math.sqrt(var) if var >= 0.0 else math.nan
    return out
