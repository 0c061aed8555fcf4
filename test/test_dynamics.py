"""Eqs. (1) + (18) stepped: accuracy, stability, contact, quasi-static mode."""
import math

import numpy as np
import pytest

from tca_ros.model import thermal
from tca_ros.model.dynamics import StabilityError, TcaSimulator
from tca_ros.model.end_motion import central_difference_step
from tca_ros.model.kinetostatics import contact_elongation
from tca_ros.model.simulation import simulate
from tca_ros.model.substeps import central_difference_limit


def _oscillator_error(dt, m=0.03, b=0.5, k=22.5, force=0.3, t_end=0.5):
    """Max error of central differences against the closed-form damped step response."""
    wn = math.sqrt(k / m)
    zeta = b / (2.0 * math.sqrt(k * m))
    wd = wn * math.sqrt(1.0 - zeta ** 2)
    n = int(round(t_end / dt))
    t = np.arange(n + 1) * dt
    exact = force / k * (1.0 - np.exp(-zeta * wn * t) * (
        np.cos(wd * t) + zeta / math.sqrt(1.0 - zeta ** 2) * np.sin(wd * t)))
    # start on the exact solution (q_0, q_1) so only the scheme's error is measured
    q = [exact[0], exact[1]]
    for _ in range(1, n):
        q.append(central_difference_step(q[-1], q[-2], force - k * q[-1], m, b, dt))
    return float(np.max(np.abs(np.array(q) - exact)))


def test_central_difference_is_second_order():
    e1, e2, e3 = (_oscillator_error(dt) for dt in (2e-3, 1e-3, 5e-4))
    order = math.log2(e1 / e2), math.log2(e2 / e3)
    assert order == (pytest.approx(2.0, abs=0.15), pytest.approx(2.0, abs=0.15))


def test_stability_limit_closed_form():
    assert central_difference_limit(22.5, 0.03) == pytest.approx(2 * math.sqrt(0.03 / 22.5))
    assert central_difference_limit(22.5, 0.0) == math.inf


def test_large_step_is_split_into_stable_substeps(free_stroke):
    coarse = TcaSimulator(free_stroke, model='cst', dt=0.2)  # limit 2/omega ~ 0.07 s
    assert coarse.substeps() >= 3
    fine = TcaSimulator(free_stroke, model='cst', dt=1e-3)
    for _ in range(100):
        coarse.step(1.0)
    for _ in range(20000):
        fine.step(1.0)
    assert coarse.state.time == pytest.approx(20.0)
    # both stable and equal to the physics within 1 % of the 20 s stroke
    assert coarse.state.displacement == pytest.approx(fine.state.displacement, rel=1e-2)


def test_unstable_mass_gives_clear_error(free_stroke):
    light = free_stroke.with_values(**{'dynamics.mass': 1e-11})
    with pytest.raises(StabilityError, match=r'dynamics.mass = 1e-11 kg.*at most 1000'):
        TcaSimulator(light, model='cst', dt=1e-2)


def test_power_step_heats_with_the_thermal_time_constant(free_stroke):
    t = np.arange(0.0, 15.0 + 1e-9, 0.05)
    res = simulate(free_stroke, t, np.full_like(t, 0.5), model='cst')
    expected = thermal.step_response(t, 0.5, free_stroke.fiber, free_stroke.thermal)
    np.testing.assert_allclose(res.temperature, expected, rtol=1e-9)


def test_rk4_path_matches_closed_form(free_stroke):
    # an exponent of 1e-12 makes the model formally nonlinear (RK4 path) with no effect
    p = free_stroke.with_values(**{'effects.convection_exponent': 1e-12})
    t = np.arange(0.0, 10.0 + 1e-9, 0.1)
    res = simulate(p, t, np.full_like(t, 0.8), model='cst', physics_rate=100.0)
    expected = thermal.step_response(t, 0.8, p.fiber, p.thermal)
    np.testing.assert_allclose(res.temperature, expected, rtol=1e-8)


def test_steady_state_equals_statics(free_stroke):
    sim = TcaSimulator(free_stroke, model='cst', dt=1e-3)
    target = thermal.steady_state_temperature(1.0, free_stroke.fiber, free_stroke.thermal)
    for _ in range(40000):
        sim.step(1.0)
    s = sim.state
    assert s.temperature == pytest.approx(target, abs=1e-3)
    expected = sim.reference_elongation - sim.equilibrium(free_stroke.dynamics.load, target)
    assert s.displacement == pytest.approx(expected, rel=1e-4)
    assert s.tension == pytest.approx(free_stroke.dynamics.load, rel=1e-4)


def test_contact_saturates_the_stroke(free_stroke):
    p = free_stroke.with_values(**{'coil.min_pitch_angle_deg': 18.0})
    sim = TcaSimulator(p, model='love', dt=1e-3)
    stop = sim.reference_elongation - contact_elongation(p)
    xs = []
    for i in range(30000):
        xs.append(sim.step(2.0).displacement)
    assert max(xs) == pytest.approx(stop, abs=1e-12)  # never beyond the stop
    assert sim.state.in_contact
    free = TcaSimulator(free_stroke, model='love', dt=1e-3)
    for _ in range(30000):
        free.step(2.0)
    assert free.state.displacement > stop + 1e-3  # without the stop it goes further


def test_quasi_static_mode_tracks_equilibrium(free_stroke):
    p = free_stroke.with_values(**{'dynamics.mass': 0.0})
    t = np.arange(0.0, 20.0 + 1e-9, 0.01)
    power = np.where(t < 10.0, 1.0, 0.0)
    qs = simulate(p, t, power, model='cst')
    full = simulate(free_stroke, t, power, model='cst')
    # inertia of the 30 g mass (omega = 27 rad/s) is the only difference: < 2 % of the stroke
    assert np.max(np.abs(qs.displacement - full.displacement)) < 0.02 * full.displacement.max()
    rigid = simulate(p.with_values(**{'dynamics.damping': 0.0}), t, power, model='cst')
    sim = TcaSimulator(p, model='cst')
    expected = sim.reference_elongation - sim.equilibrium(p.dynamics.load,
                                                          rigid.temperature[500])
    assert rigid.displacement[500] == pytest.approx(expected, rel=1e-6)


def test_resistance_follows_its_law(free_stroke):
    sim = TcaSimulator(free_stroke, model='cst')
    assert sim.state.resistance == pytest.approx(25.0)
    for _ in range(5000):
        sim.step(1.0)
    s, e = sim.state, free_stroke.electrical
    expected = e.resistance * (1 + e.temperature_coefficient * (s.temperature - 25.0)
                               + e.strain_coefficient * s.displacement / sim.loaded_length)
    assert s.resistance == pytest.approx(expected, rel=1e-12)
    assert s.resistance < 25.0


def test_effects_default_to_the_nominal_model(free_stroke):
    t = np.arange(0.0, 8.0 + 1e-9, 0.02)
    power = np.where(t < 4.0, 1.0, 0.0)
    base = simulate(free_stroke, t, power, model='cst', physics_rate=200.0)
    for name, value in [('effects.power_loss_fraction', 0.2), ('effects.sensor_lag', 0.5),
                        ('effects.hysteresis_width', 10.0), ('effects.emissivity', 0.9),
                        ('effects.ambient_offset', 5.0),
                        ('effects.creep_compliance', 0.02)]:
        other = simulate(free_stroke.with_values(**{name: value}), t, power, model='cst',
                         physics_rate=200.0)
        change = np.max(np.abs(other.displacement - base.displacement))
        assert change > 1e-5, name  # each effect changes what the sensor sees (m)


def test_set_dt_replans_substeps_and_keeps_the_old_step_on_failure(free_stroke):
    sim = TcaSimulator(free_stroke.with_values(**{'dynamics.mass': 1e-7}), model='cst',
                       dt=1e-4)
    assert sim.substeps() == 1
    sim.set_dt(1e-3)  # limit 2/omega ~ 1.3e-4 s: 9 substeps
    assert sim.dt == 1e-3 and sim.substeps() > 1
    with pytest.raises(StabilityError):
        sim.set_dt(1.0)  # would need > 1000 substeps
    assert sim.dt == 1e-3
    with pytest.raises(ValueError, match='dt = -1.0: must be a positive number of seconds'):
        sim.set_dt(-1.0)
