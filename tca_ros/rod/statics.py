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
See docs/rod.md for why this method was chosen (measurements). The discretized
problem (residual, banded Jacobian, LU) is collocation.py's; Newton is here.

References
----------
[1] Sun et al., IEEE T-RO 2022, Eqs. (6)-(8), (16), (17), (32), Algorithm 1.
"""
from dataclasses import dataclass

import numpy as np

from tca_ros.rod.collocation import _H, _M, _N, _P, CollocationProblem, N_STATE
from tca_ros.rod.helix import uniform_helix_equilibrium
from tca_ros.rod.reference import integrate_strains, RodReference
from tca_ros.rod.so3 import quaternion_from_rotation, rotation_from_quaternion

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
    prob = CollocationProblem(reference, K, end_force, end_moment, int(n_steps),
                              distributed_wrench, end_load_offset, end_height)
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
