"""Rotations for the Cosserat rod: hat/vee, non-unit quaternions, exponentials.

All functions take the sample axis last: vectors (3, n), quaternions (4, n), matrices
(3, 3, n); a single sample may be given as (3,) or (4,).

References
----------
[1] J. Sun, B. Tighe, Y. Shi, J. Zhao, "Physics-Based Modeling of Twisted-and-Coiled
    Actuators Using Cosserat Rod Theory", IEEE T-RO, 2022; Sec. V-B1, eq. (32) (row 3
    corrected, see docs/rod.md) and the R(h) formula below it.
"""
import numpy as np


def hat(w):
    """Return the skew matrix w^ with w^ x = w cross x.

    Parameters
    ----------
    w : ndarray, shape (3,) or (3, n)
        Vector(s) (any unit).

    Returns
    -------
    ndarray, shape (3, 3) or (3, 3, n)
        Skew-symmetric matrices (same unit as ``w``).
    """
    w = np.asarray(w, dtype=float)
    z = np.zeros_like(w[0])
    return np.array([[z, -w[2], w[1]], [w[2], z, -w[0]], [-w[1], w[0], z]])


def vee(mat):
    """Return w from a skew matrix w^, the inverse of :func:`hat`.

    Parameters
    ----------
    mat : ndarray, shape (3, 3) or (3, 3, n)
        Skew-symmetric matrices (any unit); the symmetric part is discarded.

    Returns
    -------
    ndarray, shape (3,) or (3, n)
    """
    mat = np.asarray(mat, dtype=float)
    return 0.5 * np.array([mat[2, 1] - mat[1, 2], mat[0, 2] - mat[2, 0],
                           mat[1, 0] - mat[0, 1]])


def quaternion_rate_matrix(u):
    """Return Omega(u) with h' = Omega(u) h / 2, Eq. (32) of [1], row 3 corrected.

        Omega = [[0, -ux, -uy, -uz], [ux, 0, uz, -uy], [uy, -uz, 0, ux], [uz, uy, -ux, 0]]

    The printed row 3 has u_z where u_x belongs; this form is h (x) (0, u), the
    body-frame rate of a Hamilton quaternion, and is skew with Omega^2 = -|u|^2 I.

    Parameters
    ----------
    u : ndarray, shape (3,) or (3, n)
        Angular strain in the body frame (1/m).

    Returns
    -------
    ndarray, shape (4, 4) or (4, 4, n)
        Omega(u) (1/m).
    """
    u = np.asarray(u, dtype=float)
    ux, uy, uz = u
    z = np.zeros_like(ux)
    return np.array([[z, -ux, -uy, -uz], [ux, z, uz, -uy], [uy, -uz, z, ux],
                     [uz, uy, -ux, z]])


def quaternion_derivative(h, u):
    """Return h' = Omega(u) h / 2 (1/m), Eq. (32) of [1] with row 3 corrected.

    Parameters
    ----------
    h : ndarray, shape (4,) or (4, n)
        Non-unit quaternion [h0, h1, h2, h3] (any positive norm).
    u : ndarray, shape (3,) or (3, n)
        Angular strain in the body frame (1/m).
    """
    omega = quaternion_rate_matrix(u)
    return 0.5 * np.einsum('ij...,j...->i...', omega, np.asarray(h, dtype=float))


def rotation_from_quaternion(h):
    """Return R(h) for a non-unit quaternion, the formula below Eq. (32) of [1].

        R = I + 2 / (h^T h) [[-h2^2 - h3^2, h1 h2 - h3 h0, h1 h3 + h2 h0],
                             [h1 h2 + h3 h0, -h1^2 - h3^2, h2 h3 - h1 h0],
                             [h1 h3 - h2 h0, h2 h3 + h1 h0, -h1^2 - h2^2]]

    Dividing by h^T h makes R orthonormal for any non-zero h, so the norm drift of an
    integrated quaternion never leaves SO(3).

    Parameters
    ----------
    h : ndarray, shape (4,) or (4, n)
        Quaternion(s) (dimensionless, non-zero).

    Returns
    -------
    ndarray, shape (3, 3) or (3, 3, n)
        Rotation matrices.
    """
    h0, h1, h2, h3 = np.asarray(h, dtype=float)
    c = 2.0 / (h0 * h0 + h1 * h1 + h2 * h2 + h3 * h3)
    one = np.ones_like(h0)
    return np.array([
        [one - c * (h2 * h2 + h3 * h3), c * (h1 * h2 - h3 * h0), c * (h1 * h3 + h2 * h0)],
        [c * (h1 * h2 + h3 * h0), one - c * (h1 * h1 + h3 * h3), c * (h2 * h3 - h1 * h0)],
        [c * (h1 * h3 - h2 * h0), c * (h2 * h3 + h1 * h0), one - c * (h1 * h1 + h2 * h2)]])


def quaternion_from_rotation(rot):
    """Return the unit quaternion h (h0 >= 0) of a rotation matrix.

    Notes
    -----
    Shepperd's method: take the square root of the largest of the four diagonal
    combinations, so no division by a small number occurs (the robust scheme [1] uses
    via MATLAB's rotm2quat).

    Parameters
    ----------
    rot : ndarray, shape (3, 3)
        Rotation matrix.

    Returns
    -------
    ndarray, shape (4,)
    """
    r = np.asarray(rot, dtype=float)
    if r.shape != (3, 3):
        raise ValueError(f'rot has shape {r.shape}, expected (3, 3)')
    trace = np.trace(r)
    cands = np.array([trace, r[0, 0], r[1, 1], r[2, 2]])
    k = int(np.argmax(cands))
    if k == 0:
        w = 0.5 * np.sqrt(1.0 + trace)
        h = np.array([w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w),
                      (r[1, 0] - r[0, 1]) / (4 * w)])
    else:
        i = k - 1
        j, m = (i + 1) % 3, (i + 2) % 3
        x = 0.5 * np.sqrt(1.0 + r[i, i] - r[j, j] - r[m, m])
        h = np.empty(4)
        h[1 + i] = x
        h[0] = (r[m, j] - r[j, m]) / (4 * x)
        h[1 + j] = (r[j, i] + r[i, j]) / (4 * x)
        h[1 + m] = (r[m, i] + r[i, m]) / (4 * x)
    return h if h[0] >= 0 else -h


def _sin_over(theta):
    """Return sin(theta)/theta, (1 - cos)/theta^2, (theta - sin)/theta^3 (series near 0)."""
    small = theta < 1e-4  # rad; the series below are exact to round-off there
    t = np.where(small, 1.0, theta)
    t2 = theta * theta
    a = np.where(small, 1.0 - t2 / 6.0, np.sin(t) / t)
    b = np.where(small, 0.5 - t2 / 24.0, (1.0 - np.cos(t)) / (t * t))
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0, (t - np.sin(t)) / (t * t * t))
    return a, b, c


def rotation_exp(phi):
    """Return exp(phi^) by Rodrigues' formula.

    Parameters
    ----------
    phi : ndarray, shape (3, n)
        Rotation vectors (rad).

    Returns
    -------
    ndarray, shape (3, 3, n)
    """
    theta = np.sqrt(np.einsum('i...,i...->...', phi, phi))
    a, b, _ = _sin_over(theta)
    k = hat(phi)
    k2 = np.einsum('ij...,jk...->ik...', k, k)
    eye = np.eye(3).reshape((3, 3) + (1,) * (np.ndim(phi) - 1))
    return eye + a * k + b * k2


def screw_exp(u, v, ds):
    """Return the rotation and body translation of a constant-strain segment.

    For constant strains (u, v) over a length ds, g(ds) = exp(ds xi^) with
    E = exp(ds u^) and d = ds T(ds u) v, T(phi) = I + (1 - cos)/theta^2 phi^ +
    (theta - sin)/theta^3 phi^2: the exact solution of Eq. (6) over the segment.

    Parameters
    ----------
    u, v : ndarray, shape (3, n)
        Angular strain (1/m) and linear strain (-) in the body frame.
    ds : float or ndarray, shape (n,)
        Segment length (m).

    Returns
    -------
    E : ndarray, shape (3, 3, n)
        Rotation of the end frame relative to the start frame.
    d : ndarray, shape (3, n)
        Position of the end relative to the start, in the start frame (m).
    """
    phi = u * ds
    theta = np.sqrt(np.einsum('i...,i...->...', phi, phi))
    a, b, c = _sin_over(theta)
    k = hat(phi)
    k2 = np.einsum('ij...,jk...->ik...', k, k)
    eye = np.eye(3).reshape((3, 3) + (1,) * (np.ndim(phi) - 1))
    E = eye + a * k + b * k2
    T = eye + b * k + c * k2
    d = np.einsum('ij...,j...->i...', T, v) * ds
    return E, d


def quaternion_step(u, ds):
    """Return the 4x4 map h(s + ds) = Q h(s) for constant u, exp(ds Omega(u) / 2).

        Q = cos(theta/2) I + sin(theta/2)/|u| Omega(u),   theta = |u| ds

    exact because Omega^2 = -|u|^2 I (Eq. (32) of [1]); Q is orthogonal, so the
    quaternion norm is kept to round-off.

    Parameters
    ----------
    u : ndarray, shape (3, n)
        Angular strain (1/m).
    ds : float or ndarray, shape (n,)
        Step (m).

    Returns
    -------
    ndarray, shape (4, 4, n)
    """
    w = np.sqrt(np.einsum('i...,i...->...', u, u))
    half = 0.5 * w * ds
    a, _, _ = _sin_over(half)
    eye = np.eye(4).reshape((4, 4) + (1,) * (np.ndim(u) - 1))
    return np.cos(half) * eye + (0.5 * ds * a) * quaternion_rate_matrix(u)
