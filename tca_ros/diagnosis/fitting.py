"""Fit candidate extensions to a record: one bounded fit, its uncertainties, its score.

Method (docs/diagnosis_method.md)
---------------------------------
1. The record is split into training and held-out parts (holdout.py: blocks spread
   over the record by default, or a tail). Both run in one simulation from the
   inputs, so a held-out part starts from the state the simulation carries into it.
2. Fits run on a coarse grid (``fit_rate`` Hz, inputs averaged over each coarse
   interval, which preserves the heat input), defect-corrected to record-rate
   accuracy at the base model (grid_simulation.py, the base class).
3. Residuals are weighted by the sensor noise of each channel (estimated from
   the data, ``residuals.noise_sigma``), so displacement (m) and temperature (K)
   enter one dimensionless cost.
4. Each candidate is screened at a few starting magnitudes; the best few (and
   the best of each measured channel) are refined by bounded nonlinear least
   squares (scipy trust-region reflective): ``candidate_fit.py``, on the training
   residuals of this module's FitProblem.
5. The search over candidates that uses these fits: ``search.py``.

The result types and the standard errors are in ``fit_result.py``, the
progress bar that counts the simulations in ``progress.py``.
"""
import math

import numpy as np

from tca_ros.calibration.residuals import lag_one_autocorrelation, noise_sigma
# FIT_RATE_HZ, MIN_PHYSICS_RATE_HZ and STOP are read from here by the diagnosis and tests
from tca_ros.diagnosis.grid_simulation import FIT_RATE_HZ, GridSimulations, \
    MIN_PHYSICS_RATE_HZ, STOP  # noqa: F401
from tca_ros.diagnosis.holdout import DEFAULT_VALIDATION, make_holdout, mask_runs
from tca_ros.diagnosis.noise import quantisation_sigma

FAILED_RESIDUAL = 1e3  # noise units per sample returned when a simulation fails
DISPLACEMENT_NOISE_FLOOR = 1e-7  # m, noise floor for noise-free data
TEMPERATURE_NOISE_FLOOR = 1e-3  # K
TRAIN_FRACTION = 0.7  # share of the record used for fitting (the rest is held out)


class FitProblem(GridSimulations):
    """A record, a nominal parameter set and the machinery to score extensions.

    ``record`` (Record, uniform grid), ``params`` (TcaParams, the record's mass and
    initial load set), ``model`` (rod | cst | love), ``physics_rate``, ``fit_rate``
    (Hz), ``progress`` and ``reduced``: as GridSimulations, which simulates. Here:
    the split into training and held-out parts (``train_fraction``, ``validation``
    'blocks' or 'tail', holdout.py), the noise of each channel, the normalised
    training residuals and the held-out cost. The bounded fit of a candidate on
    these residuals and its held-out score are in candidate_fit.py.
    """

    def __init__(self, record, params, model='cst', physics_rate=None, fit_rate=FIT_RATE_HZ,
                 train_fraction=TRAIN_FRACTION, progress=None, reduced=True,
                 validation=DEFAULT_VALIDATION):
        super().__init__(record, params, model, physics_rate, fit_rate, progress, reduced)
        n = record.time.size
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
        # white noise from second differences, at least the rounding of a quantised
        # sensor (an encoder's differences are mostly 0: their MAD would be 0)
        self.sigma = {'displacement': noise_sigma(record.displacement, max(
            DISPLACEMENT_NOISE_FLOOR, quantisation_sigma(record.displacement)))}
        if record.temperature is not None:
            self.sigma['temperature'] = noise_sigma(record.temperature, max(
                TEMPERATURE_NOISE_FLOOR, quantisation_sigma(record.temperature)))
        # the fits' residual scale of each channel: the white noise until
        # scale_channels_by sets it from a model's residual (docs/decisions.md G12)
        self.fit_scale = dict(self.sigma)
        self.measured = {c: getattr(record, c) for c in self.channels}
        self.coarse_measured = {c: self.measured[c][self.index] for c in self.channels}
        # nominal parameters refitted with every refined candidate and every polish, so an
        # effect gets no credit for what a recalibration absorbs (set by diagnose)
        self.recalibration = ()

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
        micrometres of displacement (docs/decisions.md G12). The calibration engine
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
