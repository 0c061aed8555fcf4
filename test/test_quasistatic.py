"""The quasi-static reduction against the full central-difference dynamics (18)."""
import numpy as np
import pytest

from tca_ros.model.quasistatic import QuasiStaticUnsupported, simulate_quasistatic
from tca_ros.model.quasistatic_signals import delayed_input, first_order_response
from tca_ros.model.simulation import simulate
from tca_ros.model.static_maps import ExactHelixStatics, static_map
from tca_ros.params.files import load_params


def _step_profile(rate, power=1.0):
    t = np.arange(0.0, 80.0, 1.0 / rate)
    return t, np.where((t >= 25.0) & (t < 55.0), power, 0.0)


@pytest.mark.parametrize('model', ['cst', 'rod'])
@pytest.mark.parametrize('effect', [{}, {'effects.dead_time': 1.0},
                                    {'effects.second_thermal_lag': 3.0},
                                    {'effects.sensor_lag': 0.5},
                                    {'effects.friction_force': 0.02}])
def test_quasistatic_equals_full_dynamics_at_5hz(model, effect):
    mass = 0.01
    p = load_params('free_stroke').with_values(**{'dynamics.mass': mass,
                                                  'dynamics.load': mass * 9.81, **effect})
    t, power = _step_profile(5.0)
    load = np.full_like(t, mass * 9.81)
    full = simulate(p, t, power, load, model=model, physics_rate=1000.0)
    fast = simulate_quasistatic(p, t, power, load, model=model)
    diff = full.displacement - fast.displacement
    assert full.displacement.max() > 5e-3  # a real stroke, not a trivially flat record
    # 10 um RMS and 60 um peak of ~9 mm: the mass/damping transients at power switches
    assert np.sqrt(np.mean(diff ** 2)) < 10e-6
    assert np.abs(diff).max() < 60e-6
    np.testing.assert_allclose(fast.temperature, full.temperature, atol=0.1)
    np.testing.assert_allclose(fast.resistance, full.resistance, rtol=1e-3)


def test_first_order_hold_follows_a_ramp_with_lag_tau():
    t = np.linspace(0.0, 10.0, 51)
    y = first_order_response(t, 2.0 * t, 0.5, held=False)
    # steady ramp response: 2 (t - tau (1 - exp(-t/tau)))
    np.testing.assert_allclose(y, 2.0 * (t - 0.5 * (1.0 - np.exp(-t / 0.5))), atol=1e-12)


def test_delayed_input_preserves_heat_and_shifts():
    t = np.arange(0.0, 10.0, 0.2)
    u = np.where(t >= 2.0, 1.0, 0.0)
    d = delayed_input(t, u, 0.5)
    assert d[t < 2.4].max() < 1e-12 and d[np.isclose(t, 2.4)] == pytest.approx(0.5)
    assert d[t >= 2.6].min() == pytest.approx(1.0)
    assert np.sum(d[:-3]) * 0.2 == pytest.approx((10.0 - 2.5 - 0.6) * 1.0, abs=1e-9)


def test_a_coil_that_is_not_a_helix_is_refused():
    # the history-dependent effects are supported (test_quasistatic_effects.py); the rod
    # model's exact-helix statics still need a helix
    p = load_params('conical')
    t, power = _step_profile(5.0)
    with pytest.raises(QuasiStaticUnsupported, match='helix'):
        simulate_quasistatic(p, t, power, model='rod')


def test_voltage_supply_follows_the_resistance_like_the_full_dynamics():
    # a constant-voltage supply set to 1 W at R0: R falls as the coil contracts
    # (beta_x = -1), so the delivered power and the stroke grow beyond the 1 W ones
    p = load_params('free_stroke').with_values(**{
        'dynamics.mass': 0.01, 'dynamics.load': 0.0981, 'electrical.strain_coefficient': -1.0})
    t, power = _step_profile(5.0)
    full = simulate(p, t, power, model='cst', physics_rate=1000.0, supply='voltage')
    fast = simulate_quasistatic(p, t, power, model='cst', supply='voltage')
    constant = simulate_quasistatic(p, t, power, model='cst')
    stroke = full.displacement.max()
    assert stroke > 1.5 * constant.displacement.max()
    assert np.sqrt(np.mean((full.displacement - fast.displacement) ** 2)) < 0.005 * stroke
    with pytest.raises(ValueError, match='supply'):
        simulate_quasistatic(p, t, power, supply='current')


def test_a_load_ramp_is_interpolated_between_load_levels():
    # 101 distinct loads: maps at LOAD_LEVELS loads, interpolated in load
    p = load_params('free_stroke').with_values(**{'dynamics.mass': 0.02,
                                                  'dynamics.load': 0.196})
    t = np.arange(0.0, 120.0, 0.2)
    power = np.where((t >= 20.0) & (t < 60.0), 1.0, 0.0)
    load = 0.196 * (1.0 + 0.5 * np.clip((t - 70.0) / 20.0, 0.0, 1.0))
    full = simulate(p, t, power, load, model='cst', physics_rate=1000.0)
    fast = simulate_quasistatic(p, t, power, load, model='cst')
    diff = full.displacement - fast.displacement
    assert np.ptp(full.displacement) > 10e-3
    assert np.sqrt(np.mean(diff ** 2)) < 5e-6 and np.abs(diff).max() < 40e-6


class _OneAtATime:
    """The rod statics without their vectorised solve: static_map's scalar loop."""

    def __init__(self, statics):
        self.equilibrium_elongation = statics.equilibrium_elongation


@pytest.mark.parametrize('name, load', [('free_stroke', 0.1), ('free_stroke', 0.6),
                                        ('self_coiled', 0.05)])
def test_the_vectorised_rod_static_map_equals_the_scalar_one(name, load):
    # one solve over all temperatures (the fits' hot path) gives the numbers of one
    # solve per temperature, bit for bit, elongation and stiffness
    statics = ExactHelixStatics(load_params(name))
    temps = np.arange(10.0, 230.0, 0.7)
    y, k = static_map(statics, load, temps)
    y0, k0 = static_map(_OneAtATime(statics), load, temps)
    assert np.array_equal(y, y0) and np.array_equal(k, k0)
    assert np.all(np.diff(y) != 0.0)  # a map that moves, not a constant
