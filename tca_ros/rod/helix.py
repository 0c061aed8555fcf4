"""Exact uniform-helix equilibrium of a helical Cosserat rod under an axial wrench.

A uniform helix loaded by a force F along its axis (and a moment M about it)
deforms into another uniform helix: the body strains xi = [u, v] are constant, the
internal wrench W = K (xi - xi^h) is constant, and the statics (7) with no
distributed load reduces to ad_xi^T W = 0. By the symmetry of the helix about its
principal normal, u = [0, u2, u3] and v = [0, v2, v3]; then

    u x n = 0                      -> n = F u / |u|                      (a)
    u x m + v x n = 0              -> u2 m3 - u3 m2 + v2 n3 - v3 n2 = 0  (b)
    m . u / |u| = M  (free end)    or  |u| = |u_lock|  (rotation-locked)  (c)

with m = K_bt (u - u^h), n = K_se (v - v*) (Eq. (8)). (a) gives v from (u, F), so
two equations (b), (c) in (u2, u3) remain; they are solved by Newton's method with
the analytic Jacobian, vectorized over any number of load cases. All four strains
(bending, torsion, shear, extension) are kept: the solution is geometrically exact.

References
----------
[1] Sun et al., IEEE T-RO 2022, Eqs. (7), (8), (14), (15), (22).
"""
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class HelixEquilibrium:
    """Uniform-helix solution (arrays broadcast over load cases).

    Attributes
    ----------
    u, v : ndarray, shape (3, ...)
        Body strains: angular (1/m) and linear (-).
    m, n : ndarray, shape (3, ...)
        Internal moment (N m) and force (N) in the body frame.
    axial_stretch : ndarray
        Axial advance per arc length, v . u / |u| (-): l = l_t axial_stretch.
    radius : ndarray
        Coil radius of the deformed helix (m).
    turn_rate : ndarray
        |u|, turn angle of the frame about the coil axis per arc length (rad/m).
    axial_moment : ndarray
        m . u / |u| (N m), the moment about the coil axis.
    success : ndarray of bool
        Newton converged.
    n_iter : int
        Newton iterations used.
    """

    u: np.ndarray
    v: np.ndarray
    m: np.ndarray
    n: np.ndarray
    axial_stretch: np.ndarray
    radius: np.ndarray
    turn_rate: np.ndarray
    axial_moment: np.ndarray
    success: np.ndarray
    n_iter: int

    @property
    def pitch_angle(self):
        """Pitch angle of the deformed helix (rad): atan(axial / tangential advance)."""
        return np.arctan2(self.axial_stretch, self.radius * self.turn_rate)


def _residual_and_jacobian(u2, u3, force, moment, kh, th, EI, GJ, c_se, lock):
    """Return residuals (b), (c) and their 2x2 Jacobian (see module docstring)."""
    w2 = u2 * u2 + u3 * u3
    w = np.sqrt(w2)
    f2c = force * force * c_se
    r1 = (u2 * GJ * (u3 - th) - u3 * EI * (u2 - kh) - force * u2 / w
          + f2c * u2 * u3 / w2)
    j11 = (GJ * (u3 - th) - u3 * EI - force * (1.0 / w - u2 * u2 / (w2 * w))
           + f2c * (u3 / w2 - 2.0 * u2 * u2 * u3 / (w2 * w2)))
    j12 = (u2 * GJ - EI * (u2 - kh) + force * u2 * u3 / (w2 * w)
           + f2c * (u2 / w2 - 2.0 * u2 * u3 * u3 / (w2 * w2)))
    if lock is None:
        r2 = EI * (u2 - kh) * u2 + GJ * (u3 - th) * u3 - moment * w
        j21 = EI * (2.0 * u2 - kh) - moment * u2 / w
        j22 = GJ * (2.0 * u3 - th) - moment * u3 / w
    else:
        r2 = w - lock
        j21 = u2 / w
        j22 = u3 / w
    return r1, r2, j11, j12, j21, j22


def uniform_helix_equilibrium(force, u_rest, stiffness, moment=0.0, turn_rate_lock=None,
                              tol=1e-13, max_iter=50):
    """Return the exact uniform-helix equilibrium under an axial wrench.

    Solves ad_xi^T K (xi - xi^h) = 0 (Eqs. (7), (8) with constant strains) for a
    helix whose heated reference strains are u^h = [0, kappa_h, tau_h], v^h = e3.

    Parameters
    ----------
    force : float or ndarray
        Axial force F (N) along the coil axis, tensile positive (the force the
        external load applies to the free end, towards the free end).
    u_rest : tuple of (float or ndarray)
        (kappa_h, tau_h): heated reference curvature and torsion (1/m), Eq. (15).
    stiffness : tuple of (float or ndarray)
        (EI, GJ, GA, EA): bending, torsion (N m^2), shear, extension (N) stiffness,
        Eq. (8). ``np.inf`` for GA and EA gives the Kirchhoff (inextensible,
        unshearable) rod.
    moment : float or ndarray, optional
        Axial moment M (N m) about the coil axis at the free end (free end only).
    turn_rate_lock : float or ndarray, optional
        If given, the end is rotation-locked: |u| is held at this value (rad/m), e.g.
        the ambient reference turn rate, so the coil angle l_t |u| is fixed, and the
        axial moment is an output.
    tol : float
        Convergence tolerance on the Newton step relative to |u^h| (-).
    max_iter : int
        Newton iteration limit.

    Returns
    -------
    HelixEquilibrium
    """
    kh, th = (np.asarray(x, dtype=float) for x in u_rest)
    EI, GJ, GA, EA = (np.asarray(x, dtype=float) for x in stiffness)
    force = np.asarray(force, dtype=float)
    moment = np.asarray(moment, dtype=float)
    if np.any(kh <= 0.0):
        raise ValueError('u_rest[0] (kappa_h): must be > 0 1/m for a helix')
    if np.any(EI <= 0.0) or np.any(GJ <= 0.0) or np.any(GA <= 0.0) or np.any(EA <= 0.0):
        raise ValueError('stiffness: EI, GJ, GA, EA must all be > 0')
    shape = np.broadcast(force, moment, kh, th, EI, GJ, GA, EA).shape
    c_se = 1.0 / GA - 1.0 / EA
    u2 = np.broadcast_to(kh, shape).astype(float)
    u3 = np.broadcast_to(th, shape).astype(float)
    scale = np.hypot(u2, u3)
    lock = None if turn_rate_lock is None else np.asarray(turn_rate_lock, dtype=float)
    converged = np.zeros(shape, dtype=bool)
    n_iter = 0
    for n_iter in range(1, max_iter + 1):
        r1, r2, j11, j12, j21, j22 = _residual_and_jacobian(
            u2, u3, force, moment, kh, th, EI, GJ, c_se, lock)
        det = j11 * j22 - j12 * j21
        d2 = (r1 * j22 - r2 * j12) / det
        d3 = (j11 * r2 - j21 * r1) / det
        # Limit a step to a fifth of |u|: keeps the iterate a helix on large loads.
        size = np.hypot(d2, d3)
        limit = 0.2 * np.hypot(u2, u3)
        damp = np.where(size > limit, limit / np.where(size > 0, size, 1.0), 1.0)
        u2 = u2 - damp * d2
        u3 = u3 - damp * d3
        converged = np.isfinite(size) & (size <= tol * scale)
        if np.all(converged):
            break
    w = np.hypot(u2, u3)
    n2, n3 = force * u2 / w, force * u3 / w
    v2 = n2 / GA
    v3 = 1.0 + n3 / EA
    m2 = EI * (u2 - kh)
    m3 = GJ * (u3 - th)
    zero = np.zeros(shape)
    axial = (v2 * u2 + v3 * u3) / w
    radius = np.abs(v2 * u3 - v3 * u2) / (w * w)
    return HelixEquilibrium(
        u=np.array([zero, u2, u3]), v=np.array([zero, v2 + zero, v3 + zero]),
        m=np.array([zero, m2, m3]), n=np.array([zero, n2, n3]), axial_stretch=axial,
        radius=radius, turn_rate=w, axial_moment=(m2 * u2 + m3 * u3) / w,
        success=converged & np.isfinite(axial), n_iter=n_iter)


def helix_centreline(equilibrium, length, n_points):
    """Return positions (3, n_points) (m) of a uniform helix on the global Z axis.

    The helix starts at angle 0 on the +X side at z = 0 and descends along -Z, the
    free-stroke clamp convention of Eq. (16); this is the shape away from the clamp.

    Parameters
    ----------
    equilibrium : HelixEquilibrium
        A single (scalar) solution.
    length : float
        Fiber length l_t (m).
    n_points : int
        Number of points, >= 2.
    """
    if n_points < 2:
        raise ValueError(f'n_points = {n_points!r}: must be >= 2')
    s = np.linspace(0.0, length, n_points)
    rho = float(equilibrium.radius)
    # Right-handed helix descending -Z: the coiling angle decreases about +Z.
    angle = -float(equilibrium.turn_rate) * s
    return np.array([rho * np.cos(angle), rho * np.sin(angle),
                     -float(equilibrium.axial_stretch) * s])
