"""Fit candidate extensions to a record: one bounded fit, its uncertainties, its score.

Method (docs/diagnosis.md)
--------------------------
1. The record is split into training and held-out parts (holdout.py: blocks spread
   over the record by default, or a tail). Both run in one simulation from the
   inputs, so a held-out part starts from the state the simulation carries into it.
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
5. The search over candidates that uses these fits: ``search.py``.

The result types and the standard errors are in ``fit_result.py``, the
progress bar that counts the simulations in ``progress.py``.
"""
import math

import numpy as np
from scipy.optimize import least_squares

from tca_ros.diagnosis.fit_result import CandidateScore, FitResult, standard_errors
from tca_ros.diagnosis.holdout import DEFAULT_VALIDATION, make_holdout, mask_runs
from tca_ros.diagnosis.noise import quantisation_sigma
from tca_ros.diagnosis.progress import Progress
from tca_ros.diagnosis.residuals import lag_one_autocorrelation, noise_sigma
from tca_ros.model.params import SPECS
from tca_ros.model.quasistatic import QuasiStaticUnsupported, simulate_quasistatic
from tca_ros.model.simulation import simulate

FAILED_RESIDUAL = 1e3  # noise units per sample returned when a simulation fails
DISPLACEMENT_NOISE_FLOOR = 1e-7  # m, noise floor for noise-free data
TEMPERATURE_NOISE_FLOOR = 1e-3  # K
TRAIN_FRACTION = 0.7  # share of the record used for fitting (the rest is held out)
FIT_RATE_HZ = 10.0  # coarse grid of the fits; defect correction restores accuracy
MIN_PHYSICS_RATE_HZ = 200.0  # record-rate simulations step at least this fast (Hz)
MAX_NFEV = 8  # least-squares iterations (function evaluations, Jacobian excluded)
DIFF_STEP = 2e-3  # finite-difference step in the unit-scaled parameters
STOP = 'coil.min_pitch_angle_deg'  # the coil-contact parameter (deg)


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
        Share of the record used for fitting; the rest is held out.
    validation : str
        Layout of the held-out part: 'blocks' or 'tail' (holdout.py).
    progress : Progress, optional
        Counts simulations.
    reduced : bool
        Simulate the fits' coarse grid with the quasi-static reduction where it
        applies (the defect correction removes its difference from the full
        dynamics at the base model); False: always the full dynamics (18).
    """

    def __init__(self, record, params, model='cst', physics_rate=None, fit_rate=FIT_RATE_HZ,
                 train_fraction=TRAIN_FRACTION, progress=None, reduced=True,
                 validation=DEFAULT_VALIDATION):
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
        self.holdout = make_holdout(train_fraction, validation)
        held = self.holdout.heldout_mask(self.coarse_time, record.duration)
        self.train_index = np.flatnonzero(~held)  # coarse indices of the training part
        self.heldout_index = np.flatnonzero(held)
        if self.train_index.size < 2 or self.heldout_index.size < 2:
            raise ValueError(f'{record.source}: {n} samples cannot be split into training '
                             'and held-out parts on the fit grid')
        self.split = int(self.train_index[-1]) + 1  # the training simulation's end
        self.coarse_runs = mask_runs(held)  # (i0, i1) coarse ranges held out
        self.full_runs = self.holdout.runs(record.time)  # the same at the record's rate
        self.channels = ['displacement']
        # white noise from second differences, at least the rounding of a quantised
        # sensor (an encoder's differences are mostly 0: their MAD would be 0)
        self.sigma = {'displacement': noise_sigma(record.displacement, max(
            DISPLACEMENT_NOISE_FLOOR, quantisation_sigma(record.displacement)))}
        if record.temperature is not None:
            self.channels.append('temperature')
            self.sigma['temperature'] = noise_sigma(record.temperature, max(
                TEMPERATURE_NOISE_FLOOR, quantisation_sigma(record.temperature)))
        # the fits' residual scale of each channel: the white noise until
        # scale_channels_by sets it from a model's residual (docs/diagnosis.md §15)
        self.fit_scale = dict(self.sigma)
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
    def normalised_residuals(self, prediction, index, scale=None):
        """Return the residuals (-) of all channels at coarse ``index``, each scaled.

        Each channel is divided by its ``scale`` ({channel: m or K}, default the
        sensor noise ``sigma``).
        """
        scale = scale or self.sigma
        parts = [(self.coarse_measured[c][index] - prediction[c][index])
                 / scale[c] for c in self.channels]
        return np.concatenate(parts)

    def train_residuals(self, values):
        """Return the training residual vector (-) for ``values``, channels in ``fit_scale``."""
        n = self.train_index.size * len(self.channels)
        prediction = self.simulate_coarse(values, self.split)
        if prediction is None:
            return np.full(n, FAILED_RESIDUAL)
        return self.normalised_residuals(prediction, self.train_index, self.fit_scale)

    def scale_channels_by(self, values):
        """Set each channel's fit scale to the training residual RMS of ``values`` (m, K).

        Floored at the sensor noise ``sigma``. The maximum-likelihood weight of a
        channel whose residual is mostly model error, not sensor noise: with the
        white noise as scale, a displacement whose noise is coloured (sigma from
        second differences sees only its white part) outweighs the temperature by
        orders of magnitude, and a fit trades kelvins of temperature error for
        micrometres of displacement (docs/diagnosis.md §15). The calibration engine
        scales its channels the same way (engine.py).
        """
        prediction = self.simulate_coarse(values, self.split)
        if prediction is None:
            return
        raw = self.normalised_residuals(prediction, self.train_index,
                                        dict.fromkeys(self.channels, 1.0))
        for c, res in zip(self.channels, raw.reshape(len(self.channels), -1)):
            self.fit_scale[c] = max(self.sigma[c], float(np.sqrt(np.mean(res * res))))

    def heldout(self, values):
        """Return (cost, {channel: RMSE}, n, lag-1 autocorrelation) on the held-out part."""
        prediction = self.simulate_coarse(values)
        n = self.heldout_index.size * len(self.channels)
        if prediction is None:
            return FAILED_RESIDUAL ** 2 * n, {c: math.inf for c in self.channels}, n, 1.0
        rmse, rhos = {}, []
        for c in self.channels:
            res = self.coarse_measured[c] - prediction[c]
            rmse[c] = float(np.sqrt(np.mean(res[self.heldout_index] ** 2)))
            rhos.extend(lag_one_autocorrelation(res[a:b]) for a, b in self.coarse_runs)
        r = self.normalised_residuals(prediction, self.heldout_index)
        return float(r @ r), rmse, n, float(np.mean(rhos))

    def heldout_residuals(self, values):
        """Return [{channel: measured - predicted}] on the coarse held-out runs, or None.

        One dict per contiguous held-out run (channel units); their rates are in
        ``coarse_rates``, their starts in ``heldout_starts``, the record each
        belongs to in ``heldout_groups``.
        """
        prediction = self.simulate_coarse(values)
        if prediction is None:
            return None
        return [{c: self.coarse_measured[c][a:b] - prediction[c][a:b] for c in self.channels}
                for a, b in self.coarse_runs]

    @property
    def coarse_rates(self):
        """Return [coarse-grid rate (Hz)] per held-out run."""
        return [self.sample_rate / self.k] * len(self.coarse_runs)

    @property
    def heldout_starts(self):
        """Return [time (s) of each coarse held-out run's start since the record's zero]."""
        return [float(self.coarse_time[a] - self.record.time[0]) for a, _ in self.coarse_runs]

    @property
    def heldout_groups(self):
        """Return [key of the record] per held-out run: runs of one record share a drift."""
        return [id(self)] * len(self.coarse_runs)

    @property
    def full_heldout_index(self):
        """Return the record-rate indices of the held-out part (all runs)."""
        return np.concatenate([np.arange(a, b) for a, b in self.full_runs])

    @property
    def full_train_mask(self):
        """Return the record-rate boolean mask of the training part."""
        return self.holdout.train_mask(self.record.time)

    # -- fitting --------------------------------------------------------------------
    def screen(self, candidate, base_starts=()):
        """Return [(train cost, start values, cost per channel, base start)], best first.

        Each start is tried on the base and on the base with each dict of
        ``base_starts`` ({dotted name: value} of recalibrated parameters) applied;
        the plain base's base start is {}. Costs are sums of squared normalised
        training residuals (-); the per-channel costs follow ``self.channels``.
        """
        out = []
        for start in candidate.starts:
            for base_start in ({},) + tuple(base_starts):
                values = {**self.base_values, **base_start}
                values.update({s.name: v for s, v in zip(candidate.spaces, start)})
                self.progress.label = f'screen {candidate.name}'
                r = self.train_residuals(values)
                per_channel = tuple(float(part @ part)
                                    for part in r.reshape(len(self.channels), -1))
                out.append((float(r @ r), start, per_channel, base_start))
        return sorted(out, key=lambda item: item[0])

    def fit(self, candidate, start, refine=True, free=(), max_nfev=MAX_NFEV, base_start=None):
        """Fit ``candidate`` from ``start`` (values per space); return a FitResult.

        ``free`` lists further ParameterSpaces (already in the base) refitted jointly,
        each started from ``base_start`` ({dotted name: value}) where that has it,
        else from the base.
        """
        spaces = tuple(candidate.spaces) + tuple(free)
        x0 = [s.to_unit(v) for s, v in zip(candidate.spaces, start)]
        first = {**self.base_values, **(base_start or {})}
        x0 += [s.to_unit(first[s.name]) for s in free]

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
        stderr = standard_errors(spaces, z, residual, jac)
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
