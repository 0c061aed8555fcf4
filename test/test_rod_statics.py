"""Tests of the full-length Cosserat rod BVP solver (tca_ros.rod.statics)."""
import numpy as np
import pytest

from tca_ros.model.moduli import section_stiffness
from tca_ros.model.rod_model import rod_reference, stiffness_vector
from tca_ros.rod.helix import uniform_helix_equilibrium
from tca_ros.rod.reference import helix_reference, helix_strain, RodReference
from tca_ros.rod.statics import solve_continuation, solve_rod_statics


@pytest.fixture(scope='module')
def loaded_free_stroke(free_stroke):
    """Full-length free-stroke TCA (63 coils) with 30 g on a cap on the coil axis."""
    load = 0.3  # N
    ref = rod_reference(free_stroke, 25.0)
    K = stiffness_vector(free_stroke, 25.0, load)
    sol = solve_rod_statics(ref, K, end_force=[0.0, 0.0, -load],
                            end_load_offset=(free_stroke.coil.radius, 0.0, 0.0))
    return ref, K, load, sol


def test_zero_load_at_ambient_recovers_reference_helix(free_stroke):
    c = free_stroke.coil
    ref = rod_reference(free_stroke, free_stroke.thermal.ambient_temperature)
    sol = solve_rod_statics(ref, stiffness_vector(free_stroke, 25.0, 0.0))
    assert sol.success
    s = sol.s
    np.testing.assert_allclose(np.hypot(sol.positions[0], sol.positions[1]), c.radius,
                               rtol=1e-12)  # 505 exact steps, round-off only
    np.testing.assert_allclose(sol.positions[2], -s * np.sin(c.pitch_angle), atol=1e-15)
    np.testing.assert_allclose(np.r_[sol.m, sol.n], 0.0, atol=1e-15)


def test_rotations_stay_orthonormal(loaded_free_stroke):
    sol = loaded_free_stroke[3]
    assert sol.success
    RtR = np.einsum('jik,jlk->ilk', sol.frames, sol.frames)
    np.testing.assert_allclose(RtR - np.eye(3)[:, :, None], 0.0, atol=1e-13)
    np.testing.assert_allclose(np.linalg.norm(sol.quaternions, axis=0), 1.0, atol=1e-12)


def test_full_bvp_agrees_with_exact_helix_away_from_clamp(free_stroke, loaded_free_stroke):
    ref, K, load, sol = loaded_free_stroke
    c = free_stroke.coil
    u, v = sol.strains(K, ref)
    kappa, tau = helix_strain(c.radius, c.pitch_angle)
    eq = uniform_helix_equilibrium(load, ref.strain(np.zeros(1))[0][1:, 0],
                                   (K[0], K[2], K[3], K[5]))
    middle = (sol.s > 0.2 * ref.length) & (sol.s < 0.8 * ref.length)
    # The clamp boundary layer decays within a few coils; 12 coils in, strains agree
    # to 1e-6 of |u| (measured ~1e-8).
    np.testing.assert_allclose(u[:, middle], np.repeat(eq.u[:, None], middle.sum(), 1),
                               atol=1e-6 * np.hypot(kappa, tau))
    np.testing.assert_allclose(v[:, middle], np.repeat(eq.v[:, None], middle.sum(), 1),
                               atol=1e-6)
    # Elongation: the end layers shift it by under 0.2 % of the 12 mm load elongation.
    y_bvp = sol.positions[2, 0] - sol.positions[2, -1] - ref.length * np.sin(c.pitch_angle)
    y_exact = ref.length * (eq.axial_stretch - np.sin(c.pitch_angle))
    assert y_bvp == pytest.approx(y_exact, rel=2e-3)


def _end_position(ref, K, n_steps, force):
    sol = solve_rod_statics(ref, K, end_force=force, n_steps=n_steps)
    assert sol.success
    return sol.positions[:, -1]


def test_mesh_convergence_is_second_order(free_stroke):
    """A 2-coil helix with a lateral end force has a non-uniform strain field."""
    c = free_stroke.coil
    ref = helix_reference(c.radius, c.pitch_angle, 2.0 * 2 * np.pi * c.radius
                          / np.cos(c.pitch_angle))
    K = stiffness_vector(free_stroke, 25.0, 0.0)
    force = np.array([0.05, 0.0, -0.2])  # N
    exact = _end_position(ref, K, 2048, force)
    errors = [np.linalg.norm(_end_position(ref, K, n, force) - exact) for n in (32, 64, 128)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    np.testing.assert_allclose(orders, 2.0, atol=0.15)  # midpoint strain: order 2


def test_end_force_work_equals_strain_energy(free_stroke):
    """Clapeyron: for a small load, F . u_load / 2 = 1/2 int dxi^T K dxi ds."""
    c = free_stroke.coil
    ref = helix_reference(c.radius, c.pitch_angle, 0.02)
    K = stiffness_vector(free_stroke, 25.0, 0.0)
    force = np.array([0.0, 0.0, -1e-3])  # N; nonlinearity ~ 1e-4 relative
    offset = np.array([c.radius, 0.0, 0.0])
    sol0 = solve_rod_statics(ref, K, n_steps=800)
    sol = solve_rod_statics(ref, K, end_force=force, end_load_offset=offset, n_steps=800)
    assert sol.success

    def load_point(s):
        return s.positions[:, -1] + s.frames[:, :, -1] @ offset
    work = 0.5 * force @ (load_point(sol) - load_point(sol0))
    W = np.r_[sol.m, sol.n]
    density = 0.5 * np.sum(W * W / K[:, None], axis=0)
    energy = np.sum(0.5 * (density[1:] + density[:-1]) * np.diff(sol.s))
    assert energy == pytest.approx(work, rel=2e-3)  # O(F) nonlinearity + O(ds^2)


def _straight_reference(length):
    def strain(s):
        n = np.size(s)
        return np.zeros((3, n)), np.repeat(np.array([[0.0], [0.0], [1.0]]), n, axis=1)
    return RodReference(length=length, p0=np.zeros(3), R0=np.eye(3), strain=strain,
                        n_coils=0.0, name='straight')


def test_cantilever_closed_forms(free_stroke):
    """User-supplied straight reference: P L^3/(3 EI) and q L^4/(8 EI) tip deflections."""
    length = 0.01
    K = stiffness_vector(free_stroke, 25.0, 0.0)
    ref = _straight_reference(length)
    EI, GA = K[0], K[3]
    P = 1e-7  # N; deflection/L ~ 2e-4, geometric nonlinearity ~ 1e-7 relative
    tip = solve_rod_statics(ref, K, end_force=[P, 0.0, 0.0], n_steps=200)
    expected = P * length ** 3 / (3 * EI) + P * length / GA  # bending + shear
    assert tip.positions[0, -1] == pytest.approx(expected, rel=1e-4)
    q = 1e-5  # N/m, body-frame distributed force along x
    dist = solve_rod_statics(ref, K, distributed_wrench=[0, 0, 0, q, 0, 0], n_steps=200)
    assert dist.positions[0, -1] == pytest.approx(
        q * length ** 4 / (8 * EI) + q * length ** 2 / (2 * GA), rel=1e-3)  # O(ds^2)


def test_non_convergence_is_reported_not_raised(loaded_free_stroke):
    ref, K, load, _ = loaded_free_stroke
    sol = solve_rod_statics(ref, K, end_force=[0.0, 0.0, -2 * load], max_iter=1,
                            end_load_offset='origin')
    assert not sol.success
    assert sol.message


@pytest.mark.parametrize('kwargs, match', [
    (dict(stiffness=[1.0, 1.0]), 'stiffness'),
    (dict(end_force=[0.0, 1.0]), 'end_force'),
    (dict(end_load_offset='cap'), 'end_load_offset'),
    (dict(n_steps=1), 'n_steps')])
def test_bad_inputs_raise_value_error(free_stroke, kwargs, match):
    args = dict(reference=rod_reference(free_stroke, 25.0),
                stiffness=stiffness_vector(free_stroke, 25.0, 0.0))
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        solve_rod_statics(**args)


def test_load_continuation_with_origin_wrench_on_a_short_rod(free_stroke):
    """Eq. (17) as printed (W_e^g about the origin) converges for a few coils."""
    c = free_stroke.coil
    ref = helix_reference(c.radius, c.pitch_angle, 0.01)
    sec = section_stiffness(25.0, 0.0, free_stroke)
    K = np.array([sec.EI, sec.EI, sec.GJ, sec.GA, sec.GA, sec.EA])

    def problem(load):
        return dict(reference=ref, stiffness=K, end_force=np.array([0.0, 0.0, -load]),
                    end_load_offset='origin')
    sols = solve_continuation(problem, [0.1, 0.2, 0.3])
    assert all(s.success for s in sols)
    drops = [s.positions[2, 0] - s.positions[2, -1] for s in sols]
    assert drops[0] < drops[1] < drops[2]  # more load, longer coil


def test_independent_collocation_agrees(loaded_free_stroke, free_stroke):
    """scipy's solve_bvp on the plain ODEs (6)-(8), (32) lands on the same end point."""
    from scipy.integrate import solve_bvp

    from tca_ros.rod.so3 import quaternion_derivative, quaternion_from_rotation
    from tca_ros.rod.so3 import rotation_from_quaternion
    ref, K, load, sol = loaded_free_stroke
    kinv = 1.0 / K
    force = np.array([0.0, 0.0, -load])
    offset = np.array([free_stroke.coil.radius, 0.0, 0.0])
    h0 = quaternion_from_rotation(ref.R0)

    def rhs(s, y):
        u_ref, v_ref = ref.strain(s)
        u = u_ref + kinv[:3, None] * y[7:10]
        v = v_ref + kinv[3:, None] * y[10:13]
        R = rotation_from_quaternion(y[3:7])
        return np.concatenate([np.einsum('ijk,jk->ik', R, v), quaternion_derivative(y[3:7], u),
                               -np.cross(u, y[7:10], axis=0) - np.cross(v, y[10:13], axis=0),
                               -np.cross(u, y[10:13], axis=0)])

    def bc(ya, yb):
        n_end = rotation_from_quaternion(yb[3:7]).T @ force
        return np.concatenate([ya[:3] - ref.p0, ya[3:7] - h0,
                               yb[7:10] - np.cross(offset, n_end), yb[10:13] - n_end])
    other = solve_bvp(rhs, bc, sol.s, sol.state().T, tol=1e-3, max_nodes=20000)
    assert other.status == 0
    a, b = other.y[:3, -1], sol.positions[:, -1]
    # Axial drop to 1 um against a 12 mm load elongation (measured 0.2 um); laterally to
    # 10 um (2 % of the coil radius): the end's turn angle, 396 rad in all, is only good
    # to ~0.01 rad at solve_bvp's tol 1e-3.
    assert a[2] == pytest.approx(b[2], abs=1e-6)
    assert np.hypot(a[0] - b[0], a[1] - b[1]) < 1e-5


def test_height_control_returns_the_force_that_holds_the_end_there(free_stroke):
    """Held at the height a force-controlled solve reaches, the end needs that force."""
    c = free_stroke.coil
    ref = helix_reference(c.radius, c.pitch_angle, 0.01)
    K = stiffness_vector(free_stroke, 25.0, 0.0)
    load = 0.05  # N, a hanging weight along -Z through the fiber's end point
    loaded = solve_rod_statics(ref, K, end_force=[0.0, 0.0, -load], n_steps=80)
    held = solve_rod_statics(ref, K, n_steps=80, initial=solve_rod_statics(ref, K, n_steps=80),
                             end_height=loaded.positions[2, -1])
    assert loaded.success and held.success
    np.testing.assert_allclose(held.end_force(), [0.0, 0.0, -load], atol=1e-9 * load + 1e-12)
    np.testing.assert_allclose(held.positions, loaded.positions, atol=1e-9)
    with pytest.raises(ValueError, match='end_height'):
        solve_rod_statics(ref, K, end_height=0.0, end_load_offset='origin')
