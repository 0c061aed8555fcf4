"""The quasi-static TCA clamped at its length: the force of an isometric rig.

With the mechanical time scales far below the thermal one (quasistatic.py), a
muscle clamped at the length it had under its pretension F_0 at ambient pulls
the force at which the static equilibrium at its actuating temperature T_a(t)
has that length (rig equation R4 of docs/rigs.md without its dynamics):

    F(t) = f_rod(q_0, T_a(t)),    q_0 = y_eq(F_0, T_inf)  (or the contact stop)

f_rod is the configured kinetostatic model's tension, solved on a temperature
grid and interpolated by a C2 spline. Creep, friction and hysteresis of the
dead-weight reduction are not applied.
"""
import math

import numpy as np
from scipy.interpolate import CubicSpline

from tca_ros.model.quasistatic_signals import actuating_temperature, thermal_response

TEMPERATURE_STEP = 2.0  # K between the grid points of f_rod(q_0, T)


def isometric_force(plant, time, power, pretension):
    """Return the clamped muscle's force F(t) (N) and temperature (degC) under power (W).

    ``plant``: a QuasiStaticPlant (its kinetostatics and params); ``pretension``:
    F_0 (N) under which the length is clamped at ambient. Raises ThreadBreakError
    (a ValueError) when the force passes fiber.break_force.
    """
    from tca_ros.model.limits import check_thread_strength
    params = plant.params
    time = np.asarray(time, dtype=float)
    temperature = thermal_response(time, np.asarray(power, dtype=float), params)
    actuating = actuating_temperature(time, temperature, params)
    low = min(float(np.min(actuating)), plant.ambient)
    high = max(float(np.max(actuating)), plant.ambient)
    first = math.floor(low / TEMPERATURE_STEP) - 1
    last = math.ceil(high / TEMPERATURE_STEP) + 1
    grid = np.arange(first, last + 1) * TEMPERATURE_STEP
    clamp = plant.reference_elongation(float(pretension))
    tension = plant.kinetostatics.tension
    forces = np.array([tension(clamp, float(t)) for t in grid])
    force = CubicSpline(grid, forces)(actuating)
    check_thread_strength(float(np.max(force)), params.fiber)
    return force, temperature
