"""One record simulated at its own rate and on the fits' coarse grid, defect-corrected.

The fits (fitting.py) run on a coarse grid of ``fit_rate`` Hz: the inputs averaged over
each coarse interval (which preserves the heat input), simulated by the quasi-static
reduction where it applies (model/quasistatic.py, about 100x cheaper) or by the
dynamics (18) at the coarse rate. The discretisation error of the coarse grid is
removed by defect correction: the difference between the current base model
simulated at the record rate and on the coarse grid is added to every coarse
simulation, so candidates are compared at record-rate accuracy
(docs/diagnosis_method.md, "Fast fits").
"""
import math

import numpy as np

from tca_ros.calibration.progress import Progress
from tca_ros.model.quasistatic import QuasiStaticUnsupported, simulate_quasistatic
from tca_ros.model.simulation import simulate

FIT_RATE_HZ = 10.0  # coarse grid of the fits; defect correction restores accuracy
MIN_PHYSICS_RATE_HZ = 200.0  # record-rate simulations step at least this fast (Hz)
STOP = 'coil.min_pitch_angle_deg'  # the coil-contact parameter (deg)


def _block_mean(values, k, m):
    """Return the means of consecutive blocks of k samples (m blocks, last padded)."""
    n = values.size
    pad = m * k - n
    if pad > 0:
        values = np.concatenate([values, np.full(pad, values[-1])])
    return values[:m * k].reshape(m, k).mean(axis=1)


class GridSimulations:
    """Simulations of one record for a nominal params and dotted ``values``, cached.

    ``simulate_full`` runs the record's own samples (physics at ``physics_rate``,
    at least the sample rate, default MIN_PHYSICS_RATE_HZ: about 2 um RMS from a
    500 Hz truth, against 5.6 um at 100 Hz); ``simulate_coarse`` the coarse grid of
    about ``fit_rate`` Hz, defect-corrected at the base values (``set_base``).
    ``reduced``: the coarse grid by the quasi-static reduction where it applies
    (False: always the full dynamics (18)). ``progress`` counts simulations. The
    channels are the displacement (m) and, when the record has it, the
    temperature (degC).
    """

    def __init__(self, record, params, model='cst', physics_rate=None, fit_rate=FIT_RATE_HZ,
                 progress=None, reduced=True):  # noqa: D107 -- documented on the class
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
        self.channels = ['displacement']
        if record.temperature is not None:
            self.channels.append('temperature')
        # (kind of coarse simulation, base stop) -> {channel: defect correction}
        self.correction = {}
        self._nominal_stop = math.degrees(params.coil.min_pitch_angle)
        self.stop_moves = False  # a fit moves the coil stop: all its values run full
        self.reduced = reduced
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
