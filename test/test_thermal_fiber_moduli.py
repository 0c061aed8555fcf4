"""Eqs. (1)-(4) and (9)-(11) against hand-computed values (paper_notes.md figures)."""
import math

import numpy as np
import pytest

from tca_ros.model import fiber, moduli, thermal
from tca_ros.params.files import load_params


def test_thermal_constants_match_table_ii(free_stroke):
    f, t = free_stroke.fiber, free_stroke.thermal
    assert thermal.fiber_mass(f) == pytest.approx(31.5e-6, rel=2e-3)  # 31.5 mg
    assert thermal.thermal_time_constant(f, t) == pytest.approx(3.01, rel=2e-3)  # s
    assert 1.0 / thermal.thermal_conductance(f, t) == pytest.approx(75.3, rel=2e-3)  # K/W


@pytest.mark.parametrize('power', [0.1, 0.5, 1.0])
def test_exact_update_reproduces_step_response(free_stroke, power):
    f, t = free_stroke.fiber, free_stroke.thermal
    times = np.arange(1, 2001) * 5e-3
    temp, out = t.ambient_temperature, []
    for _ in times:
        temp = thermal.exact_temperature_update(temp, power, 5e-3, f, t)
        out.append(temp)
    np.testing.assert_allclose(out, thermal.step_response(times, power, f, t), rtol=1e-12)
    assert thermal.thermal_rate(thermal.steady_state_temperature(power, f, t), power, f, t) \
        == pytest.approx(0.0, abs=1e-9)


def test_gamma_polynomial_and_untwist(free_stroke):
    f = free_stroke.fiber
    assert fiber.radius_ratio(25.0, f) == pytest.approx(1.00223625, rel=1e-9)
    assert fiber.radius_ratio(160.0, f) == pytest.approx(1.081596, rel=1e-9)
    assert fiber.unit_untwist(25.0, f, 25.0) == 0.0
    # 4710 (1.00223625 / 1.081596 - 1) rad/m by hand
    assert fiber.unit_untwist(160.0, f, 25.0) == pytest.approx(-345.61, rel=1e-4)
    r_hot = fiber.heated_fiber_radius(160.0, f, 25.0)
    assert r_hot == pytest.approx(0.21e-3 * 1.07918, rel=1e-5)


def test_the_expansion_coefficient_holds_above_the_plateau_temperature(free_stroke):
    """Eq. (2) with T_p (G50): the quadratic up to T_p, then Gamma linear with its slope there."""
    c2, c1, c0 = free_stroke.fiber.gamma_coefficients
    f = free_stroke.with_values(**{'fiber.expansion_plateau_temperature': 90.0}).fiber
    quadratic = (c2 * 80.0 + c1) * 80.0 + c0
    assert fiber.radius_ratio(80.0, f) == quadratic
    at_top = (c2 * 90.0 + c1) * 90.0 + c0
    slope = 2.0 * c2 * 90.0 + c1  # alpha_perp at T_p, 1/K
    for temp in (100.0, 150.0, 250.0):
        assert fiber.radius_ratio(temp, f) == pytest.approx(at_top + slope * (temp - 90.0),
                                                            rel=1e-15)
    # value and slope continuous at T_p; the slope no longer grows above it
    h = 1e-4
    assert fiber.radius_ratio(90.0 + h, f) - fiber.radius_ratio(90.0 - h, f) == \
        pytest.approx(2.0 * h * slope, rel=1e-6)
    assert fiber.radius_ratio(200.0, f) < (c2 * 200.0 + c1) * 200.0 + c0
    # arrays and scalars agree on both sides
    temps = np.array([25.0, 89.0, 91.0, 200.0])
    np.testing.assert_array_equal(fiber.radius_ratio(temps, f),
                                  [fiber.radius_ratio(t, f) for t in temps])
    # at the melt the paper's quadratic holds over the model's whole range
    paper = free_stroke.with_values(**{'fiber.expansion_plateau_temperature': 260.0}).fiber
    assert fiber.radius_ratio(250.0, paper) == (c2 * 250.0 + c1) * 250.0 + c0


def test_yarn_moduli_as_printed_and_scaled(free_stroke):
    a_t = math.radians(40.0)
    assert moduli.youngs_modulus_yarn(3.9e9, 0.35, a_t) == pytest.approx(0.6904e9, rel=1e-3)
    assert moduli.shear_modulus_yarn(3.9e9, 0.35, a_t) == pytest.approx(0.1952e9, rel=1e-3)
    e, g = moduli.moduli_at(25.0, 0.0, free_stroke)
    assert (e, g) == (pytest.approx(1.2e9), pytest.approx(0.22e9))
    # scaling the printed eqs. (9), (10) to (E0, G0) equals E0 E_f / E_f0
    ef = moduli.fiber_modulus(150.0, 0.3, free_stroke)
    e, g = moduli.moduli_at(150.0, 0.3, free_stroke)
    ratio9 = moduli.youngs_modulus_yarn(ef, 0.35, a_t) / moduli.youngs_modulus_yarn(
        3.9e9, 0.35, a_t)
    ratio10 = moduli.shear_modulus_yarn(ef, 0.35, a_t) / moduli.shear_modulus_yarn(
        3.9e9, 0.35, a_t)
    assert e == pytest.approx(1.2e9 * ratio9, rel=1e-12)
    assert g == pytest.approx(0.22e9 * ratio10, rel=1e-12)


def test_load_dependence_of_eq_11(free_stroke):
    # tau(60 g) = F r_t cos(alpha*) / (G0 J) = 170 by hand; Appendix point (171, 5.68)
    tau = moduli.load_torsion_strain(0.06 * 9.81, free_stroke.fiber, free_stroke.coil,
                                     free_stroke.moduli)
    assert tau == pytest.approx(170.0, rel=2e-3)
    assert moduli.load_factor(171.0, free_stroke.moduli) == pytest.approx(5.857, rel=1e-3)
    assert moduli.load_torsion_strain(10.0, free_stroke.fiber, free_stroke.coil,
                                      free_stroke.moduli) == 171.0  # clipped
    ef_hot = moduli.fiber_modulus(160.0, 0.0, free_stroke)
    assert ef_hot == pytest.approx(3.9e9 - 1.1e6 * 135.0, rel=1e-12)
    heavy = moduli.fiber_modulus(160.0, 0.06 * 9.81, free_stroke)
    assert heavy < ef_hot  # load accelerates softening (Fig. 5)
    g_drop = 1.0 - moduli.moduli_at(160.0, 0.06 * 9.81, free_stroke)[1] / 0.22e9
    assert g_drop > 0.13  # "G will decrease more than 13 %" (Sec. III-B)


def test_section_uses_heated_radius_when_enabled(free_stroke):
    s = moduli.section_stiffness(160.0, 0.0, free_stroke)
    cold = free_stroke.with_values(**{'fiber.heated_radius_in_section': False})
    s_cold = moduli.section_stiffness(160.0, 0.0, cold)
    assert s.GJ / s_cold.GJ == pytest.approx(1.07918 ** 4, rel=1e-4)  # J grows ~36 %
    const = free_stroke.with_values(**{'moduli.constant': True})
    s_const = moduli.section_stiffness(160.0, 1.0, const)
    assert s_const.E == 1.2e9 and s_const.radius == 0.21e-3


def test_section_stiffness_of_a_row_of_tensions_is_each_ones():
    # the rod table solves a row of tensions at once: the same numbers as one by one,
    # across the clipped range of eq. (11) and the modulus floor
    p = load_params('free_stroke')
    tensions = np.linspace(-0.5, 40.0, 37)
    for temp in (25.0, 120.0, 240.0):
        row = moduli.section_stiffness(temp, tensions, p)
        for i, f in enumerate(tensions):
            one = moduli.section_stiffness(temp, float(f), p)
            assert (row.EI[i], row.GJ[i], row.GA[i], row.EA[i]) == (
                one.EI, one.GJ, one.GA, one.EA)
