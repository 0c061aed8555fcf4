"""The rod model's table: exact helices on a (T, F) grid, inverted to F(T, eta).

Away from its clamp a helical TCA under an axial load is a uniform helix whose
strains solve the algebraic equilibrium of :mod:`tca_ros.rod.helix` exactly. For the
dynamics f_rod must cost microseconds: the elongation y(T, F) is computed exactly on
a grid of temperatures (T0 - 20 degC to the melt) and tensions (moduli of Eq. (11)
at the tension itself, so no fixed point is needed), then inverted per temperature
to F(T, eta) on a uniform grid of eta = y - y_free(T), with the stiffness dF/dy.
docs/rod.md gives the measured error and cost and the rows the exact helix cannot
fill. Tables are cached per parameter set.

References
----------
[1] Sun et al., IEEE T-RO 2022, Eqs. (4), (8)-(18), Appendix C.
"""
from dataclasses import dataclass
import functools
import math

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from tca_ros.model.fiber import unit_untwist
from tca_ros.model.kinetostatics import cst_compliance
from tca_ros.model.limits import BELOW_AMBIENT_MARGIN, MELT_TEMPERATURE_DEGC
from tca_ros.model.moduli import load_torsion_strain, section_stiffness
from tca_ros.rod.helix import uniform_helix_equilibrium
from tca_ros.rod.reference import helix_strain

TABLE_TEMP_STEP = 2.5  # K; linear interpolation in T, error measured in docs/rod.md
TABLE_TEMP_BELOW = BELOW_AMBIENT_MARGIN  # K below ambient covered (clamped below)
TABLE_TEMP_MAX = MELT_TEMPERATURE_DEGC  # degC, up to the melt; beyond it RodTableError
TABLE_FORCE_POINTS = 150  # tensions solved per temperature row
TABLE_ETA_POINTS = 1201  # uniform elongation points per row after inversion
STRETCH_FRACTION = 1.0  # table spans tension up to this fraction of l_t - l* (linear)
COMPRESS_FRACTION = 1.5  # and compression to this multiple of the contact travel
COMPRESSION_SCAN_POINTS = 64  # tensions on which a compressed helix is followed
COMPRESSION_BISECTIONS = 30  # halvings of the last scan step (to ~1e-9 of it)
COMPRESSION_BACKOFF = 0.8  # fraction of a row's snap-through tension the table spans
COMPRESSION_RETRIES = 8  # table builds, each with less compression, before giving up
DERIVATIVE_STEP = 1e-7  # N, forward difference of y(F) (moduli depend on F)
DERIVATIVE_FRACTION = 3e-8  # of the tension span: the step for a very weak coil


def _section_vector(section):
    return section.EI, section.GJ, section.GA, section.EA


def helix_elongation(params, temperature, tension, rotation_locked=False):
    """Return the exact helix elongation y = l_t v.u/|u| - l* (m) at (T, F).

    Parameters
    ----------
    params : TcaParams
        A helical TCA (``coil.shape == 'helix'``).
    temperature : float or ndarray
        Fiber temperature T (degC); an array broadcasts with an array ``tension``.
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
    stiff = np.broadcast_arrays(*_section_vector(section_stiffness(temperature, forces,
                                                                   params)))
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
class ForceTable:
    """F(T, eta) and dF/dy of a TCA: rows of temperature, each on its own eta grid.

    eta = y - y_free(T) (m). A query interpolates linearly in T between two rows and
    by cubic Hermite along each row; beyond a row's eta range it extrapolates
    linearly with the edge stiffness. Below the first row T is clamped; above the
    last one RodTableError is raised.
    """

    temp0: float  # degC, first row
    temp_step: float  # K between rows
    n_temp: int
    n_eta: int  # points per row
    free: list  # y_free(T_i), m
    eta0: list  # first eta of row i, m
    eta_step: list  # eta spacing of row i, m
    force: list  # F(T_i, eta_k) flattened row-major, N
    slope: list  # dF/dy(T_i, eta_k) flattened, N/m

    @property
    def top(self):
        """Return the temperature (degC) of the last row."""
        return self.temp0 + self.temp_step * (self.n_temp - 1)

    def evaluate(self, elongation, temperature):
        """Return (F (N), dF/dy (N/m)) at elongation y (m) and temperature T (degC)."""
        i, w, eta = self._locate(elongation, temperature)
        f_a, k_a = self._row(i, eta)
        f_b, k_b = self._row(i + 1, eta)
        return f_a + w * (f_b - f_a), k_a + w * (k_b - k_a)

    def force_at(self, elongation, temperature):
        """Return F (N) at elongation y (m) and temperature T (degC): evaluate()[0].

        The dynamics' hot path (each muscle, each step): _locate, hermite_cell and
        cubic_hermite written out, in their order of operations, so the value
        equals evaluate()[0] (test_rig_fast_paths pins it); the slope is formed
        only where a row extrapolates.
        """
        t = (temperature - self.temp0) / self.temp_step
        top = self.n_temp - 1.0
        if not 0.0 <= t <= top:  # clamped below the first row, an error beyond the last
            i, w, eta = self._locate(elongation, temperature)
        else:
            cap = self.n_temp - 1.000001  # as min(t, cap)
            if cap < t:
                t = cap
            i = int(t)
            w = t - i
            free = self.free
            eta = elongation - (free[i] + w * (free[i + 1] - free[i]))
        force, slope, n = self.force, self.slope, self.n_eta
        eta0, eta_step = self.eta0, self.eta_step
        last = n - 1
        value = None
        for row in (i, i + 1):
            step = eta_step[row]
            x = (eta - eta0[row]) / step
            if 0.0 <= x < last:
                k = int(x)
                u = x - k
                j = row * n + k
                f0, f1 = force[j], force[j + 1]
                d0, d1 = slope[j] * step, slope[j + 1] * step
                u2 = u * u
                u3 = u2 * u
                # float literals: CPython's fast float * float path, the same values
                f = ((2.0 * u3 - 3.0 * u2 + 1.0) * f0 + (u3 - 2.0 * u2 + u) * d0
                     + (3.0 * u2 - 2.0 * u3) * f1 + (u3 - u2) * d1)
            else:  # beyond the row: linear with the edge slope
                k, u, extra = hermite_cell(eta, eta0[row], step, n)
                f = cubic_hermite(force, slope, row * n + k, u, step, extra)[0]
            if value is None:
                value = f
            else:
                return value + w * (f - value)

    def _locate(self, elongation, temperature):
        """Return (row i, weight w of row i + 1, eta (m)) of (y (m), T (degC))."""
        t = (temperature - self.temp0) / self.temp_step
        if not t <= self.n_temp - 1.0:  # also NaN
            why = ('where nylon 6,6 melts' if self.top >= TABLE_TEMP_MAX else
                   'where this coil has no regular exact helix')
            raise RodTableError(f'temperature {temperature:.6g} degC beyond the rod table, '
                                f'which ends at {self.top:g} degC {why}')
        t = min(max(t, 0.0), self.n_temp - 1.000001)
        i = int(t)
        w = t - i
        return i, w, elongation - (self.free[i] + w * (self.free[i + 1] - self.free[i]))

    def _row(self, i, eta):
        """Hermite value and slope of row i at eta (m), extrapolated past its ends."""
        step = self.eta_step[i]
        k, u, extra = hermite_cell(eta, self.eta0[i], step, self.n_eta)
        return cubic_hermite(self.force, self.slope, i * self.n_eta + k, u, step, extra)


def hermite_cell(eta, eta0, step, n):
    """Return (k, u, extra) of eta (m) on a row of n nodes from eta0 (m), ``step`` apart.

    k is the cell (0 to n - 2), u in [0, 1] the position in it, and extra (m) how far
    eta lies beyond the row's first or last node (0 inside), for cubic_hermite.
    """
    x = (eta - eta0) / step
    last = n - 1
    if x < 0.0:
        return 0, 0.0, x * step
    if x >= last:
        return last - 1, 1.0, (x - last) * step
    k = int(x)
    return k, x - k, 0.0


def cubic_hermite(force, slope, j, u, step, extra):
    """Return (force N, slope N/m) of the cubic Hermite cell j at u in [0, 1].

    ``force``/``slope`` are the table's node values (N, N/m), ``step`` the cell
    width (m); ``extra`` (m) extends linearly with the edge slope beyond the
    table. Works on floats and on NumPy arrays alike (toolkit.batch_forces).
    """
    f0, f1 = force[j], force[j + 1]
    d0, d1 = slope[j] * step, slope[j + 1] * step
    u2 = u * u
    u3 = u2 * u
    value = ((2 * u3 - 3 * u2 + 1) * f0 + (u3 - 2 * u2 + u) * d0
             + (3 * u2 - 2 * u3) * f1 + (u3 - u2) * d1)
    gradient = ((6 * u2 - 6 * u) * f0 + (3 * u2 - 4 * u + 1) * d0
                + (6 * u - 6 * u2) * f1 + (3 * u2 - 2 * u) * d1) / step
    return value + gradient * extra, gradient


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


def _snap_force(params, temperature, force, rotation_locked):
    """Return the most compressive tension (N), down to ``force``, of a regular helix.

    The exact helix at ``temperature`` (degC) is followed from F = 0 towards
    ``force`` (N, < 0) on COMPRESSION_SCAN_POINTS tensions; a steep coil pressed far
    snaps through to an inverted helix: the solve fails, or the elongation stops
    falling. Returns the last tension before that (refined by bisection).
    """
    forces = np.linspace(0.0, force, COMPRESSION_SCAN_POINTS)
    ys = helix_elongation(params, temperature, forces, rotation_locked)
    good = np.isfinite(ys) & np.concatenate(([True], np.diff(ys) < 0.0))
    if good.all():
        return force
    first_bad = int(np.argmin(good))
    inside, outside, previous = forces[first_bad - 1], forces[first_bad], ys[first_bad - 1]
    for _ in range(COMPRESSION_BISECTIONS):
        middle = 0.5 * (inside + outside)
        y = float(helix_elongation(params, temperature, middle, rotation_locked))
        if y < previous:  # also False for NaN
            inside, previous = middle, y
        else:
            outside = middle
    return inside


def _solve_row(params, rotation_locked, temp, pieces, step):
    """Return ([y], [dy/dF]) per tension piece at temp (degC), or None if not a helix.

    None when a solve fails or y(F) is not increasing: the table needs a regular,
    monotonic y(F) to invert. ``step`` (N) is the forward-difference step.
    """
    steps = []
    for f in pieces:
        s = np.full(f.size, step)
        s[-1] = -step  # stay inside the piece at its right end
        steps.append(s)
    # one vectorised solve for the row: every piece's tensions, then their stepped ones
    tensions = np.concatenate(list(pieces) + [f + s for f, s in zip(pieces, steps)])
    solved = helix_elongation(params, temp, tensions, rotation_locked)
    half = solved.size // 2
    bounds = np.cumsum([0] + [f.size for f in pieces])
    row_y, row_dy = [], []
    for a, b, s in zip(bounds[:-1], bounds[1:], steps):
        y = solved[a:b]
        dy = (solved[half + a:half + b] - y) / s
        if not (np.all(np.isfinite(y)) and np.all(dy > 0.0)):
            return None
        row_y.append(y)
        row_dy.append(dy)
    return row_y, row_dy


class _CompressionSnap(Exception):
    """A table row lost its helix under compression only (at ``temperature``, degC)."""

    def __init__(self, temperature):
        super().__init__(temperature)
        self.temperature = temperature


@functools.lru_cache(maxsize=8)
def build_table(params, rotation_locked=False):
    """Solve exact helices on a (T, F) grid and invert to F(T, eta); see module doc.

    The compressive end of the tension range is the linear estimate, reduced to
    COMPRESSION_BACKOFF of the snap-through tension of a row where the helix inverts
    before (steep coils, soft bending; docs/rod.md), as often as needed.
    """
    length = params.fiber.length
    l_star = _natural_length(params)
    k_lin = _linear_stiffness(params)
    f_hi = k_lin * STRETCH_FRACTION * (length - l_star)
    travel = l_star - length * math.sin(min(params.coil.min_pitch_angle,
                                            0.5 * params.coil.pitch_angle))
    f_lo = -k_lin * COMPRESS_FRACTION * travel
    ambient = params.thermal.ambient_temperature
    low = ambient - TABLE_TEMP_BELOW
    # rows up to the first at or above the melt, so the whole range is covered
    temps = low + TABLE_TEMP_STEP * np.arange(
        math.ceil((TABLE_TEMP_MAX - low) / TABLE_TEMP_STEP - 1e-9) + 1)
    for _ in range(COMPRESSION_RETRIES):
        try:
            return _solve_table(params, rotation_locked, temps, f_lo, f_hi)
        except _CompressionSnap as snap:
            f_lo = COMPRESSION_BACKOFF * _snap_force(params, snap.temperature, f_lo,
                                                     rotation_locked)
    raise RodTableError(f'rod table: the exact helix inverts under compression down to '
                        f'{f_lo:.3g} N')


def _solve_table(params, rotation_locked, temps, f_lo, f_hi):
    """Return the ForceTable over ``temps`` (degC) and tensions [f_lo, f_hi] (N).

    A row above the ambient temperature where the exact helix fails ends the table
    there (the coil has inverted; a query beyond raises RodTableError). At or below
    ambient a row that fails under compression only raises _CompressionSnap, one that
    fails elsewhere RodTableError.
    """
    ambient = params.thermal.ambient_temperature
    kinks = [f for f in (0.0, _clip_force(params)) if f_lo < f < f_hi]
    edges = [f_lo] + kinks + [f_hi]
    # Split the tension range where Eq. (11) clips tau (dE_f/dF jumps, so does dy/dF):
    # each piece gets its own Hermite inverse with one-sided end slopes.
    n_piece = max(8, TABLE_FORCE_POINTS // (len(edges) - 1))
    pieces = [np.linspace(a, b, n_piece) for a, b in zip(edges[:-1], edges[1:])]
    step = min(DERIVATIVE_STEP, DERIVATIVE_FRACTION * (f_hi - f_lo))  # N
    ys, slopes, free = [], [], []
    for temp in temps:
        row = _solve_row(params, rotation_locked, temp, pieces, step)
        if row is None and temp > ambient:
            break  # no regular helix from here on (it inverts or the solve fails): stop
        if row is None:
            if pieces[0][-1] <= 0.0 and _solve_row(params, rotation_locked, temp, pieces[1:],
                                                   step) is not None:
                raise _CompressionSnap(float(temp))
            raise RodTableError(f'rod table: exact helix failed or lost monotonicity '
                                f'at T = {temp:g} degC')
        ys.append(row[0])
        slopes.append(row[1])
        free.append(float(row[0][edges.index(0.0)][0]))
    temps = temps[:len(ys)]
    free = np.array(free)
    force_tab = np.empty((temps.size, TABLE_ETA_POINTS))
    slope_tab = np.empty_like(force_tab)
    eta0, eta_step = [], []
    for i in range(temps.size):
        # each row on its own eta range: a stiff, inverted hot row does not narrow the others
        first, last = ys[i][0][0], ys[i][-1][-1]
        targets = np.linspace(first, last, TABLE_ETA_POINTS)
        targets[-1] = last  # exactly the end of the last piece
        for f, y, dy in zip(pieces, ys[i], slopes[i]):
            inside = (targets >= y[0]) & (targets <= y[-1])
            inverse = CubicHermiteSpline(y, f, 1.0 / dy)
            force_tab[i, inside] = inverse(targets[inside])
            slope_tab[i, inside] = inverse(targets[inside], 1)
        eta0.append(float(first - free[i]))
        eta_step.append(float(targets[1] - targets[0]))
    return ForceTable(temp0=float(temps[0]), temp_step=TABLE_TEMP_STEP, n_temp=temps.size,
                      n_eta=TABLE_ETA_POINTS, free=free.tolist(), eta0=eta0, eta_step=eta_step,
                      force=force_tab.ravel().tolist(), slope=slope_tab.ravel().tolist())
