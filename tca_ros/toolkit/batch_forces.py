"""f_rod of Eq. (18) for N muscles at once: CST (29) and the rod model's table.

NumPy forms of tca_ros.model.kinetostatics.CstModel and
tca_ros.model.rod_model.RodKinetostatics (its rod_table.ForceTable), one value
per muscle; parameters are arrays of shape (N,) gathered once from each
muscle's TcaParams. Each function
evaluates the same relation as its scalar original (equation numbers of [1]);
test/test_batch.py checks them against it.

References
----------
[1] J. Sun and J. Zhao, IEEE Trans. Robot., 2022.
"""
import math

import numpy as np

from tca_ros.model.fiber import plateau_quadratic
from tca_ros.model.kinetostatics import natural_length
from tca_ros.model.rod_model import cached_rod_model
from tca_ros.model.rod_table import cubic_hermite, RodTableError


class MuscleArrays:
    """The parameters f_rod reads, one array of shape (N,) per scalar (SI, rad, degC)."""

    def __init__(self, params_list):
        def gather(getter):
            return np.array([float(getter(p)) for p in params_list])
        self.n = len(params_list)
        self.fiber_length = gather(lambda p: p.fiber.length)  # l_t, m
        self.fiber_radius = gather(lambda p: p.fiber.radius)  # r_t*, m
        self.natural_length = gather(lambda p: natural_length(p.fiber, p.coil))  # l*, m
        self.coil_radius = gather(lambda p: p.coil.radius)  # r*, m
        self.cos_pitch = gather(lambda p: math.cos(p.coil.pitch_angle))  # cos alpha*
        self.ambient = gather(lambda p: p.thermal.ambient_temperature)  # T0, degC
        self.gamma = [gather(lambda p, i=i: p.fiber.gamma_coefficients[i]) for i in range(3)]
        self.plateau = gather(lambda p: p.fiber.expansion_plateau_temperature)  # T_p, degC
        self.twist = gather(lambda p: p.fiber.untwist_gain * p.fiber.inserted_twist)  # rad/m
        m = [p.moduli for p in params_list]
        self.constant = np.array([x.constant for x in m])
        self.heated = np.array([p.fiber.heated_radius_in_section and not p.moduli.constant
                                for p in params_list])
        self.youngs = np.array([x.youngs_modulus for x in m])  # E0, Pa
        self.shear = np.array([x.shear_modulus for x in m])  # G0, Pa
        self.fiber_modulus = np.array([x.fiber_modulus for x in m])  # E_f0, Pa
        self.softening = np.array([x.fiber_softening for x in m])  # k_T, Pa/K
        self.extra_softening = gather(lambda p: p.effects.extra_softening)  # Pa/K
        self.mu = [np.array([x.load_coefficients[i] for x in m]) for i in range(3)]
        self.max_tau = np.array([x.max_torsion_strain for x in m])  # 1/m
        self.floor = np.array([x.fiber_modulus_floor for x in m])  # -
        polar = math.pi * self.fiber_radius ** 4 / 2.0  # J of the unheated fiber, m^4
        self.tau_per_newton = self.fiber_radius * self.cos_pitch / (self.shear * polar)


def radius_ratio(temp, c):
    """Return Gamma(T) (-) of Eq. (2) per muscle; T in degC, linear above T_p (G50)."""
    return plateau_quadratic(temp, c.gamma, c.plateau)


def unit_untwist(temp, c):
    """Return Delta theta_bar^h (rad/m), Eq. (4): theta* (Gamma(T0)/Gamma(T) - 1)."""
    return c.twist * (radius_ratio(c.ambient, c) / radius_ratio(temp, c) - 1.0)


def modulus_ratio(temp, tension, c):
    """Return E_f / E_f0 (-) of Eq. (11) at T (degC) and tension F (N), floored.

        tau = F r_t cos(alpha*) / (G0 J) in [0, tau_max],
        E_f = E_f0 - (k_T lambda(tau) + extra) (T - T0)
    """
    tau = np.clip(tension * c.tau_per_newton, 0.0, c.max_tau)
    lam = (c.mu[0] * tau + c.mu[1]) * tau + c.mu[2]
    softening = c.softening * lam + c.extra_softening
    ratio = np.maximum(1.0 - softening * (temp - c.ambient) / c.fiber_modulus, c.floor)
    return np.where(c.constant, 1.0, ratio)


def cst_tension(elongation, temp, tension, c):
    """Return f_rod (N) of CST, Eq. (29), with the moduli at ``tension`` (N), Eq. (11).

        F = (y - A_cst Delta theta_bar^h) / (1/K_cst),
        1/K = l_t (r^2 cos^2 a / GJ + r^2 sin^2 a / EI + cos^2 a / GA + sin^2 a / EA),
        A_cst = l_t r cos a,  sin a = (l* + y) / l_t  (Eq. (26)),
        r = r* cos a / cos a*  (Eq. (24), as kinetostatics.CstModel)
    """
    sin_a = np.clip((c.natural_length + elongation) / c.fiber_length, -1.0, 1.0)
    s2 = sin_a * sin_a
    c2 = 1.0 - s2
    ratio = modulus_ratio(temp, tension, c)
    r = np.where(c.heated, c.fiber_radius * radius_ratio(temp, c) / radius_ratio(c.ambient, c),
                 c.fiber_radius)
    area = math.pi * r * r
    second_moment = area * r * r / 4.0
    e = c.youngs * ratio
    g = c.shear * ratio
    coil_radius = c.coil_radius * np.sqrt(c2) / c.cos_pitch  # Eq. (24), fixed coil count
    r2 = coil_radius * coil_radius
    compliance = c.fiber_length * (r2 * c2 / (2.0 * g * second_moment)
                                   + r2 * s2 / (e * second_moment)
                                   + c2 / (g * area) + s2 / (e * area))
    a_cst = c.fiber_length * coil_radius * np.sqrt(c2)
    return (elongation - a_cst * unit_untwist(temp, c)) / compliance


class RodTables:
    """The rod model's f_rod tables (rod_table.ForceTable) of N muscles, stacked.

    Muscles with the same mechanical parameters share one table; each muscle
    indexes its own by offsets into flat arrays. Evaluation follows
    ForceTable.evaluate: linear in T between two rows, cubic Hermite along each row
    in eta = y - y_free(T) on that row's own eta grid, linear extrapolation with the
    row's edge stiffness beyond it. Below the first row T is clamped; above the last
    one RodTableError is raised, as the scalar model does.
    """

    def __init__(self, params_list):
        models, owner, tables = {}, [], []
        for p in params_list:
            model = cached_rod_model(p)
            if id(model) not in models:
                models[id(model)] = len(tables)
                tables.append(model._table)
            owner.append(models[id(model)])
        owner = np.array(owner)
        self.owner = owner  # index of each muscle's table
        self.tables = tables  # the scalar ForceTables, for their error messages
        starts = np.cumsum([0] + [t.n_temp * t.n_eta for t in tables])[:-1]
        row_starts = np.cumsum([0] + [t.n_temp for t in tables])[:-1]
        self.n_tables = len(tables)
        self.force = np.concatenate([np.asarray(t.force) for t in tables])  # N
        self.slope = np.concatenate([np.asarray(t.slope) for t in tables])  # N/m
        # per temperature row, flat over all tables
        self.free = np.concatenate([np.asarray(t.free) for t in tables])  # m
        self.eta0 = np.concatenate([np.asarray(t.eta0) for t in tables])  # m
        self.eta_step = np.concatenate([np.asarray(t.eta_step) for t in tables])  # m

        def per_muscle(name):
            return np.array([getattr(t, name) for t in tables], dtype=float)[owner]
        self.temp0, self.temp_step = per_muscle('temp0'), per_muscle('temp_step')
        self.n_temp = per_muscle('n_temp').astype(np.int64)
        self.n_eta = per_muscle('n_eta').astype(np.int64)
        self.start = starts[owner]
        self.row_start = row_starts[owner]

    def _row(self, r, eta):
        """Hermite value (N) and slope (N/m) of flat row r at eta (m), extrapolated."""
        step = self.eta_step[r]
        x = (eta - self.eta0[r]) / step
        last = self.n_eta - 1
        below, above = x < 0.0, x >= last
        k = np.where(below, 0, np.where(above, last - 1,
                                        np.clip(x, 0, last - 1).astype(np.int64)))
        u = np.where(below, 0.0, np.where(above, 1.0, x - k))
        extra = np.where(below, x * step, np.where(above, (x - last) * step, 0.0))
        j = self.start + (r - self.row_start) * self.n_eta + k
        return cubic_hermite(self.force, self.slope, j, u, step, extra)

    def evaluate(self, elongation, temp):
        """Return (f_rod (N), d f_rod / d y (N/m)) at y (m) and T (degC) per muscle."""
        t = (temp - self.temp0) / self.temp_step
        beyond = ~(t <= self.n_temp - 1.0)  # also NaN
        if beyond.any():
            k = int(np.argmax(beyond))
            table = self.tables[self.owner[k]]
            raise RodTableError(f'muscle {k}: temperature {temp[k]:.6g} degC beyond the rod '
                                f'table, which ends at {table.top:g} degC')
        t = np.minimum(np.maximum(t, 0.0), self.n_temp - 1.000001)
        i = t.astype(np.int64)
        w = t - i
        r = self.row_start + i
        eta = elongation - (self.free[r] + w * (self.free[r + 1] - self.free[r]))
        f_a, k_a = self._row(r, eta)
        f_b, k_b = self._row(r + 1, eta)
        return f_a + w * (f_b - f_a), k_a + w * (k_b - k_a)
