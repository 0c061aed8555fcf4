"""Full-length Cosserat rod statics: a Lie-group collocation BVP solver.

Unknowns at every node s_k: position p (3), non-unit quaternion h (4), internal moment
m (3) and force n (3) in the body frame (Eqs. (6), (7), (32)). On each interval the
strain is taken constant, xi_k = xi^h(s_mid) + K^-1 (W_k + W_k+1) / 2 (Eq. (8)), and
the interval is mapped exactly for that constant strain:

    h_k+1 = exp(ds Omega(u) / 2) h_k                      (32), exact
    p_k+1 = p_k + R(h_k) ds T(ds u) v                      (6), exact screw motion
    W_k+1 = Ad^T_exp(ds xi) (W_k - ds/2 W_bar_e) - ds/2 W_bar_e   (7): the global
                                      wrench is constant between distributed loads

with the clamp (16) at s = 0 and the end wrench (17) at s = l_t. A uniform helix is
therefore reproduced exactly on any mesh; non-uniform fields converge at second
order. Newton's method with a block-banded Jacobian (analytic blocks plus forward
differences in the six strain components, vectorized over intervals), LAPACK's
banded LU and Deuflhard's natural-monotonicity damping solves all nodes at once.
See docs/rod.md for why this method was chosen (measurements).

References
----------
[1] Sun et al., IEEE T-RO 2022, Eqs. (6)-(8), (16), (17), (32), Algorithm 1.
"""
from dataclasses import dataclass
import functools

import numpy as np
from scipy.linalg.lapack import dgbtrf, dgbtrs
import scipy.sparse as sp

from tca_ros.rod.helix import uniform_helix_equilibrium
from tca_ros.rod.reference import integrate_strains, RodReference
from tca_ros.rod.so3 import hat, quaternion_from_rotation, quaternion_step
from tca_ros.rod.so3 import rotation_from_quaternion, screw_exp

N_STATE = 13  # p (3), h (4), m (3), n (3) per node
_P, _H, _M, _N = slice(0, 3), slice(3, 7), slice(7, 10), slice(10, 13)
_W = slice(7, 13)
NEWTON_BASIN_STEP = 1e-3  # scaled step below which Newton converges quadratically here


@dataclass
class RodSolution:
    """Equilibrium of a Cosserat rod on a mesh (sample axis last).

    Attributes
    ----------
    s : ndarray, shape (n,)
        Arc length of the nodes (m).
    positions : ndarray, shape (3, n)
        Centreline p(s) in the global frame (m).
    quaternions : ndarray, shape (4, n)
        Orientation h(s) (non-unit quaternion, Eq. (32)).
    frames : ndarray, shape (3, 3, n)
        R(s) = R(h(s)).
    m, n : ndarray, shape (3, n)
        Internal moment (N m) and force (N) in the body frame.
    success : bool
        Newton converged to the tolerances.
    message : str
        Why it stopped.
    n_iter : int
        Newton iterations.
    residual : float
        Final scaled max-norm residual (-).
    helix_state : ndarray or None
        The exact-helix node states (n, 13) of this load case (see
        :func:`helix_initial_state`); a warm start from this solution is shifted by
        the change of the exact helix (a predictor), None for other shapes.
    """

    s: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    frames: np.ndarray
    m: np.ndarray
    n: np.ndarray
    success: bool
    message: str
    n_iter: int
    residual: float
    helix_state: object = None

    def strains(self, stiffness, reference):
        """Return the body strains, Eq. (8) inverted: xi = xi^h + K^-1 W.

        Returns u (1/m) and v (-), each (3, n).
        """
        kinv = 1.0 / np.asarray(stiffness, dtype=float)
        u_ref, v_ref = reference.strain(self.s)
        return u_ref + kinv[:3, None] * self.m, v_ref + kinv[3:, None] * self.n

    def end_force(self):
        """Return the external force on the free end (N), global frame: R(l_t) n(l_t)."""
        return self.frames[:, :, -1] @ self.n[:, -1]

    def state(self):
        """Return the node states stacked as (n, 13): p, h, m, n."""
        return np.concatenate([self.positions, self.quaternions, self.m, self.n]).T


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


class _Problem:
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


def helix_initial_state(reference, stiffness, end_force, end_moment, s):
    """Return node states (n, 13) on the exact deformed helix aligned with the load axis.

    For a helical reference (constant strain, axis on global Z through the origin) and
    an end wrench along Z, the equilibrium away from the clamp is the uniform helix of
    :func:`tca_ros.rod.helix.uniform_helix_equilibrium`. It is placed on the Z axis
    with its body x axis (the radial direction) equal to the clamp's, its frame
    rotated about body x by the change of the axis angle. Newton then only has to
    resolve the clamp boundary layer: a 63-coil spring is laterally so compliant that
    cold starts from the unloaded shape diverge (docs/rod.md).

    Returns None when the reference is not a uniform helix or the load is off-axis.
    """
    K = np.asarray(stiffness, dtype=float)
    F = np.asarray(end_force, dtype=float)
    M = np.asarray(end_moment, dtype=float)
    u_all, v_all = reference.strain(np.array([0.0, 0.5, 1.0]) * reference.length)
    uniform = np.allclose(u_all, u_all[:, :1], rtol=1e-12, atol=0.0) and np.allclose(
        v_all, [[0.0], [0.0], [1.0]], rtol=0.0, atol=1e-15)
    if not uniform or abs(u_all[0, 0]) > 0.0 or np.any(F[:2] != 0.0) or np.any(M[:2] != 0):
        return None
    kh, th = u_all[1, 0], u_all[2, 0]
    if not kh > 0.0:
        return None
    down = reference.R0.T @ np.array([0.0, 0.0, -1.0])  # global -Z in the clamp frame
    if abs(down[0]) > 1e-9:
        return None
    eq = uniform_helix_equilibrium(-F[2], (kh, th), (K[0], K[2], K[3], K[5]),
                                   moment=-M[2])
    if not bool(eq.success):
        return None
    u, v = np.asarray(eq.u, float), np.asarray(eq.v, float)
    delta = np.arctan2(down[2], down[1]) - np.arctan2(u[2], u[1])
    c, sn = np.cos(delta), np.sin(delta)
    R_a = reference.R0 @ np.array([[1.0, 0.0, 0.0], [0.0, c, -sn], [0.0, sn, c]])
    rho = (u[1] * v[2] - u[2] * v[1]) / (u[1] ** 2 + u[2] ** 2)
    p_a = -rho * (R_a @ np.array([1.0, 0.0, 0.0]))
    p_a[2] = reference.p0[2]
    ref = RodReference(length=reference.length, p0=p_a, R0=R_a, strain=None, n_coils=0.0)
    n_int = s.size - 1
    h_a = quaternion_from_rotation(R_a)
    if h_a @ quaternion_from_rotation(reference.R0) < 0.0:
        h_a = -h_a  # same sheet of the double cover as the clamp condition
    p, h = integrate_strains(ref, s, np.repeat(u[:, None], n_int, axis=1),
                             np.repeat(v[:, None], n_int, axis=1), h0=h_a)
    m = np.repeat(np.asarray(eq.m, float)[:, None], s.size, axis=1)
    n = np.repeat(np.asarray(eq.n, float)[:, None], s.size, axis=1)
    return np.concatenate([p, h, m, n]).T


def default_steps(reference, steps_per_coil=8):
    """Return a mesh size: ``steps_per_coil`` intervals per reference turn, >= 16."""
    return int(max(16, np.ceil(reference.n_coils * steps_per_coil)))


def solve_rod_statics(reference, stiffness, end_force=(0.0, 0.0, 0.0),
                      end_moment=(0.0, 0.0, 0.0), end_load_offset=(0.0, 0.0, 0.0),
                      n_steps=None, initial=None, distributed_wrench=None, tol=1e-10,
                      max_iter=30, end_height=None):
    """Solve the Cosserat rod BVP, Eqs. (6)-(8) with the clamp (16) and end wrench (17).

        p' = R v, h' = Omega(u) h / 2, W' = ad_xi^T W - W_bar_e, W = K (xi - xi^h)

    Parameters
    ----------
    reference : RodReference
        Clamp pose and (heated) reference strains xi^h(s).
    stiffness : array_like, shape (6,)
        Diagonal of K = diag(EI, EI, GJ, GA, GA, EA): N m^2 (first three), N (last).
    end_force, end_moment : array_like, shape (3,)
        External force (N) on the free end and external couple (N m), both in the
        global frame, e.g. [0, 0, -m g] for a hanging weight (a dead load).
    end_load_offset : array_like (3,) or 'origin'
        Where the end force acts: a point fixed to the end section, given in the end
        body frame relative to the centroid (m), e.g. [r*, 0, 0] for a rigid cap whose
        hook is on the coil axis; default the fiber's end point. 'origin' applies
        Eq. (17) as printed, W_e^g about the global origin: the load line is then
        fixed in space, which makes a long coil's equilibrium exponentially
        sensitive to the clamp (docs/rod.md), so it suits short rods only.
    n_steps : int, optional
        Number of intervals; default :func:`default_steps` (8 per coil).
    initial : RodSolution, optional
        Warm start on the same mesh (e.g. the previous continuation step).
    distributed_wrench : array_like (6,) or (6, n_steps), or callable, optional
        W_bar_e = [l_bar, f_bar] per length in the body frame (N m/m, N/m) at the
        interval midpoints; a callable takes s (n_steps,) in m.
    tol : float
        Newton tolerance on the scaled step and residual (-), strain-like units.
    max_iter : int
        Newton iteration limit.
    end_height : float, optional
        Height control (m): hold the free end at global Z = end_height by a vertical
        end force whose size is solved for (``end_force`` is then ignored; read the
        force as :meth:`RodSolution.end_force`). Follows a branch through the limit
        points of the load-controlled problem (docs/rod.md, conical TCA).

    Returns
    -------
    RodSolution
        ``success`` is False (never an exception) if Newton did not converge.
    """
    K = np.asarray(stiffness, dtype=float)
    n_steps = default_steps(reference) if n_steps is None else n_steps
    _check_arguments(K, stiffness, end_force, end_moment, end_load_offset, end_height, n_steps)
    prob = _Problem(reference, K, end_force, end_moment, int(n_steps), distributed_wrench,
                    end_load_offset, end_height)
    guess = helix_initial_state(reference, K, end_force, end_moment, prob.s)
    X = _start_state(prob, guess, initial, n_steps)
    X, norm, success, message, n_iter = _damped_newton(prob, X, tol, max_iter)
    x = X.reshape(n_steps + 1, 13).T
    return RodSolution(s=prob.s, positions=x[_P].copy(), quaternions=x[_H].copy(),
                       frames=rotation_from_quaternion(x[_H]), m=x[_M].copy(),
                       n=x[_N].copy(), success=success, message=message, n_iter=n_iter,
                       residual=float(norm), helix_state=guess)


def _check_arguments(K, stiffness, end_force, end_moment, end_load_offset, end_height,
                     n_steps):
    """Raise ValueError (one line: name, value, what is allowed) for a bad argument."""
    if K.shape != (6,) or not np.all(K > 0.0):
        raise ValueError(f'stiffness = {stiffness!r}: must be 6 positive values')
    for name, val in (('end_force', end_force), ('end_moment', end_moment)):
        if np.shape(val) != (3,) or not np.all(np.isfinite(val)):
            raise ValueError(f'{name} = {val!r}: must be 3 finite values')
    if end_height is not None and (isinstance(end_load_offset, str)
                                   or not np.isfinite(end_height)):
        raise ValueError(f'end_height = {end_height!r}: must be finite, with the load on '
                         'a point of the end section (not end_load_offset="origin")')
    if isinstance(end_load_offset, str):
        if end_load_offset != 'origin':
            raise ValueError(f'end_load_offset = {end_load_offset!r}: must be 3 values '
                             'or "origin"')
    elif np.shape(end_load_offset) != (3,) or not np.all(np.isfinite(end_load_offset)):
        raise ValueError(f'end_load_offset = {end_load_offset!r}: must be 3 finite values')
    if int(n_steps) < 2:
        raise ValueError(f'n_steps = {n_steps!r}: must be >= 2')


def _start_state(prob, guess, initial, n_steps):
    """Return Newton's first state vector (flat, 13 per node).

    A RodSolution on the same mesh is a warm start, moved by the change of the
    exact helix ``guess`` (the far field) while its clamp boundary layer is kept;
    a (n_steps + 1, 13) array is taken as it is; else the helix, or the
    problem's own guess where no helix fits.
    """
    if isinstance(initial, RodSolution) and initial.s.size == n_steps + 1:
        X = initial.state().ravel().copy()
        if guess is not None and initial.helix_state is not None:
            # Predictor: keep the clamp boundary layer, move the far field exactly.
            X += (guess - initial.helix_state).ravel()
        return X
    if initial is not None and np.shape(initial) == (n_steps + 1, N_STATE):
        return np.asarray(initial, dtype=float).ravel().copy()
    return prob.initial_guess() if guess is None else guess.ravel()


def _damped_newton(prob, X, tol, max_iter):
    """Return (state, scaled residual, success, message, iterations) of damped Newton.

    Converged when the scaled residual is at ``tol`` after a step small enough
    to be in Newton's basin (NEWTON_BASIN_STEP); never raises on failure.
    """
    res, J = prob.residual(X, want_jacobian=True)
    norm = prob.scaled_norm(res)
    message = 'maximum iterations reached'
    success = False
    n_iter = 0
    for n_iter in range(1, max_iter + 1):
        try:
            factors = prob.factor(J)
        except np.linalg.LinAlgError as exc:
            message = f'linear solve failed: {exc}'
            break
        dX = -prob.solve(factors, res)
        if not np.all(np.isfinite(dX)):
            message = 'linear solve gave non-finite step'
            break
        level = prob.step_rms(dX)
        alpha = 1.0
        # Damping by Deuflhard's natural monotonicity test: the simplified Newton
        # correction at the trial point, J(x)^-1 F(x + alpha dX), must shrink. It is
        # affine invariant, so a step is not refused for a tiny but badly scaled
        # residual (a plain residual test stalls on the compliant conical coil).
        for _ in range(12):
            X_new = X + alpha * dX
            res_new = prob.residual(X_new)
            norm_new = prob.scaled_norm(res_new)
            if norm_new <= tol:
                break
            if np.isfinite(norm_new):
                simplified = prob.step_rms(prob.solve(factors, res_new))
                if simplified <= (1.0 - 0.5 * alpha) * level or level <= tol:
                    break
            alpha *= 0.5
        else:
            message = f'damping failed at scaled residual {norm:.3g}'
            break
        X, norm = X_new, norm_new
        step = alpha * prob.scaled_step(dX)
        # Residual at tolerance after a step small enough to be in Newton's basin.
        if norm <= tol and step <= NEWTON_BASIN_STEP:
            success = True
            message = 'converged'
            break
        res, J = prob.residual(X, want_jacobian=True)
    return X, norm, success, message, n_iter


def solve_continuation(problem, parameters, n_steps=None, initial=None, max_halvings=6,
                       **solver_options):
    """Solve a sequence of rod statics problems with warm starts (Algorithm 1 of [1]).

    Each problem is warm-started from the previous converged solution. If a step
    fails, intermediate parameter values are inserted by bisection (at most
    ``max_halvings`` levels) before giving up on that value.

    Parameters
    ----------
    problem : callable
        ``problem(lam) -> dict`` of :func:`solve_rod_statics` keyword arguments
        (``reference``, ``stiffness``, ``end_force``, ...) at parameter ``lam``
        (e.g. a load in N or a temperature in degC).
    parameters : sequence of float
        Parameter values, in continuation order.
    n_steps : int, optional
        Mesh size (fixed for the whole sequence so that warm starts apply).
    initial : RodSolution, optional
        Converged solution at ``parameters[0]``'s predecessor.
    max_halvings : int
        Bisection depth on failure.

    Returns
    -------
    list of RodSolution
        One per parameter; a failed one has ``success`` False.
    """
    out = []
    last_lam, last = None, initial
    for lam in parameters:
        sol = None
        if last_lam is None:
            sol = solve_rod_statics(n_steps=n_steps, initial=last, **problem(lam),
                                    **solver_options)
            if n_steps is None:
                n_steps = sol.s.size - 1
        else:
            sol = _bisect_to(problem, last_lam, lam, last, n_steps, max_halvings,
                             solver_options)
        out.append(sol)
        if sol.success:
            last_lam, last = lam, sol
    return out


def _bisect_to(problem, lam0, lam1, sol0, n_steps, depth, options):
    sol = solve_rod_statics(n_steps=n_steps, initial=sol0, **problem(lam1), **options)
    if sol.success or depth <= 0:
        return sol
    mid_lam = 0.5 * (lam0 + lam1)
    mid = _bisect_to(problem, lam0, mid_lam, sol0, n_steps, depth - 1, options)
    if not mid.success:
        return mid
    return _bisect_to(problem, mid_lam, lam1, mid, n_steps, depth - 1, options)
