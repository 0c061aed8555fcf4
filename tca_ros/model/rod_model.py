"""The Cosserat rod kinetostatic model 'rod': f_rod(y, T) of Eq. (18) from exact helices.

Away from its clamp a helical TCA under an axial load is a uniform helix whose
strains solve the algebraic equilibrium of :mod:`tca_ros.rod.helix` exactly (all four
strains, geometrically exact, end free to rotate as in the paper's BVP with
M_e = 0). The full-length BVP (:mod:`tca_ros.rod.statics`) agrees with it to the
clamp boundary layer (test/test_rod_statics.py); solving the algebraic problem is
what makes the model fast.

For the dynamics, f_rod must cost microseconds. The elongation y(T, F) is computed
exactly on a grid of temperatures and tensions (moduli of Eq. (11) evaluated at the
tension itself, so no fixed point is needed), then inverted per temperature to
F(T, eta) on a uniform grid of eta = y - y_free(T), together with the stiffness
dF/dy. A query interpolates linearly in T and by cubic Hermite in eta, in plain
Python (docs/rod.md gives the measured error and cost). Tables are cached per
parameter set.

References
----------
[1] Sun et al., IEEE T-RO 2022, Eqs. (4), (8)-(18), Algorithm 1, Appendix C.
"""
from dataclasses import dataclass, replace
import functools
import math

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.optimize import brentq

from tca_ros.model.fiber import unit_untwist
from tca_ros.model.kinetostatics import cst_compliance, KinetostaticModel
from tca_ros.model.moduli import load_torsion_strain, section_stiffness
from tca_ros.model.params import EffectParams, RigParams
from tca_ros.rod.helix import helix_centreline, uniform_helix_equilibrium
from tca_ros.rod.reference import conical_spiral_reference, helix_reference, helix_strain
from tca_ros.rod.reference import integrate_strains
from tca_ros.rod.statics import solve_continuation

TABLE_TEMP_STEP = 2.5  # K; linear interpolation in T, error measured in docs/rod.md
TABLE_TEMP_BELOW = 20.0  # K below ambient covered by the table
TABLE_TEMP_MAX = 200.0  # degC, above the 160 degC of the experiments; clamped beyond
TABLE_FORCE_POINTS = 150  # tensions solved per temperature row
TABLE_ETA_POINTS = 1201  # uniform elongation points per row after inversion
STRETCH_FRACTION = 1.0  # table spans tension up to this fraction of l_t - l* (linear)
COMPRESS_FRACTION = 1.5  # and compression to this multiple of the contact travel
DERIVATIVE_STEP = 1e-7  # N, forward difference of y(F) (moduli depend on F)
LOAD_RAMP_STEPS = 8  # load continuation steps for a loaded conical TCA
CONICAL_STEPS_PER_TURN = 128  # second-order mesh: shape error ~3e-4 of the radius


def _section_vector(section):
    return section.EI, section.GJ, section.GA, section.EA


def helix_elongation(params, temperature, tension, rotation_locked=False):
    """Return the exact helix elongation y = l_t v.u/|u| - l* (m) at (T, F).

    Parameters
    ----------
    params : TcaParams
        A helical TCA (``coil.shape == 'helix'``).
    temperature : float
        Fiber temperature T (degC).
    tension : float or ndarray
        Axial force F (N), tensile positive; the moduli are evaluated at F (Eq. (11)).
    rotation_locked : bool
        Hold the coil angle at its ambient reference value instead of a free end.

    Returns
    -------
    float or ndarray
        Elongation (m), NaN where the helix solve failed.
    """
    eq = _helix_state(params, temperature, tension, rotation_locked)
    y = params.fiber.length * eq.axial_stretch - _natural_length(params)
    return np.where(eq.success, y, np.nan)


def _natural_length(params):
    return params.fiber.length * math.sin(params.coil.pitch_angle)


def _helix_state(params, temperature, tension, rotation_locked=False):
    coil = params.coil
    kappa, tau = helix_strain(coil.radius, coil.pitch_angle)
    untwist = unit_untwist(temperature, params.fiber, params.thermal.ambient_temperature)
    forces = np.atleast_1d(np.asarray(tension, dtype=float))
    stiff = np.array([_section_vector(section_stiffness(temperature, float(f), params))
                      for f in forces.ravel()]).T.reshape((4,) + forces.shape)
    lock = math.hypot(kappa, tau) if rotation_locked else None
    eq = uniform_helix_equilibrium(forces, (kappa, tau + untwist), tuple(stiff),
                                   turn_rate_lock=lock)
    if np.ndim(tension) == 0:
        eq = type(eq)(**{k: (np.asarray(v)[..., 0] if k != 'n_iter' else v)
                         for k, v in eq.__dict__.items()})
    return eq


class RodTableError(RuntimeError, ArithmeticError):
    """The exact helices cannot fill the (elongation, temperature) table of a TCA.

    An ArithmeticError too, so the fits that treat a model failure as a failed
    candidate (ValueError, ArithmeticError) treat this one alike.
    """


@dataclass(frozen=True)
class _Table:
    temp0: float
    temp_step: float
    n_temp: int
    eta0: float
    eta_step: float
    n_eta: int
    free: list  # y_free(T_i), m
    force: list  # F(T_i, eta_k) flattened row-major, N
    slope: list  # dF/dy(T_i, eta_k) flattened, N/m


def _clip_force(params):
    """Return the tension (N) where tau of Eq. (11) reaches its calibrated maximum."""
    per_newton = load_torsion_strain(1e-3, params.fiber, params.coil, params.moduli) / 1e-3
    if per_newton <= 0.0 or params.moduli.constant:
        return math.inf
    return params.moduli.max_torsion_strain / per_newton


def _linear_stiffness(params):
    section = section_stiffness(params.thermal.ambient_temperature, 0.0, params)
    return 1.0 / cst_compliance(params.coil.radius, params.coil.pitch_angle, section,
                                params.fiber)


@functools.lru_cache(maxsize=8)
def _build_table(params, rotation_locked):
    """Solve exact helices on a (T, F) grid and invert to F(T, eta); see module doc."""
    length = params.fiber.length
    l_star = _natural_length(params)
    k_lin = _linear_stiffness(params)
    f_hi = k_lin * STRETCH_FRACTION * (length - l_star)
    travel = l_star - length * math.sin(min(params.coil.min_pitch_angle,
                                            0.5 * params.coil.pitch_angle))
    f_lo = -k_lin * COMPRESS_FRACTION * travel
    ambient = params.thermal.ambient_temperature
    temps = np.arange(ambient - TABLE_TEMP_BELOW, TABLE_TEMP_MAX + 0.5 * TABLE_TEMP_STEP,
                      TABLE_TEMP_STEP)
    kinks = [f for f in (0.0, _clip_force(params)) if f_lo < f < f_hi]
    edges = [f_lo] + kinks + [f_hi]
    # Split the tension range where Eq. (11) clips tau (dE_f/dF jumps, so does dy/dF):
    # each piece gets its own Hermite inverse with one-sided end slopes.
    n_piece = max(8, TABLE_FORCE_POINTS // (len(edges) - 1))
    pieces = [np.linspace(a, b, n_piece) for a, b in zip(edges[:-1], edges[1:])]
    ys, slopes, free = [], [], []
    for temp in temps:
        row_y, row_dy = [], []
        for f in pieces:
            y = helix_elongation(params, temp, f, rotation_locked)
            step = np.full(f.size, DERIVATIVE_STEP)
            step[-1] = -DERIVATIVE_STEP  # stay inside the piece at its right end
            dy = (helix_elongation(params, temp, f + step, rotation_locked) - y) / step
            if not (np.all(np.isfinite(y)) and np.all(dy > 0.0)):
                raise RodTableError(f'rod table: exact helix failed or lost monotonicity '
                                    f'at T = {temp:g} degC')
            row_y.append(y)
            row_dy.append(dy)
        ys.append(row_y)
        slopes.append(row_dy)
        free.append(float(row_y[edges.index(0.0)][0]))
    free = np.array(free)
    eta_lo = float(np.max([row[0][0] - fr for row, fr in zip(ys, free)]))
    eta_hi = float(np.min([row[-1][-1] - fr for row, fr in zip(ys, free)]))
    etas = np.linspace(eta_lo, eta_hi, TABLE_ETA_POINTS)
    force_tab = np.empty((temps.size, etas.size))
    slope_tab = np.empty_like(force_tab)
    for i in range(temps.size):
        targets = free[i] + etas
        for f, y, dy in zip(pieces, ys[i], slopes[i]):
            inside = (targets >= y[0]) & (targets <= y[-1])
            inverse = CubicHermiteSpline(y, f, 1.0 / dy)
            force_tab[i, inside] = inverse(targets[inside])
            slope_tab[i, inside] = inverse(targets[inside], 1)
    return _Table(temp0=float(temps[0]), temp_step=TABLE_TEMP_STEP, n_temp=temps.size,
                  eta0=eta_lo, eta_step=float(etas[1] - etas[0]), n_eta=etas.size,
                  free=free.tolist(), force=force_tab.ravel().tolist(),
                  slope=slope_tab.ravel().tolist())


class RodKinetostatics(KinetostaticModel):
    """Cosserat rod kinetostatics (exact uniform helix), the model 'rod'.

    ``tension(y, T)`` and ``stiffness(y, T)`` interpolate a cached table of exact
    solutions (a few microseconds); ``direct_tension`` solves exactly (the reference
    the table is tested against). Elongation y (m) is from l* = l_t sin(alpha*),
    positive when stretched; tension F (N) positive when the TCA pulls.

    Parameters
    ----------
    params : TcaParams
        A helical TCA.
    rotation_locked : bool
        Hold the coil count (end cannot rotate) instead of the free end (M_e = 0).
    """

    name = 'rod'

    def __init__(self, params, rotation_locked=False):
        if params.coil.shape != 'helix':
            raise ValueError(f'coil.shape = {params.coil.shape!r}: the rod kinetostatic '
                             'model needs a helix; use conical_shapes for a conical TCA')
        super().__init__(params)
        self.rotation_locked = bool(rotation_locked)
        self._table = _build_table(params, self.rotation_locked)

    def _locate(self, elongation, temperature):
        tab = self._table
        t = (temperature - tab.temp0) / tab.temp_step
        t = min(max(t, 0.0), tab.n_temp - 1.000001)
        i = int(t)
        w = t - i
        free = tab.free[i] + w * (tab.free[i + 1] - tab.free[i])
        x = (elongation - free - tab.eta0) / tab.eta_step
        return i, w, x

    def _row(self, i, k, u):
        """Hermite value and slope at cell k (fraction u) of temperature row i."""
        tab = self._table
        j = i * tab.n_eta + k
        f0, f1 = tab.force[j], tab.force[j + 1]
        d0, d1 = tab.slope[j] * tab.eta_step, tab.slope[j + 1] * tab.eta_step
        u2 = u * u
        u3 = u2 * u
        value = ((2 * u3 - 3 * u2 + 1) * f0 + (u3 - 2 * u2 + u) * d0
                 + (3 * u2 - 2 * u3) * f1 + (u3 - u2) * d1)
        slope = ((6 * u2 - 6 * u) * f0 + (3 * u2 - 4 * u + 1) * d0
                 + (6 * u - 6 * u2) * f1 + (3 * u2 - 2 * u) * d1) / tab.eta_step
        return value, slope

    def _evaluate(self, elongation, temperature):
        tab = self._table
        i, w, x = self._locate(elongation, temperature)
        last = tab.n_eta - 1
        if x < 0.0:  # beyond the table: linear extrapolation with the edge stiffness
            k, u, extra = 0, 0.0, x * tab.eta_step
        elif x >= last:
            k, u, extra = last - 1, 1.0, (x - last) * tab.eta_step
        else:
            k = int(x)
            u, extra = x - k, 0.0
        f_a, k_a = self._row(i, k, u)
        f_b, k_b = self._row(i + 1, k, u)
        slope = k_a + w * (k_b - k_a)
        return f_a + w * (f_b - f_a) + slope * extra, slope

    def tension(self, elongation, temperature, force_guess=None):
        """Return f_rod (N) at elongation y (m) and temperature T (degC), Eq. (18).

        ``force_guess`` is accepted for interface compatibility and ignored: the
        table already satisfies the moduli fixed point of Eq. (11).
        """
        return self._evaluate(elongation, temperature)[0]

    def stiffness(self, elongation, temperature):
        """Return d f_rod / d y (N/m) at elongation (m) and temperature (degC)."""
        return self._evaluate(elongation, temperature)[1]

    def free_elongation(self, temperature):
        """Return the unloaded elongation y_free(T) (m) (exact helix, F = 0)."""
        return float(helix_elongation(self.params, temperature, 0.0, self.rotation_locked))

    def equilibrium_elongation(self, load, temperature, guess=None):
        """Return y (m) where f_rod(y, T) = load (N), solved exactly; no coil contact."""
        return float(helix_elongation(self.params, temperature, load, self.rotation_locked))

    def direct_tension(self, elongation, temperature):
        """Return f_rod (N) by an exact solve (Brent on F of the exact y(T, F)).

        The moduli are evaluated at the root F itself (the fixed point of Eq. (11)).
        """
        def gap(force):
            return float(helix_elongation(self.params, temperature, force,
                                          self.rotation_locked)) - elongation
        k = _linear_stiffness(self.params)
        guess = self.tension(elongation, temperature)
        span = 0.05 * abs(guess) + 1e-3 * k * self.params.fiber.length
        lo, hi = guess - span, guess + span
        for _ in range(40):
            if gap(lo) < 0.0 < gap(hi):
                break
            lo, hi = lo - span, hi + span
            span *= 2.0
        return brentq(gap, lo, hi, xtol=1e-13, rtol=1e-13)


def cached_rod_model(params):
    """Return the RodKinetostatics of ``params``, built once per mechanical state.

    The table depends only on the fiber, coil, moduli, ambient temperature and the
    modulus-softening effect; parameter sets differing elsewhere (thermal constants,
    mass, resistance, other effects) share one table.
    """
    return _rod_model_for(mechanical_params(params))


def mechanical_params(params):
    """Return ``params`` with every field the rod table does not read set to default."""
    thermal = replace(params.thermal, convection_coefficient=0.0, surface_factor=1.0,
                      delivered_power_ratio=1.0)
    fiber = replace(params.fiber, density=1.0, specific_heat=1.0)
    return replace(params, tca_type='', model='rod', source='', thermal=thermal, fiber=fiber,
                   dynamics=replace(params.dynamics, mass=0.0, load=0.0, damping=0.0),
                   electrical=replace(params.electrical, resistance=1.0,
                                      temperature_coefficient=0.0, strain_coefficient=0.0),
                   effects=EffectParams(extra_softening=params.effects.extra_softening),
                   rig=RigParams())


@functools.lru_cache(maxsize=8)
def _rod_model_for(params):
    return RodKinetostatics(params)


def centreline(params, elongation, temperature, n_points=200):
    """Return the centreline of the TCA at elongation y and temperature T.

    Helix: the exact uniform helix at the tension f_rod(y, T), on the global Z axis,
    from the clamp at z = 0 downwards (z = -l at the free end), for display (RViz).
    Other shapes (conical): the unloaded heated reference integrated from the clamp
    (the no-load equilibrium); ``elongation`` is then ignored.

    Parameters
    ----------
    params : TcaParams
        A helical TCA.
    elongation : float
        y (m) from the natural length.
    temperature : float
        T (degC).
    n_points : int
        Number of points, >= 2.

    Returns
    -------
    ndarray, shape (3, n_points)
        Positions (m) in the clamp's frame.
    """
    if int(n_points) < 2:
        raise ValueError(f'n_points = {n_points!r}: must be >= 2')
    if params.coil.shape != 'helix':
        ref = rod_reference(params, temperature)
        return integrate_strains(ref, np.linspace(0.0, ref.length, int(n_points)))[0]
    model = cached_rod_model(params)
    force = model.tension(elongation, temperature)
    eq = _helix_state(params, temperature, force)
    return helix_centreline(eq, params.fiber.length, int(n_points))


def rod_reference(params, temperature):
    """Return the heated RodReference of ``params`` at T (degC), Eqs. (15), (40)."""
    untwist = unit_untwist(temperature, params.fiber, params.thermal.ambient_temperature)
    c = params.coil
    if c.shape == 'helix':
        return helix_reference(c.radius, c.pitch_angle, params.fiber.length, untwist)
    return conical_spiral_reference(c.spiral_pitch, c.cone_angle, params.fiber.length,
                                    untwist)


def stiffness_vector(params, temperature, tension):
    """Return diag(K) = [EI, EI, GJ, GA, GA, EA] (N m^2, N) at (T, F), Eq. (8)."""
    s = section_stiffness(temperature, tension, params)
    return np.array([s.EI, s.EI, s.GJ, s.GA, s.GA, s.EA])


def rod_statics_sweep(params, load, temperatures, n_steps=None, **solver_options):
    """Solve the full-length rod BVP over temperatures (Algorithm 1 of [1]).

    The load (N, tensile) hangs below the free end along -Z through a rigid cap
    whose hook is on the coil axis of the end (offset r* along the end frame's
    principal normal; docs/rod.md). Each temperature is warm-started from the
    previous one; the moduli use F = load (Eq. (11)).

    Returns
    -------
    list of RodSolution
        One per temperature; check ``success``.
    """
    offset = (params.coil.radius, 0.0, 0.0) if params.coil.shape == 'helix' else (0, 0, 0)

    def problem(temp):
        return dict(reference=rod_reference(params, temp),
                    stiffness=stiffness_vector(params, temp, load),
                    end_force=np.array([0.0, 0.0, -load]), end_load_offset=offset)
    return solve_continuation(problem, list(temperatures), n_steps=n_steps,
                              **solver_options)


def solution_elongation(params, solution):
    """Return y (m) of a helical BVP solution: axial drop of the free end minus l*."""
    return float(solution.positions[2, 0] - solution.positions[2, -1]) - _natural_length(
        params)


def conical_shapes(params, temperatures, load=0.0, n_steps=None):
    """Return the 3-D centreline of a (conical) TCA per temperature.

    The rod BVP is solved at each temperature in order (Algorithm 1, warm starts).
    With no load (the paper's case, W(l_t) = 0, Appendix C) it is the heated
    reference (40) integrated from the clamp (41). No coil contact is modelled: coils
    may pass each other, as in Fig. 13.

    Parameters
    ----------
    params : TcaParams
        Any shape ('conical' for the paper's Fig. 13).
    temperatures : sequence of float
        T (degC).
    load : float
        Dead load (N) on the fiber's end point along -Z (e.g. an end marker's weight).
    n_steps : int, optional
        Intervals along the fiber (default CONICAL_STEPS_PER_TURN per turn).

    Returns
    -------
    list of (s, xyz)
        s (n,) arc length (m), xyz (3, n) positions (m), global Z up the cone axis;
        the clamp is at the origin.

    Raises
    ------
    RuntimeError
        If a solve fails (it is a linear problem at no load; never expected).
    """
    temps = [float(t) for t in temperatures]
    if not temps:
        return []
    if n_steps is None:
        turns = rod_reference(params, temps[0]).n_coils
        n_steps = int(max(64, math.ceil(CONICAL_STEPS_PER_TURN * turns)))
    load = float(load)

    def problem(temp):
        return dict(reference=rod_reference(params, temp),
                    stiffness=stiffness_vector(params, temp, load),
                    end_force=np.array([0.0, 0.0, -load]))
    start = None
    if load != 0.0:
        # Ramp the load at the first temperature: the wide coils are compliant.
        ramp = solve_continuation(
            lambda f: dict(reference=rod_reference(params, temps[0]),
                           stiffness=stiffness_vector(params, temps[0], f),
                           end_force=np.array([0.0, 0.0, -f])),
            list(np.linspace(0.0, load, LOAD_RAMP_STEPS + 1)), n_steps=n_steps)
        start = ramp[-1] if ramp[-1].success else None
    out = []
    sols = solve_continuation(problem, temps, n_steps=n_steps, initial=start)
    for temp, sol in zip(temps, sols):
        if not sol.success:
            raise RuntimeError(f'conical shape at {temp:g} degC: {sol.message}')
        out.append((sol.s, sol.positions))
    return out


def conical_end_height(params, temperatures, load=0.0, n_steps=None):
    """Return the free end's vertical position z(l_t) (m) per temperature (Fig. 13b)."""
    shapes = conical_shapes(params, temperatures, load, n_steps)
    return np.array([xyz[2, -1] for _, xyz in shapes])
