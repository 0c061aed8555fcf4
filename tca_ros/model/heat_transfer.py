"""Heat loss of a thin heated thread from textbook correlations: the prior of eq. (1)'s loss.

Eq. (1) lumps the loss into h c_s A_0 (T - T_inf). A maker does not measure h;
these relations estimate the loss conductance of a thin cylinder in still air
from its diameter, so that a calibration can tell a physical heat loss from one
that stands in for something else (docs/calibration.md, "Physical priors").

References
----------
[1] V. T. Morgan, "The overall convective heat transfer from smooth circular
    cylinders," Adv. Heat Transfer 11, 199-264, 1975 (Nu = C Ra^n, Table of C, n
    for 1e-10 <= Ra <= 1e12).
[2] F. P. Incropera, D. P. DeWitt, Fundamentals of Heat and Mass Transfer, 6th ed.,
    Table A.4 (air at 300-350 K) and eq. (1.9) (linearised radiation).
"""
import math

from tca_ros.model.effects import KELVIN, STEFAN_BOLTZMANN
from tca_ros.model.params_schema import GRAVITY

REFERENCE_RISE_K = 50.0  # K, surface temperature rise at which a still-air loss is quoted
STILL_AIR_EMISSIVITY = 0.5  # -, between polished silver (0.05) and nylon (0.9): unknown
#: Morgan's [1] (Ra upper bound, C, n) for a horizontal cylinder, ascending in Ra
MORGAN_RANGES = ((1e-2, 0.675, 0.058), (1e2, 1.02, 0.148), (1e4, 0.850, 0.188),
                 (1e7, 0.480, 0.250), (1e12, 0.125, 0.333))


def air_properties(film_temp):
    """Return (k W/(m K), nu m^2/s, alpha m^2/s) of still air at ``film_temp`` (degC) [2].

    Linear in temperature through the tabulated values at 300 and 350 K.
    """
    s = (film_temp + KELVIN - 300.0) / 50.0
    k = 0.0263 + s * (0.0300 - 0.0263)
    nu = 15.89e-6 + s * (20.92e-6 - 15.89e-6)
    alpha = 22.5e-6 + s * (29.9e-6 - 22.5e-6)
    return k, nu, alpha


def rayleigh_number(diameter, temp_difference, ambient):
    """Return Ra_d = g beta dT d^3 / (nu alpha) (-) of a cylinder (m) hotter by dT (K)."""
    film = ambient + 0.5 * temp_difference
    _, nu, alpha = air_properties(film)
    beta = 1.0 / (film + KELVIN)  # 1/K, ideal gas
    return GRAVITY * beta * abs(temp_difference) * diameter ** 3 / (nu * alpha)


def natural_convection_coefficient(diameter, temp_difference, ambient):
    """Return h (W/(m^2 K)) of a thin cylinder in still air, Morgan's correlation [1].

    Nu_d = C Ra_d^n with (C, n) of the Ra range; ``diameter`` in m, the surface
    ``temp_difference`` above ``ambient`` (degC) in K.
    """
    ra = max(rayleigh_number(diameter, temp_difference, ambient), 1e-10)
    c, n = next((c, n) for top, c, n in MORGAN_RANGES if ra <= top) \
        if ra <= MORGAN_RANGES[-1][0] else MORGAN_RANGES[-1][1:]
    k, _, _ = air_properties(ambient + 0.5 * temp_difference)
    return c * ra ** n * k / diameter


def radiation_coefficient(emissivity, temp_difference, ambient):
    """Return the linearised radiation coefficient 4 eps sigma T_m^3 (W/(m^2 K)) [2].

    T_m (K) is the mean of the surface (``ambient`` + ``temp_difference``) and ambient.
    """
    mean = ambient + 0.5 * temp_difference + KELVIN
    return 4.0 * emissivity * STEFAN_BOLTZMANN * mean ** 3


def still_air_loss_exponent(diameter, ambient, emissivity=STILL_AIR_EMISSIVITY,
                            rises=(25.0, 100.0)):
    """Return n (-) of the loss coefficient's growth h(dT) ~ dT^n in still air.

    The slope of ln h against ln dT between the two surface temperature ``rises``
    (K above ``ambient``, degC), h the convection of Morgan's correlation [1] on a
    cylinder of ``diameter`` (m) plus the linearised radiation of ``emissivity``
    [2]. For a 0.45 mm thread it is about 0.17: the heat loss of eq. (1) grows a
    little faster than the temperature rise, as the catalogue's
    'nonlinear_convection' effect states it.
    """
    low, high = rises
    h = [natural_convection_coefficient(diameter, dt, ambient)
         + radiation_coefficient(emissivity, dt, ambient) for dt in (low, high)]
    return math.log(h[1] / h[0]) / math.log(high / low)
