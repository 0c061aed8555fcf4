"""The conical TCA's kinetostatic table: f_rod(y, T) of Eq. (18) from rod branches.

Each temperature row is the stretched branch of the hanging conical TCA
(:func:`tca_ros.model.conical.stretched_branch`: height-controlled rod solves from no
load to past the break force), resampled by PCHIP (shape-preserving, C1) onto a
uniform grid of eta = y - y_free(T) with its slope dF/dy. Queries interpolate
linearly in T between rows and by cubic Hermite along a row, as the helix table
(:class:`tca_ros.model.rod_table.ForceTable`); above the stretched range and below
the unloaded state (the end pushed up) they extrapolate linearly with the edge
stiffness.

A row costs a few seconds of rod solves, so rows are built when a query first needs
them and kept in memory and in a row store, keyed by the mechanical parameters: the
model reads no files, a store given to the table or by :func:`use_row_store` keeps
the rows (tca_ros.params.row_cache keeps them on disk, ``$TCA_ROS_CACHE``, default
``~/.cache/tca_ros``, once tca_ros.params is imported). Each row also keeps a
coarse set of centrelines for display (the node's ``shape`` Marker).

References
----------
[1] Sun et al., IEEE T-RO 2022, Eqs. (6)-(11), (18), (36)-(41).
"""
from dataclasses import dataclass
import functools
import hashlib
import math

import numpy as np
from scipy.interpolate import PchipInterpolator

from tca_ros.model.conical import free_state, HANGING, mesh_steps, stretched_branch
from tca_ros.model.kinetostatics import KinetostaticModel
from tca_ros.model.limits import BELOW_AMBIENT_MARGIN, MELT_TEMPERATURE_DEGC
from tca_ros.model.limits import check_thread_strength
from tca_ros.model.rod_model import mechanical_params
from tca_ros.model.rod_table import cubic_hermite, hermite_cell, RodTableError

TEMP_STEP = 10.0  # K between rows; interpolation error measured in docs/rod.md
ETA_POINTS = 801  # uniform points per row after resampling
SHAPE_DROPS = 41  # centrelines kept per row (uniform in the drop)
SHAPE_POINTS = 96  # points per kept centreline
CACHE_VERSION = 1  # bump when the row's content or method changes


@dataclass(frozen=True)
class ConicalRow:
    """One temperature row: F and dF/dy on a uniform eta grid, and centrelines.

    free: y_free(T) (m); eta0, eta_step (m); force (N), slope (N/m) per eta point;
    shape_drops (m) and shapes (n_drop, 3, SHAPE_POINTS) in the world frame (m).
    """

    temperature: float
    free: float
    eta0: float
    eta_step: float
    force: np.ndarray
    slope: np.ndarray
    shape_drops: np.ndarray
    shapes: np.ndarray


def build_row(params, temperature, natural_drop):
    """Return the ConicalRow at ``temperature`` (degC); y = drop - natural_drop (m)."""
    points = stretched_branch(params, temperature, mesh_steps(params, temperature))
    drops = np.array([p.drop for p in points])
    forces = np.array([p.force for p in points])
    curve = PchipInterpolator(drops, forces)
    grid = np.linspace(drops[0], drops[-1], ETA_POINTS)
    shape_drops = np.linspace(drops[0], drops[-1], SHAPE_DROPS)
    shapes = np.array([_shape_at(points, drops, d) for d in shape_drops])
    return ConicalRow(temperature=float(temperature), free=float(drops[0] - natural_drop),
                      eta0=0.0, eta_step=float(grid[1] - grid[0]), force=curve(grid),
                      slope=curve.derivative()(grid), shape_drops=shape_drops - natural_drop,
                      shapes=shapes)


def _shape_at(points, drops, drop):
    """Return the world-frame centreline (3, SHAPE_POINTS) (m) at ``drop`` (m).

    Interpolated linearly between the two branch equilibria around it (a display shape).
    """
    k = int(np.clip(np.searchsorted(drops, drop) - 1, 0, len(points) - 2))
    w = (drop - drops[k]) / (drops[k + 1] - drops[k])
    a, b = points[k].solution.positions, points[k + 1].solution.positions
    pick = np.linspace(0, a.shape[1] - 1, SHAPE_POINTS).round().astype(int)
    return HANGING @ ((1.0 - w) * a[:, pick] + w * b[:, pick])


#: The row store of tables given none (use_row_store); None: rows kept in memory only.
_default_store = None


def use_row_store(store):
    """Keep the rows of conical tables given no store of their own in ``store``.

    ``store`` has ``load(key, index)`` -> ConicalRow or None and ``save(key, index,
    row)`` (``key`` names the mechanical parameters, ``index`` the temperature row);
    None keeps rows in memory only. Return the store it replaces.
    """
    global _default_store
    previous, _default_store = _default_store, store
    return previous


class ConicalTable:
    """F(T, eta) and dF/dy of a hanging conical TCA, rows built on first use.

    Parameters
    ----------
    params : TcaParams
        A conical TCA, only its mechanical fields read (rod_model.mechanical_params).
    store : row store, optional
        Where rows persist between processes (use_row_store); default: the store
        given to use_row_store when a row is first needed.
    """

    def __init__(self, params, store=None):
        self.params = params
        self._store = store
        ambient = params.thermal.ambient_temperature
        self.temp0 = ambient - BELOW_AMBIENT_MARGIN
        self.temp_step = TEMP_STEP
        self.n_temp = int(math.ceil((MELT_TEMPERATURE_DEGC - self.temp0) / TEMP_STEP
                                    - 1e-9)) + 1
        self.top = self.temp0 + TEMP_STEP * (self.n_temp - 1)
        self._key = hashlib.sha256(repr((CACHE_VERSION, params)).encode()).hexdigest()[:20]
        self._rows = {}
        self.natural_drop = float(free_state(params, ambient,
                                             mesh_steps(params, ambient)).positions[2, -1])

    def row(self, i):
        """Return ConicalRow i (T = temp0 + i temp_step), from memory, store or solved."""
        row = self.cached_row(i)
        if row is None:
            row = self._rows[i] = self._build_and_save(i)
        return row

    def cached_row(self, i):
        """Return ConicalRow i from memory or the row store, or None (nothing solved)."""
        row = self._rows.get(i)
        if row is None:
            store = self._store if self._store is not None else _default_store
            row = store.load(self._key, i) if store is not None else None
            if row is not None:
                self._rows[i] = row
        return row

    def insert(self, i, row):
        """Keep ConicalRow i built elsewhere (another process, from the same params)."""
        self._rows[i] = row

    def _build_and_save(self, i):
        row = build_row(self.params, self.temp0 + i * self.temp_step, self.natural_drop)
        store = self._store if self._store is not None else _default_store
        if store is not None:
            store.save(self._key, i, row)
        return row

    def build_all(self):
        """Build (or load) every row now; return the number of rows."""
        for i in range(self.n_temp):
            self.row(i)
        return self.n_temp

    def _index(self, temperature):
        t = (temperature - self.temp0) / self.temp_step
        if not t <= self.n_temp - 1.0:  # also NaN
            raise RodTableError(f'temperature {temperature:.6g} degC beyond the conical rod '
                                f'table, which ends at {self.top:g} degC where nylon 6,6 '
                                'melts')
        t = min(max(t, 0.0), self.n_temp - 1.000001)
        i = int(t)
        return i, t - i

    def free_elongation(self, temperature):
        """Return y_free(T) (m), the unloaded elongation (linear between rows)."""
        i, w = self._index(temperature)
        a, b = self.row(i).free, self.row(i + 1).free
        return a + w * (b - a)

    def evaluate(self, elongation, temperature):
        """Return (F (N), dF/dy (N/m)) at elongation y (m) and temperature T (degC)."""
        i, w = self._index(temperature)
        ra, rb = self.row(i), self.row(i + 1)
        eta = elongation - (ra.free + w * (rb.free - ra.free))
        f_a, k_a = _row_value(ra, eta)
        f_b, k_b = _row_value(rb, eta)
        return f_a + w * (f_b - f_a), k_a + w * (k_b - k_a)

    def centreline(self, elongation, temperature):
        """Return the world-frame shape (3, SHAPE_POINTS) (m) at y (m) and T (degC).

        The nearest row's kept centrelines, interpolated linearly in y.
        """
        i, w = self._index(temperature)
        row = self.row(i + int(round(w)))
        drops = row.shape_drops
        k = int(np.clip(np.searchsorted(drops, elongation) - 1, 0, len(drops) - 2))
        u = min(max((elongation - drops[k]) / (drops[k + 1] - drops[k]), 0.0), 1.0)
        return (1.0 - u) * row.shapes[k] + u * row.shapes[k + 1]


def _row_value(row, eta):
    """Hermite value and slope of ``row`` at eta (m), extrapolated past its ends."""
    k, u, extra = hermite_cell(eta, row.eta0, row.eta_step, row.force.size)
    return cubic_hermite(row.force, row.slope, k, u, row.eta_step, extra)


class ConicalKinetostatics(KinetostaticModel):
    """The rod model 'rod' of a hanging conical TCA: f_rod(y, T) from ConicalTable.

    y (m) is the free end's drop below the clamp minus l*, the unloaded drop at
    ambient (``natural_length``); tension F (N) positive when the TCA pulls up on
    the hanging load. Rows are built on first use (module doc).
    """

    name = 'rod'

    def __init__(self, params):
        if params.coil.shape != 'conical':
            raise ValueError(f'coil.shape = {params.coil.shape!r}: ConicalKinetostatics '
                             'needs a conical TCA')
        super().__init__(params)
        self._table = ConicalTable(mechanical_params(params))
        self.natural_length = self._table.natural_drop

    @property
    def table(self):
        """Return the ConicalTable."""
        return self._table

    @property
    def temperature_range(self):
        """Return (first, last) temperature (degC) of the table's rows."""
        return self._table.temp0, self._table.top

    def tension(self, elongation, temperature, force_guess=None):
        """Return f_rod (N) at elongation y (m) and T (degC), Eq. (18).

        No fixed point is needed: the rows hold the moduli at F (Eq. (11)).
        """
        return self._table.evaluate(elongation, temperature)[0]

    def stiffness(self, elongation, temperature):
        """Return d f_rod / d y (N/m) at elongation (m) and temperature (degC)."""
        return self._table.evaluate(elongation, temperature)[1]

    def free_elongation(self, temperature):
        """Return the unloaded elongation y_free(T) (m)."""
        return self._table.free_elongation(temperature)

    def equilibrium_elongation(self, load, temperature, guess=None):
        """Return y (m) where f_rod(y, T) = load (N): the first crossing from no load.

        Scanned along the stretched rows from the unloaded state (the branch a
        weight hung on the unloaded coil reaches), then refined by bisection.
        ThreadBreakError above ``fiber.break_force``.
        """
        check_thread_strength(load, self.params.fiber)
        free = self.free_elongation(temperature)
        f0, k0 = self._table.evaluate(free, temperature)
        if load <= f0:  # pushed up: the linear extension of the table
            return free + (load - f0) / k0
        i, _ = self._table._index(temperature)
        span = max(self._table.row(i).eta_step, self._table.row(i + 1).eta_step) * (
            ETA_POINTS - 1)
        etas = np.linspace(0.0, span, 4 * (SHAPE_DROPS - 1) + 1)
        lo = free
        for eta in etas[1:]:
            hi = free + eta
            if self.tension(hi, temperature) >= load:
                break
            lo = hi
        else:
            return hi + (load - self.tension(hi, temperature)) / self.stiffness(hi, temperature)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if self.tension(mid, temperature) < load:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    def loaded_equilibrium(self, load, temperature, guess=None):
        """Return y (m) with f_rod(y, T) = load (N) (as equilibrium_elongation)."""
        return self.equilibrium_elongation(load, temperature, guess)

    def centreline(self, elongation, temperature):
        """Return the world-frame shape (3, SHAPE_POINTS) (m) at y (m), T (degC)."""
        return self._table.centreline(elongation, temperature)


def cached_conical_model(params):
    """Return the ConicalKinetostatics of ``params``, one per mechanical state."""
    return _conical_model_for(mechanical_params(params))


@functools.lru_cache(maxsize=4)
def _conical_model_for(params):
    return ConicalKinetostatics(params)
