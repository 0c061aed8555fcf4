"""The quasi-static TCA on a rig: clamped (isometric) or on a series spring.

With the mechanical time scales far below the thermal one (quasistatic.py), a
muscle clamped at the length it had under its pretension F_0 at ambient pulls
the force at which the static equilibrium at its actuating temperature T_a(t)
has that length (rig equation R4 of docs/rigs.md without its dynamics):

    F(t) = f_rod(q_0, T_a(t)),    q_0 = y_eq(F_0, T_inf)  (or the contact stop)

On a series spring k_s pulling F_0 at q_0 the end sits where f_rod(q, T_a) =
F_0 + k_s (q_0 - q) (R2-R3). f_rod is the configured kinetostatic model's tension,
solved on a temperature grid and interpolated by a C2 spline. Creep, friction and
hysteresis of the dead-weight reduction are not applied.
"""
import math

import numpy as np
from scipy.interpolate import CubicSpline

from tca_ros.model.limits import check_thread_strength
from tca_ros.model.quasistatic_signals import actuating_temperature, thermal_response

TEMPERATURE_STEP = 2.0  # K between the grid points of f_rod(q_0, T)


def _temperatures(plant, time, power):
    """Return (T of eq. (1), the actuating T_a, a grid covering T_a and ambient) (degC)."""
    params = plant.params
    time = np.asarray(time, dtype=float)
    temperature = thermal_response(time, np.asarray(power, dtype=float), params)
    actuating = actuating_temperature(time, temperature, params)
    low = min(float(np.min(actuating)), plant.ambient)
    high = max(float(np.max(actuating)), plant.ambient)
    grid = np.arange(math.floor(low / TEMPERATURE_STEP) - 1,
                     math.ceil(high / TEMPERATURE_STEP) + 2) * TEMPERATURE_STEP
    return temperature, actuating, grid


def isometric_force(plant, time, power, pretension):
    """Return the clamped muscle's force F(t) (N) and temperature (degC) under power (W).

    ``plant``: a QuasiStaticPlant (its kinetostatics and params); ``pretension``:
    F_0 (N) under which the length is clamped at ambient. Raises ThreadBreakError
    (a ValueError) when the force passes fiber.break_force.
    """
    params = plant.params
    temperature, actuating, grid = _temperatures(plant, time, power)
    clamp = plant.reference_elongation(float(pretension))
    tension = plant.kinetostatics.tension
    forces = np.array([tension(clamp, float(t)) for t in grid])
    force = CubicSpline(grid, forces)(actuating)
    check_thread_strength(float(np.max(force)), params.fiber)
    return force, temperature


def spring_equilibrium(plant, time, power, pretension, stiffness):
    """Return (contraction (m), force (N), temperature (degC)) of the muscle on a spring.

    The spring rig (docs/rigs.md, R2-R3) without its dynamics: the end sits where
    f_rod(q, T_a) = F_0 + k_s (q_0 - q), q_0 the equilibrium under F_0 at ambient,
    ``stiffness`` k_s (N/m), ``pretension`` F_0 (N). Solved by Brent's method on a
    temperature grid and interpolated by a C2 spline; the contraction is q_0 - q.
    """
    from scipy.optimize import brentq
    params = plant.params
    temperature, actuating, grid = _temperatures(plant, time, power)
    q0 = plant.reference_elongation(float(pretension))
    tension = plant.kinetostatics.tension
    span = 0.05 * plant.kinetostatics.natural_length + 1e-4

    def residual(q, temp):
        return tension(q, temp) - pretension - stiffness * (q0 - q)

    elongations = []
    for temp in grid:
        lo, hi = q0 - span, q0 + span
        for _ in range(40):  # widen until the root is bracketed (f_rod rises with q)
            if residual(lo, temp) < 0.0 < residual(hi, temp):
                break
            lo, hi = q0 - 2.0 * (q0 - lo), q0 + 2.0 * (hi - q0)
        else:
            raise ArithmeticError(f'spring rig: no equilibrium at {temp:g} degC')
        elongations.append(brentq(residual, lo, hi, args=(float(temp),), xtol=1e-12))
    q = CubicSpline(grid, np.array(elongations))(actuating)
    force = pretension + stiffness * (q0 - q)
    check_thread_strength(float(np.max(force)), params.fiber)
    return q0 - q, force, temperature
