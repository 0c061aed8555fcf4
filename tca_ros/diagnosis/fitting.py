"""Fit candidate extensions to a record and choose among them on held-out data.

Method (docs/diagnosis.md)
--------------------------
1. The record is split in time: the first ``train_fraction`` trains, the rest is
   held out. Both parts run in one simulation (the held-out part starts from the
   state the training part ends in).
2. Fits run on a coarse grid (``fit_rate`` Hz, inputs averaged over each coarse
   interval, which preserves the heat input). The discretisation error of the
   coarse grid is removed by defect correction: the difference between the
   current base model simulated at the record rate and on the coarse grid is added
   to every coarse simulation, so candidates are compared at record-rate accuracy.
3. Residuals are weighted by the sensor noise of each channel (estimated from
   the data, ``residuals.noise_sigma``), so displacement (m) and temperature (K)
   enter one dimensionless cost.
4. Each candidate is screened at a few starting magnitudes; the best few (and
   the best of each measured channel) are refined by bounded nonlinear least
   squares (scipy trust-region reflective).
5. The held-out cost decides. A candidate is added when its held-out gain is
   significant after a BIC penalty on an effective sample count that accounts
   for residual autocorrelation [3 in residuals.py]; the search repeats greedily
   with the added effects as the new base (refitting them jointly with each new
   candidate) until the held-out residual is within 5 % of the sensor noise;
   effects made redundant by later ones are then removed (backward elimination).
"""
import dataclasses
from dataclasses import dataclass, field
import math
import sys
import time as wallclock

import numpy as np
from scipy.optimize import least_squares

from tca_ros.diagnosis.noise import quantisation_sigma
from tca_ros.diagnosis.residuals import lag_one_autocorrelation, noise_sigma
from tca_ros.diagnosis.verdict import noise_model_gain
from tca_ros.model.dynamics import simulate
from tca_ros.model.params import SPECS
from tca_ros.model.quasistatic import QuasiStaticUnsupported, simulate_quasistatic

FAILED_RESIDUAL = 1e3  # noise units per sample returned when a simulation fails
DISPLACEMENT_NOISE_FLOOR = 1e-7  # m, noise floor for noise-free data
TEMPERATURE_NOISE_FLOOR = 1e-3  # K
TRAIN_FRACTION = 0.7  # leading share of the record used for fitting
FIT_RATE_HZ = 10.0  # coarse grid of the fits; defect correction restores accuracy
MIN_PHYSICS_RATE_HZ = 200.0  # record-rate simulations step at least this fast (Hz)
REFINE_TOP = 3  # candidates refined by least squares after screening
MAX_NFEV = 8  # least-squares iterations (function evaluations, Jacobian excluded)
POLISH_NFEV = 10  # iterations of the joint refit after an effect is added
PRUNE_NFEV = 4  # iterations of the brief refit when an effect is tentatively removed
DIFF_STEP = 2e-3  # finite-difference step in the unit-scaled parameters
MIN_GAIN_PERCENT = 1.0  # held-out RMS gain below this is not worth a parameter
MAX_EFFECTS = 3  # greedy additions
WHITE_SCORE = 1.05  # held-out RMS (noise sigmas) at which the search stops
STOP = 'coil.min_pitch_angle_deg'  # the coil-contact parameter (deg)
PROGRESS_INTERVAL = 0.25  # s between progress-bar redraws


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


class Progress:
    """A one-line progress bar on stderr, counting simulations."""

    def __init__(self, enabled, total, width=30, stream=None):
        self.enabled = enabled
        self.total = max(total, 1)
        self.width = width
        self.count = 0
        self.label = ''
        self.stream = stream or sys.stderr
        self.start = wallclock.perf_counter()
        self._drawn = -math.inf

    def tick(self, label=None):
        """Count one simulation and redraw."""
        self.count += 1
        if label is not None:
            self.label = label
        if not self.enabled:
            return
        now = wallclock.perf_counter()
        if now - self._drawn < PROGRESS_INTERVAL and self.count < self.total:
            return
        self._drawn = now
        filled = min(self.width, int(self.width * self.count / self.total))
        elapsed = wallclock.perf_counter() - self.start
        self.stream.write(f'\r[{"#" * filled}{"." * (self.width - filled)}] '
                          f'{self.count:4d} sims {elapsed:5.1f} s  {self.label:<28s}')
        self.stream.flush()

    def close(self):
        """End the bar's line."""
        if self.enabled:
            self.stream.write('\n')
            self.stream.flush()


def _block_mean(values, k, m):
    """Return the means of consecutive blocks of k samples (m blocks, last padded)."""
    n = values.size
    pad = m * k - n
    if pad > 0:
        values = np.concatenate([values, np.full(pad, values[-1])])
    return values[:m * k].reshape(m, k).mean(axis=1)


class FitProblem:
    """A record, a nominal parameter set and the machinery to score extensions.

    Parameters
    ----------
    record : Record
        Measured data (uniform grid).
    params : TcaParams
        Nominal parameters (mass and initial load already set from the record).
    model : str
        Kinetostatic model rod | cst | love.
    physics_rate : float, optional
        Physics rate (Hz) of record-rate simulations; at least the sample rate,
        default MIN_PHYSICS_RATE_HZ (about 2 um RMS from a 500 Hz truth, against
        5.6 um at 100 Hz: above the noise of a good displacement sensor).
    fit_rate : float
        Coarse-grid rate (Hz) of the fits.
    train_fraction : float
        Leading share of the record used for fitting.
    progress : Progress, optional
        Counts simulations.
    reduced : bool
        Simulate the fits' coarse grid with the quasi-static reduction where it
        applies (the defect correction removes its difference from the full
        dynamics at the base model); False: always the full dynamics (18).
    """

    def __init__(self, record, params, model='cst', physics_rate=None, fit_rate=FIT_RATE_HZ,
                 train_fraction=TRAIN_FRACTION, progress=None, reduced=True):
        self.record = record
        self.params = params
        self.model = model
        self.sample_rate = record.sample_rate
        self.physics_rate = max(physics_rate or MIN_PHYSICS_RATE_HZ, self.sample_rate)
        self.progress = progress or Progress(False, 1)
        self.k = max(1, int(round(self.sample_rate / fit_rate)))
        n = record.time.size
        self.m = (n - 1) // self.k + 1  # coarse samples at full indices 0, k, 2k, ...
        self.index = np.arange(self.m) * self.k
        self.coarse_time = record.time[self.index]
        # input on [t_j, t_j+1) of the coarse grid = mean of the fine ZOH samples in it
        self.coarse_power = _block_mean(record.power, self.k, self.m)
        self.coarse_load = _block_mean(record.load, self.k, self.m)
        self.coarse_load[0] = record.load[0]  # the initial equilibrium uses load[0]
        split_time = record.time[0] + train_fraction * record.duration
        self.split = int(np.searchsorted(self.coarse_time, split_time))  # coarse index
        self.full_split = int(np.searchsorted(record.time, split_time))
        self.channels = ['displacement']
        # white noise from second differences, at least the rounding of a quantised
        # sensor (an encoder's differences are mostly 0: their MAD would be 0)
        self.sigma = {'displacement': noise_sigma(record.displacement, max(
            DISPLACEMENT_NOISE_FLOOR, quantisation_sigma(record.displacement)))}
        if record.temperature is not None:
            self.channels.append('temperature')
            self.sigma['temperature'] = noise_sigma(record.temperature, max(
                TEMPERATURE_NOISE_FLOOR, quantisation_sigma(record.temperature)))
        self.measured = {c: getattr(record, c) for c in self.channels}
        self.coarse_measured = {c: self.measured[c][self.index] for c in self.channels}
        # (kind of coarse simulation, base stop) -> {channel: defect correction}
        self.correction = {}
        self._nominal_stop = math.degrees(params.coil.min_pitch_angle)
        self.stop_moves = False  # a fit moves the coil stop: all its values run full
        self.reduced = reduced
        # nominal parameters refitted with every refined candidate and every polish, so an
        # effect gets no credit for what a recalibration absorbs (set by diagnose)
        self.recalibration = ()
        self.base_values = {}
        self._cache = {}
        self._full_cache = {}

    # -- simulation -----------------------------------------------------------------
    def parameters(self, values):
        """Return the nominal params with dotted ``values`` applied."""
        return self.params.with_values(**values) if values else self.params

    def simulate_full(self, values):
        """Return the SimulationResult at the record's samples for ``values`` (cached)."""
        key = tuple(sorted(values.items()))
        if key not in self._full_cache:
            self.progress.tick()
            r = self.record
            self._full_cache[key] = simulate(self.parameters(values), r.time, r.power, r.load,
                                             model=self.model, physics_rate=self.physics_rate)
        return self._full_cache[key]

    def simulate_coarse(self, values, end=None):
        """Return {channel: prediction} on the coarse grid up to index ``end``.

        Defect-corrected: the base model's record-rate minus coarse-grid
        difference is added. Returns None when the simulation fails.
        """
        end = self.m if end is None else end
        # a coil stop that moves from the base's is a mass hitting a new stop: the
        # reduction's lag towards it differs from (18) by more than the defect correction
        # at the base holds, so such values (and every value of a fit that moves the
        # stop, so its finite differences compare like with like) run the full dynamics;
        # a stop held at the base's value is in the correction like any other effect
        stop = values.get(STOP, self._nominal_stop)
        moved = self.stop_moves or abs(stop - self._base_stop()) > 1e-9
        kind = 'full' if moved else None
        key = (tuple(sorted(values.items())), end, kind)
        if key in self._cache:
            return self._cache[key]
        self.progress.tick()
        try:
            kind, sim = self._coarse_simulation(self.parameters(values), end, kind)
            correction = self._correction(kind)
        except (ValueError, ArithmeticError):
            self._cache[key] = None
            return None
        out = {c: getattr(sim, c) + correction[c][:end] for c in self.channels}
        if not all(np.all(np.isfinite(v)) for v in out.values()):
            out = None
        self._cache[key] = out
        return out

    def _base_stop(self):
        """Return the coil stop (deg) of the base values."""
        return self.base_values.get(STOP, self._nominal_stop)

    def _coarse_simulation(self, params, end, kind=None):
        """Return (kind, SimulationResult) on the coarse grid up to index ``end``.

        kind 'reduced': the quasi-static reduction (model/quasistatic.py, about
        100x cheaper), used when ``self.reduced`` and the params need nothing it
        cannot represent; kind 'full': the dynamics (18) at the coarse rate.
        """
        args = (params, self.coarse_time[:end], self.coarse_power[:end],
                self.coarse_load[:end])
        if kind != 'full' and self.reduced:
            try:
                return 'reduced', simulate_quasistatic(*args, model=self.model)
            except QuasiStaticUnsupported:
                if kind == 'reduced':
                    raise
        return 'full', simulate(*args, model=self.model, physics_rate=self.sample_rate / self.k)

    def _correction(self, kind):
        """Return the defect correction {channel: array} of a coarse-grid ``kind``.

        The base model at the record rate minus the base on the coarse grid by
        the same kind of simulation, so a candidate simulated by either kind is
        corrected by its own kind's error (computed on first need per base and
        base stop: a brief refit that drops a coil stop from the base must not
        take the reduction's error with the stop binding).
        """
        key = (kind, self._base_stop())
        if key not in self.correction:
            _, coarse = self._coarse_simulation(self.parameters(self.base_values), self.m, kind)
            full = self.simulate_full(self.base_values)
            self.correction[key] = {c: getattr(full, c)[self.index] - getattr(coarse, c)
                                    for c in self.channels}
        return self.correction[key]

    def set_base(self, values):
        """Make ``values`` the base model: recompute the defect correction.

        Returns the record-rate SimulationResult of the base.
        """
        self.base_values = dict(values)
        full = self.simulate_full(values)
        self.correction = {}
        self._cache.clear()
        coarse = self.simulate_coarse(values)
        if coarse is not None and abs(self._base_stop() - self._nominal_stop) > 1e-9:
            # a base with a stop: its full-dynamics correction too, so fits that move the
            # stop (and the brief refits of prune_effects) are corrected at this base
            self.stop_moves = True
            try:
                coarse = self.simulate_coarse(values)
            finally:
                self.stop_moves = False
        if coarse is None:  # e.g. the coarse grid beyond the explicit stability limit
            raise ValueError(f'values {values}: the coarse fit grid cannot simulate them')
        return full

    # -- residuals ------------------------------------------------------------------
    def normalised_residuals(self, prediction, start, end):
        """Return the noise-normalised residuals (-) of all channels on [start, end)."""
        parts = [(self.coarse_measured[c][start:end] - prediction[c][start:end])
                 / self.sigma[c] for c in self.channels]
        return np.concatenate(parts)

    def train_residuals(self, values):
        """Return the training residual vector (-) for ``values``."""
        n = self.split * len(self.channels)
        prediction = self.simulate_coarse(values, self.split)
        if prediction is None:
            return np.full(n, FAILED_RESIDUAL)
        return self.normalised_residuals(prediction, 0, self.split)

    def heldout(self, values):
        """Return (cost, {channel: RMSE}, n, lag-1 autocorrelation) on the held-out part."""
        prediction = self.simulate_coarse(values)
        n = (self.m - self.split) * len(self.channels)
        if prediction is None:
            return FAILED_RESIDUAL ** 2 * n, {c: math.inf for c in self.channels}, n, 1.0
        rmse, rhos = {}, []
        for c in self.channels:
            res = self.coarse_measured[c][self.split:] - prediction[c][self.split:]
            rmse[c] = float(np.sqrt(np.mean(res ** 2)))
            rhos.append(lag_one_autocorrelation(res))
        r = self.normalised_residuals(prediction, self.split, self.m)
        return float(r @ r), rmse, n, float(np.mean(rhos))

    def heldout_residuals(self, values):
        """Return [{channel: measured - predicted}] on the coarse held-out part, or None.

        One dict per record (channel units); rates in ``coarse_rates``.
        """
        prediction = self.simulate_coarse(values)
        if prediction is None:
            return None
        return [{c: self.coarse_measured[c][self.split:] - prediction[c][self.split:]
                 for c in self.channels}]

    @property
    def coarse_rates(self):
        """Return [coarse-grid rate (Hz)] per record."""
        return [self.sample_rate / self.k]

    # -- fitting --------------------------------------------------------------------
    def screen(self, candidate):
        """Return [(train cost, start values, cost per channel)], best first.

        Costs are sums of squared noise-normalised training residuals (-); the
        per-channel costs follow ``self.channels``.
        """
        out = []
        for start in candidate.starts:
            values = dict(self.base_values)
            values.update({s.name: v for s, v in zip(candidate.spaces, start)})
            self.progress.label = f'screen {candidate.name}'
            r = self.train_residuals(values)
            per_channel = tuple(float(part @ part)
                                for part in r.reshape(len(self.channels), -1))
            out.append((float(r @ r), start, per_channel))
        return sorted(out, key=lambda item: item[0])

    def fit(self, candidate, start, refine=True, free=(), max_nfev=MAX_NFEV):
        """Fit ``candidate`` from ``start`` (values per space); return a FitResult.

        ``free`` lists further ParameterSpaces (already in the base) refitted jointly.
        """
        spaces = tuple(candidate.spaces) + tuple(free)
        x0 = [s.to_unit(v) for s, v in zip(candidate.spaces, start)]
        x0 += [s.to_unit(self.base_values[s.name]) for s in free]

        def values_at(z):
            values = dict(self.base_values)
            values.update({s.name: s.from_unit(zi) for s, zi in zip(spaces, z)})
            return values

        def fun(z):
            self.progress.label = f'fit {candidate.name}'
            return self.train_residuals(values_at(z))

        self.stop_moves = refine and any(s.name == STOP for s in spaces)
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
            self.stop_moves = False
        values = values_at(z)
        n = residual.size
        failed = bool(np.all(residual == FAILED_RESIDUAL))
        params = {s.name: values[s.name] for s in spaces}
        stderr = _standard_errors(spaces, z, residual, jac)
        return FitResult(name=candidate.name, params=params,
                         units={s.name: SPECS[s.name].unit for s in spaces},
                         stderr=stderr, residual_rms=float(np.sqrt(np.mean(residual ** 2))),
                         n_samples=n, success=success and not failed,
                         message='simulation failed' if failed else message)

    def score(self, fit, refined):
        """Return the CandidateScore of a FitResult on the held-out part."""
        values = dict(self.base_values)
        values.update(fit.params)
        cost, rmse, n, rho = self.heldout(values)
        return CandidateScore(fit=fit, heldout_cost=cost,
                              heldout_score=math.sqrt(cost / n), heldout_rmse=rmse,
                              n_heldout=n, lag_one=rho, refined=refined, values=values)


def _standard_errors(spaces, z, residual, jac):
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


@dataclass
class SearchRound:
    """One greedy round: the scores of every remaining candidate, best first."""

    base_effects: list
    base_score: float
    base_rmse: dict
    scores: list
    accepted: str = ''
    restarted: bool = False  # the search restarted from this round's runner-up


def search_effects(problem, candidates, max_effects=MAX_EFFECTS, refine_top=REFINE_TOP,
                   min_gain_percent=MIN_GAIN_PERCENT):
    """Add candidates greedily while the held-out gain is significant.

    Greedy forward selection can be led astray when one effect alone mimics two
    (creep plus power loss look like extra softening). So when the greedy path
    ends with structured residuals, it is restarted once from the runner-up of
    the first round (a beam of width two at the root), and the path with the
    lower held-out BIC wins.

    Returns (effects found in order, values of the extended model, list of
    SearchRound). ``problem`` must have its nominal base set; on return its base
    is the extended model.
    """
    if problem.recalibration:
        # the recalibrated nominal parameters are refitted under the defect correction
        # first, so no candidate is credited with what that refit alone gains
        polish_effects(problem, [], {})
    nominal = dict(problem.base_values)
    found, values, rounds = _greedy(problem, candidates, max_effects, refine_top,
                                    min_gain_percent)
    first = rounds[0].scores if rounds else []
    runner_up = next((s for s in first[1:2] if s.refined and s.significant), None)
    if found and runner_up is not None and _final_score(problem, values) > WHITE_SCORE:
        best_bic = _heldout_bic(problem, values, found, candidates)
        problem.set_base(nominal)
        alt_found, alt_values, alt_rounds = _greedy(problem, candidates, max_effects,
                                                    refine_top, min_gain_percent,
                                                    first=runner_up)
        if _heldout_bic(problem, alt_values, alt_found, candidates) < best_bic:
            alt_rounds[0] = dataclasses.replace(rounds[0], accepted=runner_up.name,
                                                restarted=True)
            found, values, rounds = alt_found, alt_values, alt_rounds
        else:
            problem.set_base(values)
    found, values = prune_effects(problem, found, values, candidates)
    return found, values, rounds


def prune_effects(problem, found, values, candidates):
    """Drop effects made redundant by later additions (backward elimination).

    An effect accepted early, while the residuals were structured, can become
    redundant once a later effect explains the same signature. Each found effect
    is removed in turn and the rest refitted briefly under the current defect
    correction; the removal that lowers the held-out BIC (n ln(S/n) + k ln n) most
    is made (and polished), and the step repeats. Returns (effects, values); the
    problem's base is left at the returned model.
    """
    from tca_ros.diagnosis.candidates import Candidate
    spaces_of = {c.name: c.spaces for c in candidates}
    best_bic = _heldout_bic(problem, values, found, candidates)
    while len(found) > 1:
        trials = []
        for name in found:
            rest = [n for n in found if n != name]
            dropped = {s.name for s in spaces_of[name]}
            reduced = {k: v for k, v in values.items() if k not in dropped}
            spaces = tuple(s for n in rest for s in spaces_of[n])
            problem.base_values = reduced
            fit = problem.fit(Candidate('+'.join(rest), spaces, ()),
                              [reduced[s.name] for s in spaces], max_nfev=PRUNE_NFEV)
            reduced.update(fit.params)
            trials.append((_heldout_bic(problem, reduced, rest, candidates), rest, reduced))
        bic, rest, reduced = min(trials, key=lambda t: t[0])
        if bic > best_bic:
            break
        problem.set_base(reduced)
        reduced = polish_effects(problem, rest, spaces_of)
        best_bic, found, values = _heldout_bic(problem, reduced, rest, candidates), rest, reduced
    problem.set_base(values)
    return found, values


def _final_score(problem, values):
    cost, _, n, _ = problem.heldout(values)
    return math.sqrt(cost / n)


def _heldout_bic(problem, values, found, candidates):
    """Return n ln(S / n) + k ln(n) of the held-out residuals of ``values`` (-)."""
    cost, _, n, _ = problem.heldout(values)
    k = sum(c.n_params for c in candidates if c.name in found)
    return n * math.log(cost / n) + k * math.log(n)


def _greedy(problem, candidates, max_effects, refine_top, min_gain_percent, first=None):
    """Run forward selection from the problem's base; ``first`` forces round one."""
    found, rounds = [], []
    remaining = [c for c in candidates if c.starts]
    spaces_of = {c.name: c.spaces for c in candidates}
    values = dict(problem.base_values)
    if first is not None:
        rounds.append(None)  # the caller fills in the first round it forced
        found.append(first.name)
        problem.set_base(first.values)
        values = polish_effects(problem, found, spaces_of)
        remaining = [c for c in remaining if c.name != first.name]
    while remaining and len(found) < max_effects:
        base_cost, base_rmse, n, _ = problem.heldout(values)
        base_score = math.sqrt(base_cost / n)
        if found and base_score <= WHITE_SCORE:
            break  # the residual is noise: nothing left for a further effect to explain
        base_residuals = problem.heldout_residuals(values)
        screened = [(problem.screen(c), c) for c in remaining]
        screened.sort(key=lambda item: item[0][0][0])
        scores = []
        # forward selection with refit: the effects already found are refitted jointly
        # with each refined candidate, so an earlier effect that absorbed part of this
        # one's signature can give it back
        free = tuple(s for name in found for s in spaces_of[name]) + problem.recalibration

        def evaluate(trials, cand, refine):
            fit = problem.fit(cand, trials[0][1], refine=refine, free=free if refine else ())
            score = problem.score(fit, refine)
            score.criterion = noise_model_gain(problem, base_residuals, score.values,
                                               cand.n_params)
            gain = 100.0 * (1.0 - score.heldout_score / base_score)
            score.significant = bool(fit.success and score.criterion > 0.0
                                     and gain >= min_gain_percent)
            return score

        by_name = {cand.name: (trials, cand) for trials, cand in screened}
        # refine the best few by total cost, and the best screen of each channel: an
        # effect that alone explains the temperature points at a thermal cause even
        # when displacement errors dominate the total
        refine = {cand.name for _, cand in screened[:refine_top]}
        for i in range(len(problem.channels)):
            refine.add(min(screened, key=lambda item: min(t[2][i] for t in item[0]))[1].name)
        scores = [evaluate(trials, cand, cand.name in refine) for trials, cand in screened]
        scores.sort(key=lambda s: s.heldout_cost)
        while not scores[0].refined:
            # a screened start beat the refined fits on held-out data: refine it too
            scores[0] = evaluate(*by_name[scores[0].name], True)
            scores.sort(key=lambda s: s.heldout_cost)
        rnd = SearchRound(base_effects=list(found), base_score=base_score,
                          base_rmse=base_rmse, scores=scores)
        rounds.append(rnd)
        best = scores[0]
        if not (best.refined and best.significant):
            break
        rnd.accepted = best.name
        found.append(best.name)
        problem.set_base(best.values)
        values = polish_effects(problem, found, spaces_of)
        remaining = [c for c in remaining if c.name != best.name]
    return found, values, rounds


def polish_effects(problem, found, spaces_of, max_nfev=POLISH_NFEV):
    """Refit the found effects jointly under the current base's defect correction.

    The correction was computed for the model the candidate was fitted against;
    refitting now makes the base as good as it can be before the next round, so
    a further candidate is not credited with the refit's gain. Returns the values
    of the (re-based) model.
    """
    from tca_ros.diagnosis.candidates import Candidate
    values = dict(problem.base_values)
    spaces = tuple(s for name in found for s in spaces_of[name]) + problem.recalibration
    joint = Candidate('+'.join(found), spaces, ())
    fit = problem.fit(joint, [values[s.name] for s in spaces], refine=True,
                      max_nfev=max_nfev)
    polished = dict(values)
    polished.update(fit.params)
    before = problem.train_residuals(values)
    after = problem.train_residuals(polished)
    if fit.success and after @ after < before @ before:
        problem.set_base(polished)
        return polished
    return values
