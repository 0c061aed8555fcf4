"""The rod BVP discretized by Lie-group collocation: residual and banded Jacobian.

The nodes' states (p, h, m, n; N_STATE per node) on a fixed mesh, each interval
mapped exactly for its constant strain (statics.py's module docstring gives the
equations), the clamp (16) and the end wrench (17) or a height control; the
Jacobian in LAPACK band storage and its LU. statics.py runs Newton on it.
"""
import functools

import numpy as np
from scipy.linalg.lapack import dgbtrf, dgbtrs
import scipy.sparse as sp

from tca_ros.rod.reference import integrate_strains
from tca_ros.rod.so3 import hat, quaternion_from_rotation, quaternion_step
from tca_ros.rod.so3 import rotation_from_quaternion, screw_exp

N_STATE = 13  # p (3), h (4), m (3), n (3) per node
_P, _H, _M, _N = slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 13)
_W = slice(7, 13)


def _cross(a, b):
    """Return a x b for (3, n) arrays (np.cross's axis handling costs more here)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def _step_map(h0, m0, n0, u, v, ds, R=None):
    """Map a node state over one constant-strain interval (see module docstring)."""
    Q = quaternion_step(u, ds)
    E, d = screw_exp(u, v, ds)
    if R is None:
        R = rotation_from_quaternion(h0)
    h1 = np.einsum('ijk,jk->ik', Q, h0)
    dp = np.einsum('ijk,jk->ik', R, d)
    n1 = np.einsum('jik,jk->ik', E, n0)
    m1 = np.einsum('jik,jk->ik', E, m0 - _cross(d, n0))
    return h1, dp, m1, n1, Q, E, d, R


@functools.lru_cache(maxsize=16)
def _band_pattern(N):
    """Return the Jacobian's sparsity and LAPACK band layout for N intervals (cached)."""
    k = np.arange(N)
    r = 7 + 13 * k[:, None, None] + np.arange(13)[None, :, None]
    c = 13 * k[:, None, None] + np.arange(26)[None, None, :]
    r_step = np.broadcast_to(r, (N, 13, 26))
    c_step = np.broadcast_to(c, (N, 13, 26))
    r_end = np.broadcast_to(7 + 13 * N + np.arange(6)[:, None], (6, 13))
    c_end = np.broadcast_to(13 * N + np.arange(13)[None, :], (6, 13))
    rows = np.concatenate([np.arange(7), r_step.ravel(), r_end.ravel()])
    cols = np.concatenate([np.arange(7), c_step.ravel(), c_end.ravel()])
    offset = cols - rows
    lower = int(max(0, -offset.min()))
    upper = int(max(0, offset.max()))
    # LAPACK band storage for gbtrf: row lower + upper + i - j of column j (the top
    # ``lower`` rows are workspace for the fill-in of partial pivoting).
    band_index = (lower + upper + rows - cols, cols)
    band_flat = np.ravel_multi_index(band_index, (2 * lower + upper + 1, 13 * (N + 1)))
    return rows, cols, lower, upper, band_index, band_flat


class CollocationProblem:
    """Discretized BVP: residual and sparse Jacobian on a fixed mesh."""

    def __init__(self, reference, stiffness, end_force, end_moment, n_steps,
                 distributed_wrench, end_load_offset=(0.0, 0.0, 0.0), end_height=None):
        self.ref = reference
        self.end_height = None if end_height is None else float(end_height)
        self.offset = (None if isinstance(end_load_offset, str)
                       else np.asarray(end_load_offset, dtype=float))
        self.K = np.asarray(stiffness, dtype=float)
        self.kinv = 1.0 / self.K
        self.F = np.asarray(end_force, dtype=float)
        self.M = np.asarray(end_moment, dtype=float)
        self.N = n_steps
        self.s = np.linspace(0.0, reference.length, n_steps + 1)
        self.ds = np.diff(self.s)
        s_mid = 0.5 * (self.s[1:] + self.s[:-1])
        u_ref, v_ref = reference.strain(s_mid)
        self.xi_ref = np.concatenate([u_ref, v_ref])
        self.h0 = quaternion_from_rotation(reference.R0)
        if distributed_wrench is None:
            self.wbar = None
        elif callable(distributed_wrench):
            self.wbar = np.asarray(distributed_wrench(s_mid), dtype=float)
        else:
            self.wbar = np.broadcast_to(np.asarray(distributed_wrench, dtype=float)
                                        .reshape(6, -1), (6, n_steps)).copy()
        u_scale = float(np.max(np.linalg.norm(u_ref, axis=0)))
        self.length_scale = reference.length / max(1.0, reference.length * u_scale)
        # Scales turning each state/residual into a strain-like dimensionless number.
        self.scale = np.concatenate([np.full(3, self.length_scale), np.ones(4),
                                     self.K[:3] * max(u_scale, 1.0 / reference.length),
                                     self.K[3:]])
        self.end_scale = self.scale[7:].copy()
        if self.end_height is not None:
            self.end_scale[5] = self.length_scale  # the last end row is a height (m)
        self._pattern()

    def _pattern(self):
        (self.rows, self.cols, self.lower, self.upper, self.band_index,
         self.band_flat) = _band_pattern(self.N)

    def _end_residual(self, x):
        R = rotation_from_quaternion(x[_H])
        if self.end_height is not None:
            # Height control: a vertical end force of unknown size (the internal force
            # at the end, n(l_t)) holds the end at Z = end_height; no horizontal force.
            m_end = R.T @ self.M + _cross(self.offset, x[_N])
            force = R @ x[_N]
            return np.concatenate([x[_M] - m_end, force[:2], [x[2] - self.end_height]])
        n_end = R.T @ self.F
        if self.offset is None:  # Eq. (17) as printed: W_e^g about the global origin
            m_end = R.T @ (self.M - np.cross(x[_P], self.F))
        else:  # force applied at a point fixed to the end section, plus a couple
            m_end = R.T @ self.M + _cross(self.offset, n_end)
        return np.concatenate([x[_M] - m_end, x[_N] - n_end])

    def residual(self, X, want_jacobian=False):
        x = X.reshape(self.N + 1, 13).T
        xa, xb = x[:, :-1], x[:, 1:]
        wmid = 0.5 * (xa[_W] + xb[_W])
        xi = self.xi_ref + self.kinv[:, None] * wmid  # Eq. (8)
        ds = self.ds
        w_in = xa[_W]
        if self.wbar is not None:
            # Half the interval's distributed wrench before the transport, half after:
            # second order, like the strain at the midpoint.
            w_in = w_in - 0.5 * ds * self.wbar
        h1, dp, m1, n1, Q, E, d, R = _step_map(xa[_H], w_in[:3], w_in[3:], xi[:3], xi[3:],
                                               ds)
        r_step = np.concatenate([xb[_P] - xa[_P] - dp, xb[_H] - h1, xb[_M] - m1,
                                 xb[_N] - n1])
        if self.wbar is not None:
            r_step[_W] += 0.5 * ds * self.wbar
        r0 = np.concatenate([x[_P, 0] - self.ref.p0, x[_H, 0] - self.h0])  # Eq. (16)
        r_end = self._end_residual(x[:, -1])
        res = np.concatenate([r0, r_step.T.ravel(), r_end])
        if not want_jacobian:
            return res
        return res, self._jacobian(x, xa, w_in, xi, Q, E, d, R,
                                   np.concatenate([dp, h1, m1, n1]))

    def _jacobian(self, x, xa, w_in, xi, Q, E, d, R, out0):
        N = self.N
        ds = self.ds
        # Forward differences of the interval map in the six strains.
        D = np.empty((13, 6, N))
        for j in range(6):
            eps = 1e-7 * np.maximum(np.abs(xi[j]), 1.0 if j >= 3 else 1.0 / self.length_scale)
            xp = xi.copy()
            xp[j] += eps
            h1, dp, m1, n1, *_ = _step_map(xa[_H], w_in[:3], w_in[3:], xp[:3], xp[3:], ds,
                                           R)
            D[:, j, :] = (np.concatenate([dp, h1, m1, n1]) - out0) / eps
        G = -0.5 * D * self.kinv[None, :, None]  # d r / d W at either end of the interval
        A = np.zeros((13, 13, N))
        B = np.zeros((13, 13, N))
        eye3 = np.eye(3)[:, :, None]
        A[_P, _P] = -eye3
        A[_H, _H] = -Q
        for i in range(4):  # d (R(h) d) / d h, forward differences
            hp = xa[_H].copy()
            eps = 1e-7 * np.maximum(np.abs(hp[i]), 1.0)
            hp[i] += eps
            A[_P, 3 + i] = -(np.einsum('ijk,jk->ik', rotation_from_quaternion(hp), d)
                             - out0[_P]) / eps
        Et = np.transpose(E, (1, 0, 2))
        A[_M, _M] = -Et
        A[_M, _N] = np.einsum('ijk,jlk->ilk', Et, hat(d))
        A[_N, _N] = -Et
        A[:, _W] += G
        B[:, :] = np.eye(13)[:, :, None]
        B[:, _W] += G
        step = np.concatenate([A, B], axis=1)  # (13, 26, N)
        step = np.transpose(step, (2, 0, 1))
        xe = x[:, -1]
        r_end0 = self._end_residual(xe)
        J_end = np.empty((6, 13))
        for i in range(13):
            xp = xe.copy()
            eps = 1e-7 * max(abs(xp[i]), 1e-3 if i < 3 else 1.0)
            xp[i] += eps
            J_end[:, i] = (self._end_residual(xp) - r_end0) / eps
        data = np.concatenate([np.ones(7), step.ravel(), J_end.ravel()])
        n_unknown = 13 * (N + 1)
        band = np.zeros((2 * self.lower + self.upper + 1, n_unknown))
        band.flat[self.band_flat] = data
        return band

    def factor(self, band):
        """Return the banded LU factors (LAPACK gbtrf, partial pivoting) of J."""
        lu, piv, info = dgbtrf(band, self.lower, self.upper, overwrite_ab=True)
        if info != 0:
            raise np.linalg.LinAlgError(f'singular Jacobian (gbtrf info {info})')
        return lu, piv

    def solve(self, factors, rhs):
        """Solve J x = rhs with the factors of :meth:`factor`."""
        x, info = dgbtrs(factors[0], self.lower, self.upper, rhs, factors[1])
        return x

    def jacobian_matrix(self, band):
        """Return the Jacobian as a sparse matrix (for inspection and tests)."""
        n_unknown = 13 * (self.N + 1)
        return sp.csc_matrix((band[self.band_index], (self.rows, self.cols)),
                             shape=(n_unknown, n_unknown))

    def scaled_residual(self, res):
        """Return the residual made dimensionless per state component (strain-like)."""
        body = res[7:7 + 13 * self.N].reshape(self.N, 13) / self.scale
        return np.concatenate([res[:7] / self.scale[:7], body.ravel(),
                               res[-6:] / self.end_scale])

    def scaled_norm(self, res):
        """Return the max norm of the scaled residual (the convergence test)."""
        return float(np.max(np.abs(self.scaled_residual(res))))

    def scaled_step(self, dX):
        """Return the max norm of a state change made dimensionless."""
        return float(np.max(np.abs(dX.reshape(self.N + 1, 13) / self.scale)))

    def step_rms(self, dX):
        """Return the RMS of a state change made dimensionless (Deuflhard's level)."""
        d = dX.reshape(self.N + 1, 13) / self.scale
        return float(np.sqrt(np.mean(d * d)))

    def initial_guess(self):
        """Return the reference shape with the end wrench carried rigidly to each node."""
        p, h = integrate_strains(self.ref, self.s)
        R = rotation_from_quaternion(h)
        if self.offset is None:
            lever = -p
        else:
            lever = (p[:, -1] + R[:, :, -1] @ self.offset)[:, None] - p
        moment = self.M[:, None] + np.cross(lever, self.F[:, None], axis=0)
        m = np.einsum('jik,jk->ik', R, moment)
        n = np.einsum('jik,j->ik', R, self.F)
        return np.concatenate([p, h, m, n]).T.ravel()
