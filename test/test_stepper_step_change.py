"""The central-difference stepper of eq. (18) across a change of its step length.

q_{i-1} carries the velocity of the central difference; when the substep length
changes (``set_dt``, or a re-planned substep count) it is moved to q(t_i - h_new)
(``rescaled_previous``), so the motion continues without a kick (issue 11, item 5:
13-30 um before the fix).
"""
import numpy as np
import pytest

from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.end_motion import central_difference_acceleration, rescaled_previous

POWER = 1.0  # W: the free-stroke TCA contracts ~mm/s at the switch
SWITCH = 1.0  # s
END = 1.9  # s, a whole number of 60 ms steps after SWITCH


def _run(params, dt_before, dt_after, model=None):
    """Return (time, displacement) of a heating run that changes dt at SWITCH."""
    sim = TcaSimulator(params, model=model, dt=dt_before)
    times, xs = [], []
    while sim.state.time < SWITCH - 1e-9:
        sim.step(POWER)
    sim.set_dt(dt_after)
    while sim.state.time < END - 1e-9:
        s = sim.step(POWER)
        times.append(s.time)
        xs.append(s.displacement)
    return np.array(times), np.array(xs)


@pytest.fixture(scope='module')
def fine(free_stroke):
    """A reference run at 0.25 ms throughout, per model."""
    return {m: _run(free_stroke, 2.5e-4, 2.5e-4, m) for m in ('cst', 'rod')}


@pytest.mark.parametrize('model, dt_after, tolerance', [
    ('cst', 0.06, 1e-7),  # measured 4 nm (2 substeps of 30 ms); before the fix 22 um
    ('cst', 5e-4, 1e-7),  # measured 0.1 nm; before 31 um
    ('rod', 0.01, 2e-7),  # measured 33 nm (the 10 ms step's own error); before 26 um
])
def test_changing_dt_mid_run_leaves_no_kick(free_stroke, fine, model, dt_after, tolerance):
    """After 1 ms -> dt_after at 1 s the run follows a 0.25 ms run (m).

    Each tolerance is a few times the measured error and 100x below the kick the
    stepper gave before q_{i-1} was rescaled.
    """
    t, x = _run(free_stroke, 1e-3, dt_after, model)
    t_ref, x_ref = fine[model]
    assert np.max(np.abs(x - np.interp(t, t_ref, x_ref))) < tolerance
    assert x[-1] > 1e-3  # it did move: > 1 mm of contraction by the end


def test_rescaled_previous_is_exact_for_uniform_acceleration():
    """q(t) = q0 + v t + a t^2 / 2 is rescaled exactly (the Taylor expansion is exact)."""
    q0, v, a = 0.01, -3e-3, 0.7  # m, m/s, m/s^2

    def q(t):
        return q0 + v * t + 0.5 * a * t * t
    for h_old, h_new in ((1e-3, 0.06), (0.05, 1e-4), (2e-3, 2e-3)):
        assert rescaled_previous(q(0.0), q(-h_old), h_old, h_new, a) == pytest.approx(
            q(-h_new), abs=1e-15)
    # without the acceleration it keeps the half-step velocity (first order)
    assert rescaled_previous(q(0.0), q(-1e-3), 1e-3, 2e-3) == pytest.approx(
        q(0.0) - 2e-3 * (q(0.0) - q(-1e-3)) / 1e-3, abs=1e-15)


def test_acceleration_is_that_of_the_central_difference_step():
    """m a + b v = F at step i, with v = v_{i-1/2} + a h/2 (the scheme's own velocity)."""
    mass, damping, h, force = 0.03, 0.5, 1e-3, 0.02  # kg, N s/m, s, N
    q, q_prev = 1e-3, 0.999e-3  # m
    a = central_difference_acceleration(q, q_prev, force, mass, damping, h)
    v = (q - q_prev) / h + 0.5 * a * h
    assert mass * a + damping * v == pytest.approx(force, rel=1e-12)


def test_friction_held_end_stays_held_across_a_step_change(free_stroke):
    """With Coulomb friction the half-step velocity is kept: a stuck end stays put."""
    p = free_stroke.with_values(**{'model': 'cst', 'effects.friction_force': 0.05,
                                   'effects.static_friction_ratio': 2.0})
    sim = TcaSimulator(p, dt=1e-3)
    q0 = sim.state.elongation
    for _ in range(50):
        sim.step(0.0)
    sim.set_dt(0.02)
    for _ in range(20):
        sim.step(0.0)
    assert sim.state.stuck
    assert sim.state.elongation == q0
