"""Lumped thermal model of the TCA, Eq. (1) of [1].

    m_t c_p dT/dt = -h c_s A_0 (T - T_inf) + P_in

References
----------
[1] J. Sun and J. Zhao, "Physics-based modeling of twisted-and-coiled actuators
    using Cosserat rod theory," IEEE Trans. Robot., 2022.
"""
import math


def fiber_mass(fiber):
    """Return the twisted fiber's mass m_t = rho pi r_t^2 l_t (kg)."""
    return fiber.density * math.pi * fiber.radius ** 2 * fiber.length


def heat_capacity(fiber):
    """Return the lumped heat capacity m_t c_p (J/K), Eq. (1)."""
    return fiber_mass(fiber) * fiber.specific_heat


def surface_area(fiber):
    """Return the smooth surface area A_0 = 2 pi r_t l_t (m^2), Eq. (1)."""
    return 2.0 * math.pi * fiber.radius * fiber.length


def thermal_conductance(fiber, thermal):
    """Return the convective conductance h c_s A_0 (W/K), Eq. (1)."""
    return thermal.convection_coefficient * thermal.surface_factor * surface_area(fiber)


def thermal_time_constant(fiber, thermal):
    """Return tau = m_t c_p / (h c_s A_0) (s) of Eq. (1)."""
    return heat_capacity(fiber) / thermal_conductance(fiber, thermal)


def thermal_rate(temp, power, fiber, thermal):
    """Return dT/dt (K/s) of Eq. (1) for temperature ``temp`` (degC) and power (W)."""
    loss = thermal_conductance(fiber, thermal) * (temp - thermal.ambient_temperature)
    return (power - loss) / heat_capacity(fiber)


def steady_state_temperature(power, fiber, thermal):
    """Return the equilibrium temperature (degC) of Eq. (1) under constant power (W)."""
    return thermal.ambient_temperature + power / thermal_conductance(fiber, thermal)


def step_response(t, power, fiber, thermal):
    """Return T(t) (degC) for a power step (W) applied at t = 0 from ambient.

    The closed-form solution of Eq. (1): T_inf + P / (h c_s A_0) (1 - exp(-t / tau)).
    """
    tau = thermal_time_constant(fiber, thermal)
    rise = power / thermal_conductance(fiber, thermal)
    return thermal.ambient_temperature + rise * (1.0 - _exp_neg(t, tau))


def exact_temperature_update(temp, power, dt, fiber, thermal):
    """Return T(t + dt) (degC) for constant power P (W) over dt (s), exact for Eq. (1)."""
    target = steady_state_temperature(power, fiber, thermal)
    return target + (temp - target) * math.exp(-dt / thermal_time_constant(fiber, thermal))


def _exp_neg(t, tau):
    import numpy as np
    return np.exp(-np.asarray(t, dtype=float) / tau)
