"""Temperature- and load-dependent moduli of the twisted fiber, Eqs. (8)-(11) of [1].

Decisions (docs/decisions.md): eqs. (9) and (10) are linear in E_f, so both are
scaled to the measured E0 = 1.2 GPa and G0 = 0.22 GPa at T0 without load and then
follow E_f(T, F) / E_f0 (D2); the torsional strain of eq. (11) is
tau = F r_t cos(alpha*) / (G0 J), clipped to the calibrated range, and E_f is
floored (D3); the section uses the heated radius when switched on (D4).
"""
from dataclasses import dataclass
import math

import numpy as np

from tca_ros.model.fiber import heated_fiber_radius


@dataclass(slots=True)  # built once per f_rod evaluation: a frozen one costs twice as much
class Section:
    """Cross-section stiffnesses of Eq. (8): EI, GJ (N m^2) and GA, EA (N)."""

    EI: float
    GJ: float
    GA: float
    EA: float
    E: float
    G: float
    radius: float


def youngs_modulus_yarn(fiber_modulus, volume_fraction, bias_angle):
    """Return E (Pa) of a twisted yarn from yarn mechanics, Eq. (9) as printed.

    E = 3 V_f E_f / 4 (1 + cos^2 a_t) / (1 + cos a_t + cos^2 a_t); a_t in rad.
    """
    c = math.cos(bias_angle)
    return 0.75 * volume_fraction * fiber_modulus * (1.0 + c * c) / (1.0 + c + c * c)


def shear_modulus_yarn(fiber_modulus, volume_fraction, bias_angle):
    """Return G (Pa) of a twisted yarn from yarn mechanics, Eq. (10) as printed."""
    a = bias_angle
    c, s = math.cos(a), math.sin(a)
    w = a / 2.0 - math.sin(2.0 * a) / 4.0
    denominator = (math.pi * (1.0 - c) * s ** 3 / (6.0 * w * w)
                   + 8.0 * s ** 3 / (3.0 * math.pi * (1.0 - c) * (c + 1.0) ** 2)
                   + math.pi * (4.0 - 3.0 * c - c ** 3) / (6.0 * w * (c + 1.0)))
    return fiber_modulus * volume_fraction / denominator


def load_torsion_strain(tension, fiber, coil, moduli):
    """Return tau = F r_t cos(alpha*) / (G0 J) (1/m) of Eq. (11), clipped to its range.

    ``tension`` is the axial force F (N, tensile positive) on the TCA, a float or an
    ndarray (then so is the result).
    """
    polar = math.pi * fiber.radius ** 4 / 2.0
    tau = tension * fiber.radius * math.cos(coil.pitch_angle) / (moduli.shear_modulus * polar)
    if isinstance(tau, np.ndarray):  # a row of tensions (the rod table)
        return np.clip(tau, 0.0, moduli.max_torsion_strain)
    return min(max(tau, 0.0), moduli.max_torsion_strain)


def load_factor(tau, moduli):
    """Return lambda(tau) = mu2 tau^2 + mu1 tau + mu0 (-) of Eq. (11)."""
    mu2, mu1, mu0 = moduli.load_coefficients
    return (mu2 * tau + mu1) * tau + mu0


def fiber_modulus(temp, tension, params):
    """Return the monofilament modulus E_f (Pa), Eq. (11).

        E_f = E_f0 - k_T (T - T0) lambda(tau)

    with k_T = 1.1 MPa/K; plus the optional ``effects.extra_softening`` (Pa/K), the
    'modulus_softening' extension. Floored at ``moduli.fiber_modulus_floor`` E_f0.
    """
    m = params.moduli
    dtemp = temp - params.thermal.ambient_temperature
    lam = load_factor(load_torsion_strain(tension, params.fiber, params.coil, m), m)
    softening = m.fiber_softening * lam + params.effects.extra_softening
    modulus = m.fiber_modulus - softening * dtemp
    if isinstance(modulus, np.ndarray):  # a row of tensions (the rod table)
        return np.maximum(modulus, m.fiber_modulus_floor * m.fiber_modulus)
    return max(modulus, m.fiber_modulus_floor * m.fiber_modulus)


def moduli_at(temp, tension, params):
    """Return (E, G) (Pa) at temperature ``temp`` (degC) and tension (N), Eqs. (9)-(11).

    Eqs. (9) and (10) are linear in E_f, so scaling them to the measured
    ``moduli.youngs_modulus`` and ``moduli.shear_modulus`` at (T0, no load) gives
    E = E0 E_f / E_f0 and G = G0 E_f / E_f0 (docs/decisions.md, D2; the scaling is
    checked against the printed formulas in test_moduli.py).
    """
    m = params.moduli
    if m.constant:
        return m.youngs_modulus, m.shear_modulus
    ratio = fiber_modulus(temp, tension, params) / m.fiber_modulus
    return m.youngs_modulus * ratio, m.shear_modulus * ratio


def section_radius(temp, params):
    """Return the fiber radius (m) used in A, I, J: heated (Eq. (2)) or r_t*."""
    if params.fiber.heated_radius_in_section and not params.moduli.constant:
        return heated_fiber_radius(temp, params.fiber, params.thermal.ambient_temperature)
    return params.fiber.radius


def section_stiffness(temp, tension, params):
    """Return the Section of Eq. (8) at temperature (degC) and tension (N).

    K_bt = diag(EI, EI, GJ), K_se = diag(GA, GA, EA), I = pi r^4 / 4, J = 2 I.
    ``tension`` may be an ndarray: the stiffnesses are then arrays of its shape
    (the moduli depend on F, Eq. (11)).
    """
    e, g = moduli_at(temp, tension, params)
    r = section_radius(temp, params)
    area = math.pi * r * r
    second_moment = area * r * r / 4.0
    return Section(EI=e * second_moment, GJ=g * 2.0 * second_moment, GA=g * area,
                   EA=e * area, E=e, G=g, radius=r)
