"""Tests of the exact uniform-helix equilibrium (tca_ros.rod.helix)."""
import numpy as np
import pytest

from tca_ros.model.moduli import section_stiffness
from tca_ros.rod.helix import helix_centreline, uniform_helix_equilibrium
from tca_ros.rod.reference import helix_strain
from tca_ros.rod.so3 import hat

SMALL_LOAD = 1e-6  # N; stiffness by central difference, nonlinearity ~ F/(k l) ~ 1e-6


def _small_load_stiffness(params, locked=False, rigid_shear_extension=False):
    c, length = params.coil, params.fiber.length
    sec = section_stiffness(params.thermal.ambient_temperature, 0.0, params)
    kappa, tau = helix_strain(c.radius, c.pitch_angle)
    ga, ea = (np.inf, np.inf) if rigid_shear_extension else (sec.GA, sec.EA)
    eq = uniform_helix_equilibrium(np.array([-SMALL_LOAD, SMALL_LOAD]), (kappa, tau),
                                   (sec.EI, sec.GJ, ga, ea),
                                   turn_rate_lock=np.hypot(kappa, tau) if locked else None)
    assert np.all(eq.success)
    return 2 * SMALL_LOAD / (length * np.diff(eq.axial_stretch)[0]), sec


def _cst_stiffness(params, sec):
    """1/K_cst of Eq. (29) at the reference state."""
    a, r, length = params.coil.pitch_angle, params.coil.radius, params.fiber.length
    return 1.0 / (length * (r * r * np.cos(a) ** 2 / sec.GJ + r * r * np.sin(a) ** 2 / sec.EI
                            + np.cos(a) ** 2 / sec.GA + np.sin(a) ** 2 / sec.EA))


def test_free_end_small_load_stiffness_equals_cst(free_stroke, self_coiled):
    """Paper notes: free-stroke 22.52 N/m, self-coiled 56.15 N/m; CST = exact helix."""
    for params, expected in ((free_stroke, 22.52), (self_coiled, 56.15)):
        k, sec = _small_load_stiffness(params)
        assert k == pytest.approx(expected, abs=0.005)  # figures quoted to 0.01 N/m
        assert k == pytest.approx(_cst_stiffness(params, sec), rel=1e-5)  # notes: 1e-5


def test_rotation_locked_stiffness_matches_notes(free_stroke):
    k, _ = _small_load_stiffness(free_stroke, locked=True)
    assert k == pytest.approx(25.19, abs=0.005)  # paper notes, quoted to 0.01 N/m


def test_rigid_shear_and_extension_locked_is_love(free_stroke, self_coiled):
    """Kirchhoff (GA, EA -> inf) rotation-locked helix = Love linearised, Eq. (25)."""
    for params, expected in ((free_stroke, 28.87), (self_coiled, 87.7)):
        k, sec = _small_load_stiffness(params, locked=True, rigid_shear_extension=True)
        a, r = params.coil.pitch_angle, params.coil.radius
        love = (sec.GJ * np.cos(a) ** 2 + sec.EI * np.sin(a) ** 2) / (
            params.fiber.length * r * r)
        assert k == pytest.approx(love, rel=1e-5)  # linearisation error ~ SMALL_LOAD
        assert k == pytest.approx(expected, rel=1e-3)  # notes quote 4 digits


def test_stiff_shear_extension_approaches_love(free_stroke):
    """Scaling GA, EA up makes the locked Cosserat helix converge to Love's stiffness."""
    k_love, sec = _small_load_stiffness(free_stroke, locked=True, rigid_shear_extension=True)
    c = free_stroke.coil
    kappa, tau = helix_strain(c.radius, c.pitch_angle)
    gaps = []
    for factor in (1.0, 10.0, 100.0):
        eq = uniform_helix_equilibrium(np.array([-SMALL_LOAD, SMALL_LOAD]), (kappa, tau),
                                       (sec.EI, sec.GJ, factor * sec.GA, factor * sec.EA),
                                       turn_rate_lock=np.hypot(kappa, tau))
        k = 2 * SMALL_LOAD / (free_stroke.fiber.length * np.diff(eq.axial_stretch)[0])
        gaps.append(abs(k - k_love) / k_love)
    assert gaps[0] > 0.1  # shear and extension matter at the real moduli (25.2 vs 28.9)
    assert gaps[1] < gaps[0] / 5 and gaps[2] < gaps[1] / 5  # compliance ~ 1/factor
    assert gaps[2] < 2e-3


def test_zero_load_returns_heated_reference_exactly():
    eq = uniform_helix_equilibrium(0.0, (2000.0, 700.0), (1e-6, 5e-7, 30.0, 150.0))
    np.testing.assert_allclose(eq.u, [0.0, 2000.0, 700.0], rtol=1e-14)
    np.testing.assert_allclose(eq.v, [0.0, 0.0, 1.0], rtol=1e-14)
    np.testing.assert_allclose([eq.m, eq.n], 0.0, atol=1e-18)


@pytest.mark.parametrize('force', [-0.5, 0.3, 2.0])
@pytest.mark.parametrize('moment', [0.0, 1e-4])
def test_solution_satisfies_statics_and_load(force, moment):
    """ad_xi^T W = 0 (Eq. (7), constant strain), n . e = F, m . e = M."""
    eq = uniform_helix_equilibrium(force, (2094.0, 864.0), (1.83e-6, 6.7e-7, 30.5, 166.0),
                                   moment=moment)
    assert eq.success
    u, v, m, n = eq.u, eq.v, eq.m, eq.n
    scale = np.linalg.norm(u) * (np.linalg.norm(m) + 1e-9)
    np.testing.assert_allclose(hat(u) @ n, 0.0, atol=1e-12 * np.linalg.norm(u))
    np.testing.assert_allclose(hat(u) @ m + hat(v) @ n, 0.0, atol=1e-10 * scale)
    e = u / np.linalg.norm(u)
    assert n @ e == pytest.approx(force, rel=1e-12)
    assert m @ e == pytest.approx(moment, abs=1e-15)


def test_invalid_stiffness_is_rejected():
    with pytest.raises(ValueError, match='stiffness'):
        uniform_helix_equilibrium(0.1, (2000.0, 700.0), (1e-6, -1.0, 30.0, 150.0))


def test_centreline_has_helix_radius_and_length():
    eq = uniform_helix_equilibrium(0.3, (2094.0, 864.0), (1.83e-6, 6.7e-7, 30.5, 166.0))
    xyz = helix_centreline(eq, 0.1, 5000)
    np.testing.assert_allclose(np.hypot(xyz[0], xyz[1]), eq.radius, rtol=1e-12)
    assert xyz[2, -1] == pytest.approx(-0.1 * eq.axial_stretch, rel=1e-12)
    arc = np.sum(np.linalg.norm(np.diff(xyz, axis=1), axis=0))
    assert arc == pytest.approx(0.1 * np.linalg.norm(eq.v), rel=2e-4)  # chords, 140 per turn
