"""Tests of tca_ros.rod.so3 and tca_ros.rod.reference (rotations, reference curves)."""
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.linalg import expm

from tca_ros.rod.reference import conical_spiral_reference, helix_clamp_frame
from tca_ros.rod.reference import helix_reference, integrate_strains, spiral_arc_length
from tca_ros.rod.reference import spiral_coefficients, spiral_curvature_torsion
from tca_ros.rod.reference import spiral_height, spiral_position
from tca_ros.rod.so3 import hat, quaternion_derivative, quaternion_from_rotation
from tca_ros.rod.so3 import quaternion_step, rotation_exp, rotation_from_quaternion
from tca_ros.rod.so3 import screw_exp, vee

RNG = np.random.default_rng(3)
ROUND_OFF = 1e-12  # a few hundred ulps of O(1) quantities


def test_vee_inverts_hat():
    w = RNG.standard_normal((3, 5))
    np.testing.assert_allclose(vee(hat(w)), w, atol=ROUND_OFF)
    np.testing.assert_allclose(np.einsum('ijk,jk->ik', hat(w), w), 0.0, atol=ROUND_OFF)


def test_rotation_of_nonunit_quaternion_is_orthonormal():
    h = 3.7 * RNG.standard_normal((4, 20))
    R = rotation_from_quaternion(h)
    RtR = np.einsum('jik,jlk->ilk', R, R)
    np.testing.assert_allclose(RtR, np.repeat(np.eye(3)[:, :, None], 20, axis=2),
                               atol=ROUND_OFF)
    np.testing.assert_allclose(np.linalg.det(R.transpose(2, 0, 1)), 1.0, atol=ROUND_OFF)


def test_quaternion_from_rotation_round_trip():
    for _ in range(10):
        R = rotation_from_quaternion(RNG.standard_normal(4))
        np.testing.assert_allclose(rotation_from_quaternion(quaternion_from_rotation(R)),
                                   R, atol=ROUND_OFF)
    R0 = helix_clamp_frame(1e-3, 0.4)[1]  # trace -1 - sin: exercises a non-trace branch
    np.testing.assert_allclose(rotation_from_quaternion(quaternion_from_rotation(R0)), R0,
                               atol=ROUND_OFF)


def test_quaternion_rate_gives_body_angular_rate():
    """Eq. (32), row 3 corrected: d/ds R(h) = R(h) u^ (checked by central differences)."""
    h = RNG.standard_normal(4)
    u = RNG.standard_normal(3)
    eps = 1e-6  # central difference, error O(eps^2) ~ 1e-12
    dR = (rotation_from_quaternion(h + eps * quaternion_derivative(h, u))
          - rotation_from_quaternion(h - eps * quaternion_derivative(h, u))) / (2 * eps)
    np.testing.assert_allclose(dR, rotation_from_quaternion(h) @ hat(u), atol=1e-8)


def test_exact_steps_match_matrix_exponentials():
    u = RNG.standard_normal((3, 4)) * 100.0
    v = RNG.standard_normal((3, 4))
    ds = 0.013
    E, d = screw_exp(u, v, ds)
    Q = quaternion_step(u, ds)
    for k in range(4):
        xi = np.zeros((4, 4))
        xi[:3, :3] = hat(u[:, k])
        xi[:3, 3] = v[:, k]
        g = expm(ds * xi)
        np.testing.assert_allclose(E[:, :, k], g[:3, :3], atol=1e-12)
        np.testing.assert_allclose(d[:, k], g[:3, 3], atol=1e-14)
        np.testing.assert_allclose(rotation_exp(ds * u)[:, :, k], g[:3, :3], atol=1e-12)
        h = RNG.standard_normal(4)
        np.testing.assert_allclose(rotation_from_quaternion(Q[:, :, k] @ h),
                                   rotation_from_quaternion(h) @ g[:3, :3], atol=1e-12)


def test_clamp_frame_is_eq13_at_s0():
    """Eq. (16) equals R*(0) = R_z(pi) R_x(-pi/2 - alpha*) of Eq. (13)."""
    alpha = 0.39

    def rz(a):
        return rotation_exp(np.array([[0.0], [0.0], [a]]))[:, :, 0]

    def rx(a):
        return rotation_exp(np.array([[a], [0.0], [0.0]]))[:, :, 0]
    np.testing.assert_allclose(helix_clamp_frame(1e-3, alpha)[1],
                               rz(np.pi) @ rx(-np.pi / 2 - alpha), atol=ROUND_OFF)


def test_helix_reference_integrates_to_a_helix_on_the_z_axis():
    r, alpha, length = 0.408e-3, np.radians(22.42), 0.02
    ref = helix_reference(r, alpha, length)
    s = np.linspace(0.0, length, 301)
    p, h = integrate_strains(ref, s)
    np.testing.assert_allclose(np.hypot(p[0], p[1]), r, rtol=1e-12)
    np.testing.assert_allclose(p[2], -s * np.sin(alpha), atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(h, axis=0), 1.0, atol=ROUND_OFF)


@pytest.mark.parametrize('bad', [dict(radius=-1.0), dict(pitch_angle=2.0),
                                 dict(length=0.0)])
def test_helix_reference_rejects_bad_geometry(bad):
    args = dict(radius=1e-3, pitch_angle=0.4, length=0.1)
    args.update(bad)
    with pytest.raises(ValueError, match=next(iter(bad))):
        helix_reference(**args)


def test_spiral_arc_length_and_inversion():
    a, b = spiral_coefficients(10.6e-3, np.radians(12.0))
    z = np.array([0.0, 1e-3, 0.01, 0.03])
    exact = [quad(lambda t: np.sqrt(1 + b * b + (a * b * t) ** 2), 0.0, zz)[0] for zz in z]
    np.testing.assert_allclose(spiral_arc_length(z, a, b), exact, rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(spiral_height(spiral_arc_length(z, a, b), a, b), z,
                               rtol=1e-12, atol=1e-16)


def test_spiral_torsion_matches_eq39():
    a, b = spiral_coefficients(10.6e-3, np.radians(12.0))
    z = np.linspace(0.0, 0.03, 7)
    tau39 = a * (6 + a * a * z * z) / (4 + a * a * z * z + b * b * (2 + a * a * z * z) ** 2)
    np.testing.assert_allclose(spiral_curvature_torsion(z, a, b)[1], tau39, rtol=1e-12)


def test_conical_reference_integrates_to_the_spiral_at_second_order():
    """Integrating u*(s) from the clamp reproduces p*(z(s)) of (36); error ~ ds^2."""
    ref = conical_spiral_reference(10.6e-3, np.radians(12.0), 0.03)
    a, b = spiral_coefficients(10.6e-3, np.radians(12.0))
    errors = []
    for n in (200, 400):
        s = np.linspace(0.0, ref.length, n + 1)
        p, _ = integrate_strains(ref, s)
        errors.append(np.max(np.abs(p - spiral_position(spiral_height(s, a, b), a, b))))
    assert errors[1] < 1e-5 * ref.length  # 64 steps per turn
    assert 3.5 < errors[0] / errors[1] < 4.5  # second order: halving ds quarters the error
