"""The bounded least-squares fit of one candidate extension, and its held-out score.

A problem (a FitProblem of fitting.py, or a FitProblemSet of problem_set.py over
several records) gives the normalised training residuals (-) of a set of parameter
values and their held-out cost; here a candidate (calibration/candidates.py: its
ParameterSpaces and starting magnitudes) is

1. screened: the training cost at each start, on the base and on each recalibrated
   base start (``screen``);
2. fitted: bounded nonlinear least squares in the unit-scaled parameters (scipy
   trust-region reflective, finite differences of DIFF_STEP, at most MAX_NFEV
   evaluations), optionally with further spaces refitted jointly (``fit_candidate``);
3. scored on the held-out part (``score_fit``).

The search that chooses among the candidates is search.py; the result types and the
standard errors are in fit_result.py.
"""
import math

import numpy as np
from scipy.optimize import least_squares

from tca_ros.diagnosis.fit_result import CandidateScore, FitResult, standard_errors
from tca_ros.diagnosis.fitting import FAILED_RESIDUAL
from tca_ros.diagnosis.grid_simulation import STOP
from tca_ros.model.params_schema import SPECS

MAX_NFEV = 8  # least-squares iterations (function evaluations, Jacobian excluded)
DIFF_STEP = 2e-3  # finite-difference step in the unit-scaled parameters


def screen(problem, candidate, base_starts=()):
    """Return [(train cost, start values, cost per channel, base start)], best first.

    Each start of ``candidate`` is tried on the problem's base and on the base with
    each dict of ``base_starts`` ({dotted name: value in schema units} of recalibrated
    parameters) applied; the plain base's base start is {}. Costs are sums of squared
    normalised training residuals (-); the per-channel costs follow
    ``problem.channels``.
    """
    out = []
    for start in candidate.starts:
        for base_start in ({},) + tuple(base_starts):
            values = {**problem.base_values, **base_start}
            values.update({s.name: v for s, v in zip(candidate.spaces, start)})
            problem.progress.label = f'screen {candidate.name}'
            r = problem.train_residuals(values)
            per_channel = tuple(float(part @ part)
                                for part in r.reshape(len(problem.channels), -1))
            out.append((float(r @ r), start, per_channel, base_start))
    return sorted(out, key=lambda item: item[0])


def fit_candidate(problem, candidate, start, refine=True, free=(), max_nfev=MAX_NFEV,
                  base_start=None):
    """Fit ``candidate`` from ``start`` (values per space, schema units); return a FitResult.

    ``free`` lists further ParameterSpaces (already in the base) refitted jointly,
    each started from ``base_start`` ({dotted name: value}) where that has it,
    else from the base. With ``refine`` False the start is only evaluated.
    """
    spaces = tuple(candidate.spaces) + tuple(free)
    x0 = [s.to_unit(v) for s, v in zip(candidate.spaces, start)]
    first = {**problem.base_values, **(base_start or {})}
    x0 += [s.to_unit(first[s.name]) for s in free]

    def values_at(z):
        values = dict(problem.base_values)
        values.update({s.name: s.from_unit(zi) for s, zi in zip(spaces, z)})
        return values

    def fun(z):
        problem.progress.label = f'fit {candidate.name}'
        return problem.train_residuals(values_at(z))

    problem.stop_moves = refine and any(s.name == STOP for s in spaces)
    try:
        if refine:
            sol = least_squares(fun, np.asarray(x0), bounds=(0.0, 1.0), method='trf',
                                diff_step=DIFF_STEP, max_nfev=max_nfev, xtol=1e-4,
                                ftol=1e-6, x_scale=1.0)
            z, residual, jac = sol.x, sol.fun, sol.jac
            success = bool(sol.success) or sol.status == 0
            message = sol.message if sol.status != 0 else 'iteration limit reached'
        else:
            z = np.asarray(x0)
            residual = fun(z)
            jac = None
            success, message = True, 'screened only (not refined)'
    finally:
        problem.stop_moves = False
    values = values_at(z)
    n = residual.size
    failed = bool(np.all(residual == FAILED_RESIDUAL))
    params = {s.name: values[s.name] for s in spaces}
    stderr = standard_errors(spaces, z, residual, jac)
    return FitResult(name=candidate.name, params=params,
                     units={s.name: SPECS[s.name].unit for s in spaces},
                     stderr=stderr, residual_rms=float(np.sqrt(np.mean(residual ** 2))),
                     n_samples=n, success=success and not failed,
                     message='simulation failed' if failed else message)


def score_fit(problem, fit, refined):
    """Return the CandidateScore of a FitResult on the problem's held-out part (-)."""
    values = dict(problem.base_values)
    values.update(fit.params)
    cost, rmse, n, rho = problem.heldout(values)
    return CandidateScore(fit=fit, heldout_cost=cost,
                          heldout_score=math.sqrt(cost / n), heldout_rmse=rmse,
                          n_heldout=n, lag_one=rho, refined=refined, values=values)
