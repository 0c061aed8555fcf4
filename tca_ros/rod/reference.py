"""Reference (unloaded) centrelines of a TCA as strain fields over arc length.

A reference is the clamp pose (p0, R0) plus the body strains u*(s), v*(s); the
rod's shape follows by integrating Eq. (6), g' = g xi^, from the clamp.

References
----------
[1] Sun et al., IEEE T-RO 2022: helix Eqs. (12)-(16); conical Archimedes spiral,
    Appendix C, Eqs. (36)-(41).
"""
from dataclasses import dataclass
from typing import Callable

import numpy as np

from tca_ros.rod.so3 import quaternion_from_rotation, rotation_from_quaternion
from tca_ros.rod.so3 import quaternion_step, screw_exp


@dataclass(frozen=True)
class RodReference:
    """A reference centreline: clamp pose and body strains along arc length.

    Attributes
    ----------
    length : float
        Arc length l_t of the rod (m).
    p0 : ndarray, shape (3,)
        Clamp position in the global frame (m).
    R0 : ndarray, shape (3, 3)
        Clamp orientation (body frame in the global frame).
    strain : callable
        ``strain(s) -> (u, v)``: s (n,) in m; u (3, n) in 1/m, v (3, n) (-), the
        reference (or heated reference) strains xi^h of Eqs. (14), (15), (40).
    n_coils : float
        Number of turns of the reference, an estimate for mesh sizing (-).
    name : str
        Label.
    """

    length: float
    p0: np.ndarray
    R0: np.ndarray
    strain: Callable
    n_coils: float
    name: str = 'user'


def helix_strain(radius, pitch_angle):
    """Return curvature and torsion (kappa*, tau*) (1/m) of a helix, Eq. (14).

        kappa* = cos^2(alpha*) / r*,  tau* = sin(alpha*) cos(alpha*) / r*

    Parameters
    ----------
    radius : float
        Coil radius r* (m).
    pitch_angle : float
        Pitch angle alpha* (rad).
    """
    c, s = np.cos(pitch_angle), np.sin(pitch_angle)
    return c * c / radius, s * c / radius


def helix_clamp_frame(radius, pitch_angle):
    """Return the clamp pose (p0 (m), R0) of a right-handed helix, Eq. (16).

        p0 = [r*, 0, 0],  R0 = [[-1, 0, 0], [0, sin a*, -cos a*], [0, -cos a*, -sin a*]]

    The coil axis is the global Z axis; the helix descends along -Z from the clamp.
    """
    c, s = np.cos(pitch_angle), np.sin(pitch_angle)
    return (np.array([radius, 0.0, 0.0]),
            np.array([[-1.0, 0.0, 0.0], [0.0, s, -c], [0.0, -c, -s]]))


def _constant_strain(u, v):
    u = np.asarray(u, dtype=float).reshape(3, 1)
    v = np.asarray(v, dtype=float).reshape(3, 1)

    def strain(s):
        n = np.size(s)
        return np.repeat(u, n, axis=1), np.repeat(v, n, axis=1)
    return strain


def helix_reference(radius, pitch_angle, length, untwist=0.0):
    """Return the (heated) reference of a right-handed helical TCA, Eqs. (12)-(16).

        u^h = [0, kappa*, tau* + untwist],  v^h = [0, 0, 1]          Eq. (15)

    The centreline is integrated from the clamp frame (16) (the printed p*(s) of
    (12) is inconsistent with R*(s) of (13); see docs/rod.md).

    Parameters
    ----------
    radius : float
        Coil radius r* (m), > 0.
    pitch_angle : float
        Pitch angle alpha* (rad), in (0, pi/2).
    length : float
        Fiber length l_t (m), > 0.
    untwist : float, optional
        Unit untwist Delta theta_bar^h (rad/m), Eq. (4); negative when hot.

    Returns
    -------
    RodReference
    """
    if not radius > 0.0:
        raise ValueError(f'radius = {radius!r}: must be > 0 m')
    if not 0.0 < pitch_angle < 0.5 * np.pi:
        raise ValueError(f'pitch_angle = {pitch_angle!r}: must be in (0, pi/2) rad')
    if not length > 0.0:
        raise ValueError(f'length = {length!r}: must be > 0 m')
    kappa, tau = helix_strain(radius, pitch_angle)
    p0, R0 = helix_clamp_frame(radius, pitch_angle)
    turns = length * np.hypot(kappa, tau + untwist) / (2.0 * np.pi)
    return RodReference(length=float(length), p0=p0, R0=R0,
                        strain=_constant_strain([0.0, kappa, tau + untwist], [0, 0, 1]),
                        n_coils=float(turns), name='helix')


def spiral_coefficients(spiral_pitch, cone_angle):
    """Return (a (rad/m), b (-)) of the conical Archimedes spiral, Eq. (36).

    a = 2 pi / p_c (one turn per pitch p_c), b = tan(cone angle / 2).
    """
    return 2.0 * np.pi / spiral_pitch, np.tan(0.5 * cone_angle)


def spiral_position(z, a, b):
    """Return p*(z) = [b z cos(a z), b z sin(a z), z] (m), Eq. (36); z (n,) in m."""
    z = np.asarray(z, dtype=float)
    return np.array([b * z * np.cos(a * z), b * z * np.sin(a * z), z])


def spiral_arc_length(z, a, b):
    """Return s(z) (m), the arc length of the spiral from its apex, Eq. (37).

        s = z/2 sqrt(1 + b^2 (1 + a^2 z^2))
            + (1 + b^2) / (2 a b) asinh(a b z / sqrt(1 + b^2))

    (the printed argument of asinh has sqrt(1 + z^2); this is the integral of
    |dp*/dz| = sqrt(1 + b^2 + a^2 b^2 z^2)).
    """
    z = np.asarray(z, dtype=float)
    c2 = 1.0 + b * b
    return (0.5 * z * np.sqrt(c2 + (a * b * z) ** 2)
            + c2 / (2.0 * a * b) * np.arcsinh(a * b * z / np.sqrt(c2)))


def spiral_height(s, a, b, tol=1e-14):
    """Return z(s) (m) by inverting Eq. (37) numerically (vectorized Newton).

    Notes
    -----
    s(z) is smooth, increasing and convex for z >= 0 with ds/dz =
    sqrt(1 + b^2 + a^2 b^2 z^2) >= 1; Newton from z = s / sqrt(1 + b^2) (the apex
    slope, an upper bound) decreases monotonically to the root.

    Parameters
    ----------
    s : ndarray
        Arc length from the apex (m), >= 0.
    tol : float
        Relative tolerance on z (-).
    """
    s = np.asarray(s, dtype=float)
    z = s / np.sqrt(1.0 + b * b)
    for _ in range(60):
        step = (spiral_arc_length(z, a, b) - s) / np.sqrt(1.0 + b * b + (a * b * z) ** 2)
        z = z - step
        if np.all(np.abs(step) <= tol * np.maximum(np.abs(z), 1e-12)):
            break
    return z


def _spiral_derivatives(z, a, b):
    """Return dp/dz, d2p/dz2, d3p/dz3 of Eq. (36), each (3, n)."""
    c, s = np.cos(a * z), np.sin(a * z)
    zero = np.zeros_like(z)
    d1 = np.array([b * c - a * b * z * s, b * s + a * b * z * c, 1.0 + zero])
    d2 = np.array([-2 * a * b * s - a * a * b * z * c, 2 * a * b * c - a * a * b * z * s,
                   zero])
    d3 = np.array([-3 * a * a * b * c + a ** 3 * b * z * s,
                   -3 * a * a * b * s - a ** 3 * b * z * c, zero])
    return d1, d2, d3


def spiral_curvature_torsion(z, a, b):
    """Return (kappa*, tau*) (1/m) of the conical spiral at height z, Eqs. (38)-(39).

        kappa = |p' x p''| / |p'|^3,  tau = (p' x p'') . p''' / |p' x p''|^2

    evaluated from the exact z-derivatives of (36) (the printed (38) is garbled; (39)
    agrees with this form).
    """
    z = np.asarray(z, dtype=float)
    d1, d2, d3 = _spiral_derivatives(z, a, b)
    cr = np.cross(d1, d2, axis=0)
    cr2 = np.einsum('i...,i...->...', cr, cr)
    speed = np.sqrt(np.einsum('i...,i...->...', d1, d1))
    return np.sqrt(cr2) / speed ** 3, np.einsum('i...,i...->...', cr, d3) / cr2


def spiral_frame(z, a, b):
    """Return the Frenet frame [N, B, T] (3, 3, n) of the spiral, the body frame of (40).

    Body z along the tangent T, x along the principal normal N, y along the binormal,
    so that u* = [0, kappa*, tau*] (as for the helix, Eq. (14)).
    """
    z = np.atleast_1d(np.asarray(z, dtype=float))
    d1, d2, _ = _spiral_derivatives(z, a, b)
    t = d1 / np.linalg.norm(d1, axis=0)
    bn = np.cross(d1, d2, axis=0)
    bn = bn / np.linalg.norm(bn, axis=0)
    nn = np.cross(bn, t, axis=0)
    return np.stack([nn, bn, t], axis=1)


def conical_spiral_reference(spiral_pitch, cone_angle, length, untwist=0.0):
    """Return the (heated) reference of a conical TCA, Eqs. (36)-(41).

        u^h(s) = [0, kappa*(z(s)), tau*(z(s)) + untwist],  v^h = [0, 0, 1]   Eq. (40)

    The clamp is the apex z = 0 with p0 = 0 and R0 the exact Frenet frame there (the
    paper's R0 = R_z(pi + 0.1) of (41) approximates it; see docs/rod.md).

    Parameters
    ----------
    spiral_pitch : float
        Spiral pitch p_c (m), > 0.
    cone_angle : float
        Full cone angle (rad), in (0, pi).
    length : float
        Fiber length l_t (m), > 0.
    untwist : float, optional
        Unit untwist Delta theta_bar^h (rad/m), Eq. (4).

    Returns
    -------
    RodReference
    """
    if not spiral_pitch > 0.0:
        raise ValueError(f'spiral_pitch = {spiral_pitch!r}: must be > 0 m')
    if not 0.0 < cone_angle < np.pi:
        raise ValueError(f'cone_angle = {cone_angle!r}: must be in (0, pi) rad')
    if not length > 0.0:
        raise ValueError(f'length = {length!r}: must be > 0 m')
    a, b = spiral_coefficients(spiral_pitch, cone_angle)

    def strain(s):
        kappa, tau = spiral_curvature_torsion(spiral_height(s, a, b), a, b)
        zero = np.zeros_like(kappa)
        return (np.array([zero, kappa, tau + untwist]),
                np.array([zero, zero, zero + 1.0]))
    z_end = spiral_height(np.array([length]), a, b)[0]
    return RodReference(length=float(length), p0=np.zeros(3),
                        R0=spiral_frame(np.array([0.0]), a, b)[:, :, 0], strain=strain,
                        n_coils=float(a * z_end / (2.0 * np.pi)), name='conical')


def integrate_strains(reference, s, u=None, v=None, h0=None):
    """Integrate Eq. (6) from the clamp with strains piecewise constant per interval.

    Notes
    -----
    On each interval [s_k, s_k+1] the strain is taken at the midpoint and the exact
    screw motion (quaternion step and SE(3) translation) is applied, so a uniform
    strain field (a helix) is reproduced to round-off; otherwise the error is
    second order in the step.

    Parameters
    ----------
    reference : RodReference
        Clamp pose (and strains if ``u``, ``v`` are not given).
    s : ndarray, shape (n,)
        Increasing nodes from 0 (m).
    u, v : ndarray, shape (3, n - 1), optional
        Strains on each interval (1/m, -); default: the reference at midpoints.
    h0 : ndarray, shape (4,), optional
        Quaternion of ``reference.R0`` to start from (picks the sign of the double
        cover); default the one with h0 >= 0.

    Returns
    -------
    positions : ndarray, shape (3, n)
        Centreline (m).
    quaternions : ndarray, shape (4, n)
        Orientation as quaternions (unit at the clamp).
    """
    s = np.asarray(s, dtype=float)
    ds = np.diff(s)
    if u is None:
        u, v = reference.strain(0.5 * (s[1:] + s[:-1]))
    qs = quaternion_step(u, ds)
    E, d = screw_exp(u, v, ds)
    del E
    h = np.empty((4, s.size))
    p = np.empty((3, s.size))
    h[:, 0] = quaternion_from_rotation(reference.R0) if h0 is None else h0
    p[:, 0] = reference.p0
    for k in range(ds.size):
        h[:, k + 1] = qs[:, :, k] @ h[:, k]
    R = rotation_from_quaternion(h[:, :-1])
    p[:, 1:] = reference.p0[:, None] + np.cumsum(np.einsum('ijk,jk->ik', R, d), axis=1)
    return p, h
