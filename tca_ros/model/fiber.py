"""Fiber actuation model: radial expansion and untwist, Eqs. (2)-(4) of [1].

Convention (docs/decisions.md, D1): Gamma(T) = c2 T^2 + c1 T + c0 with
[c2, c1, c0] = [3.54e-6, -6.705e-5, 1.0017] (the text swaps c0 and c2), renormalised
to Gamma(T0) so that the untwist is zero at the ambient temperature and negative
when hot (the fiber untwists, the right-handed coil contracts).
"""
import numpy as np


def radius_ratio(temp, fiber):
    """Return Gamma(T) = r_t^h / r_t^* (-), the polynomial fit of Eq. (2); T in degC.

    Up to ``fiber.expansion_plateau_temperature`` T_p (degC) the paper's quadratic;
    above it the radial expansion coefficient alpha_perp = dGamma/dT of eq. (2) holds
    its value at T_p, so Gamma goes on linearly (nylon's rubbery plateau past its
    glass transition, docs/decisions.md G50). T_p at the melt: the paper's law.
    """
    return plateau_quadratic(temp, fiber.gamma_coefficients,
                             fiber.expansion_plateau_temperature)


def plateau_quadratic(temp, coefficients, top):
    """Return c2 T^2 + c1 T + c0 (-) up to ``top`` (degC), linear with its slope above.

    ``temp`` (degC) and the coefficients [c2, c1, c0] (1/degC^2, 1/degC, -) and
    ``top`` may be scalars or arrays (one entry per muscle in the batch stepper).
    """
    c2, c1, c0 = coefficients
    if np.ndim(temp) == 0 and np.ndim(top) == 0 and temp <= top:
        return (c2 * temp + c1) * temp + c0
    t = np.minimum(temp, top)
    return (c2 * t + c1) * t + c0 + (2.0 * c2 * t + c1) * (temp - t)


def heated_fiber_radius(temp, fiber, ambient):
    """Return the heated fiber radius r_t^h (m), Eq. (2), renormalised to Gamma(T0)."""
    return fiber.radius * radius_ratio(temp, fiber) / radius_ratio(ambient, fiber)


def unit_untwist(temp, fiber, ambient):
    """Return the untwist per length Delta theta_bar^h (rad/m), Eq. (4).

        Delta theta_bar^h = theta_bar* (Gamma(T0) / Gamma(T) - 1)

    Zero at T0 = ``ambient`` (degC) and negative when hotter. Multiplied by
    ``fiber.untwist_gain`` (1 for the paper's law; a calibrated actuation gain).
    """
    ratio = radius_ratio(ambient, fiber) / radius_ratio(temp, fiber)
    return fiber.untwist_gain * fiber.inserted_twist * (ratio - 1.0)
