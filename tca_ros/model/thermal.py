"""Lumped thermal model of the TCA, Eq. (1) of [1], with its thermal effects.

    m_t c_p dT/dt = (1 - eta) r P - h c_s A_0 (T - T_inf) phi(T) - Q_rad(T)   (1)
    tau dy/dt     = u - y          first-order lags (T_f behind T, the sensor)

As printed in [1] eta = 0, r = 1, phi = 1, Q_rad = 0. The effects of effects.py:
eta the 'power_loss' fraction, r the calibrated delivered-power ratio, phi =
(|T - T_inf| / dT_ref)^n the 'nonlinear_convection', Q_rad = eps sigma A_0
((T + 273.15)^4 - (T_inf + 273.15)^4) the 'radiation', T_inf with the
'ambient_offset'; the 'second_thermal_lag' T_f and the 'sensor_lag' are the lag.

This module is the one home of eq. (1): its coefficients (``HeatBalance``), its
right-hand side (``heat_rate``), its exact and Runge-Kutta steps and the lag.
Each function takes floats (one muscle) or NumPy arrays of shape (N,) (one
value per muscle) in one order of operations, so the scalar stepper
(dynamics.py via thermal_step.py), the rigs (rigs.py), the batch stepper
(toolkit/batch.py) and the linearisation (toolkit/state_equations.py) agree to
the bit; the quasi-static reduction (quasistatic_signals.py,
quasistatic_voltage.py, quasistatic_effects.py) takes the same steps on a
record's grid. The drive's dead time is in thermal_step.py.

References
----------
[1] J. Sun and J. Zhao, "Physics-based modeling of twisted-and-coiled actuators
    using Cosserat rod theory," IEEE Trans. Robot., 2022.
"""
from dataclasses import dataclass, field, fields
import math

import numpy as np

from tca_ros.model import effects as fx


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


def _exp(x):
    return np.exp(x) if isinstance(x, np.ndarray) else math.exp(x)


@dataclass(frozen=True)
class HeatBalance:
    """The coefficients of eq. (1): floats (one muscle) or arrays (N,), SI, degC.

    ``capacity`` m_t c_p (J/K), ``conductance`` h c_s A_0 (W/K), ``area`` A_0
    (m^2, radiating), ``ambient`` T_inf (degC, with the offset), ``gain`` (1 - eta) r
    (W heating per W logged), ``emissivity`` eps (-), ``exponent`` n (-),
    ``reference_dt`` dT_ref (K).
    """

    capacity: object
    conductance: object
    area: object
    ambient: object
    gain: object
    emissivity: object
    exponent: object
    reference_dt: object
    radiates: bool = field(init=False)  # any muscle radiates (eps > 0)
    convects_nonlinearly: bool = field(init=False)  # any muscle's n != 0
    linear: bool = field(init=False)  # eq. (1) linear in T for every muscle: exact steps

    def __post_init__(self):
        """Read the switches of the nonlinear terms once (they are fixed)."""
        radiates = bool(np.any(np.asarray(self.emissivity) != 0.0))
        nonlinear = bool(np.any(np.asarray(self.exponent) != 0.0))
        object.__setattr__(self, 'radiates', radiates)
        object.__setattr__(self, 'convects_nonlinearly', nonlinear)
        object.__setattr__(self, 'linear', not (radiates or nonlinear))

    @classmethod
    def of(cls, params):
        """Return the HeatBalance (floats) of one TcaParams, its thermal effects included."""
        e, t = params.effects, params.thermal
        return cls(capacity=heat_capacity(params.fiber),
                   conductance=thermal_conductance(params.fiber, t),
                   area=surface_area(params.fiber), ambient=fx.true_ambient(t, e),
                   gain=fx.heating_power(1.0, e, t.delivered_power_ratio),
                   emissivity=e.emissivity, exponent=e.convection_exponent,
                   reference_dt=e.convection_reference_dt)

    @classmethod
    def nominal(cls, fiber, thermal):
        """Return the HeatBalance of eq. (1) as printed (no effects) for fiber, thermal."""
        return cls(capacity=heat_capacity(fiber), conductance=thermal_conductance(fiber, thermal),
                   area=surface_area(fiber), ambient=thermal.ambient_temperature, gain=1.0,
                   emissivity=0.0, exponent=0.0, reference_dt=1.0)

    @classmethod
    def gather(cls, params_list):
        """Return the HeatBalance of N muscles: each coefficient an array (N,)."""
        each = [cls.of(p) for p in params_list]
        names = [f.name for f in fields(cls) if f.init]
        return cls(**{name: np.array([float(getattr(b, name)) for b in each])
                      for name in names})


def heat_loss(temp, hb):
    """Return the heat lost (W) at T (degC): convection phi(T) and radiation of eq. (1)."""
    loss = hb.conductance * (temp - hb.ambient)
    if hb.convects_nonlinearly:
        loss = loss * (abs(temp - hb.ambient) / hb.reference_dt) ** hb.exponent
    if hb.radiates:
        loss = loss + hb.emissivity * fx.STEFAN_BOLTZMANN * hb.area * (
            (temp + fx.KELVIN) ** 4 - (hb.ambient + fx.KELVIN) ** 4)
    return loss


def heat_rate(temp, power, hb):
    """Return dT/dt (K/s) of eq. (1) at T (degC) under the logged power P (W)."""
    return (hb.gain * power - heat_loss(temp, hb)) / hb.capacity


def heat_loss_slope(temp, hb):
    """Return an upper bound of d(loss)/dT (W/K) at T (degC): (1 + n) h c_s A_0 phi + 4 eps.

    The radiation term is taken at |T| + 273.15 K (cubed), the RK4 limit's bound.
    """
    convection = hb.conductance * (1.0 + hb.exponent)
    if hb.convects_nonlinearly:
        convection = convection * (abs(temp - hb.ambient) / hb.reference_dt) ** hb.exponent
    return convection + 4.0 * hb.emissivity * fx.STEFAN_BOLTZMANN * hb.area * (
        abs(temp) + fx.KELVIN) ** 3


def steady_temperature(power, hb):
    """Return T (degC) where the linear eq. (1) rests under the logged power P (W).

    T_inf + (1 - eta) r P / (h c_s A_0): the exact step's target (decay 0).
    """
    return heat_step_exact(hb.ambient, power, 0.0, hb)


def heat_decay(h, hb):
    """Return exp(-h h c_s A_0 / (m_t c_p)) (-): the linear eq. (1)'s decay over h (s)."""
    return _exp(-h * hb.conductance / hb.capacity)


def heat_step_exact(temp, power, decay, hb):
    """Return T (degC) after a step of the linear eq. (1), power P (W) held.

    ``decay`` is ``heat_decay`` of the step (kept by a stepper while h is).
    """
    target = hb.ambient + hb.gain * power / hb.conductance  # degC, where it rests
    return target + (temp - target) * decay


def heat_step_rk4(temp, power, h, hb):
    """Return T (degC) after h (s) of eq. (1), power P (W) held: classical Runge-Kutta."""
    k1 = heat_rate(temp, power, hb)
    k2 = heat_rate(temp + 0.5 * h * k1, power, hb)
    k3 = heat_rate(temp + 0.5 * h * k2, power, hb)
    k4 = heat_rate(temp + h * k3, power, hb)
    return temp + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0


def heat_march_rk4(temp, powers, steps, hb):
    """Return T (degC) after each step of eq. (1) from ``temp`` (degC), as a list.

    heat_step_rk4 step after step: the logged power ``powers[j]`` (W) held over
    ``steps[j]`` (s), sequences of floats (the quasi-static reduction's march on a
    record's own grid, quasistatic_effects.py).
    """
    out = []
    for power, h in zip(powers, steps):
        temp = heat_step_rk4(temp, power, h, hb)
        out.append(temp)
    return out


def lag_rate(value, target, tau):
    """Return dy/dt (unit/s) of the first-order lag tau dy/dt = u - y (tau > 0 s)."""
    return (target - value) / tau


def lag_step(value, target, h, tau):
    """Return y after h (s) of the lag tau dy/dt = u - y, u = ``target`` held (exact).

    The 'second_thermal_lag' (y = T_f, u = T) and the 'sensor_lag' (y the
    reading, u the contraction); y = u where tau <= 0 (the lag off).
    """
    if isinstance(tau, np.ndarray):
        on = tau > 0.0
        return np.where(on, target + (value - target) * np.exp(-h / np.where(on, tau, 1.0)),
                        target)
    if tau <= 0.0:
        return target
    return target + (value - target) * math.exp(-h / tau)


def thermal_rate(temp, power, fiber, thermal):
    """Return dT/dt (K/s) of Eq. (1) as printed at temperature ``temp`` (degC), power (W)."""
    return heat_rate(temp, power, HeatBalance.nominal(fiber, thermal))


def steady_state_temperature(power, fiber, thermal):
    """Return the equilibrium temperature (degC) of Eq. (1) under constant power (W)."""
    return steady_temperature(power, HeatBalance.nominal(fiber, thermal))


def step_response(t, power, fiber, thermal):
    """Return T(t) (degC) for a power step (W) applied at t = 0 from ambient.

    The closed-form solution of Eq. (1): T_inf + P / (h c_s A_0) (1 - exp(-t / tau)).
    """
    tau = thermal_time_constant(fiber, thermal)
    rise = power / thermal_conductance(fiber, thermal)
    return thermal.ambient_temperature + rise * (1.0 - _exp_neg(t, tau))


def exact_temperature_update(temp, power, dt, fiber, thermal):
    """Return T(t + dt) (degC) for constant power P (W) over dt (s), exact for Eq. (1)."""
    decay = math.exp(-dt / thermal_time_constant(fiber, thermal))
    return heat_step_exact(temp, power, decay, HeatBalance.nominal(fiber, thermal))


def _exp_neg(t, tau):
    return np.exp(-np.asarray(t, dtype=float) / tau)
