"""Creep, hysteresis, radiation and nonlinear convection in the quasi-static reduction.

Each effect at two magnitudes against the full central-difference dynamics (18) at
1 kHz (20 g on the free-stroke TCA, a power step and a ramp, sampled at 5 Hz as in
test_quasistatic.py), and the relations of quasistatic_effects.py (on eq. (1) of
thermal.py) against closed forms and an adaptive ODE solver.
"""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tca_ros.model import effects as fx
from tca_ros.model import quasistatic_effects as qe
from tca_ros.model.quasistatic import simulate_quasistatic
from tca_ros.model.simulation import simulate
from tca_ros.model.thermal import heat_loss, heat_loss_slope, HeatBalance, step_response
from tca_ros.params.files import load_params

MASS = 0.02  # kg
LOAD = MASS * 9.81  # N


def _params(**values):
    return load_params('free_stroke').with_values(**{'dynamics.mass': MASS,
                                                     'dynamics.load': LOAD, **values})


def _profile(rate=5.0, duration=60.0):
    """Return (time (s), power (W)): a 1.2 W step over 5-20 s, a 0-1.5 W ramp over 30-45 s."""
    t = np.arange(0.0, duration, 1.0 / rate)
    step = np.where((t >= 5.0) & (t < 20.0), 1.2, 0.0)
    ramp = np.where((t >= 30.0) & (t < 45.0), 1.5 * (t - 30.0) / 15.0, 0.0)
    return t, step + ramp


# (effect values, model, least change of the stroke the effect makes (m)): 60 s records
CASES = [
    ({'effects.emissivity': 0.5}, 'cst', 0.5e-3),
    ({'effects.emissivity': 0.95}, 'cst', 1e-3),
    ({'effects.convection_exponent': 0.25}, 'cst', 0.5e-3),
    ({'effects.convection_exponent': 1.0}, 'cst', 2e-3),
    ({'effects.creep_compliance': 0.005, 'effects.creep_time_constant': 15.0}, 'cst', 0.5e-3),
    ({'effects.creep_compliance': 0.02, 'effects.creep_time_constant': 40.0}, 'cst', 2e-3),
    ({'effects.hysteresis_width': 6.0}, 'cst', 0.5e-3),
    ({'effects.hysteresis_width': 20.0}, 'cst', 2e-3),
    ({'effects.hysteresis_width': 20.0}, 'rod', 2e-3),
]


@pytest.mark.parametrize('values, model, change', CASES)
def test_each_effect_equals_the_full_dynamics(values, model, change):
    p = _params(**values)
    t, power = _profile()
    full = simulate(p, t, power, model=model, physics_rate=1000.0)
    fast = simulate_quasistatic(p, t, power, model=model)
    nominal = simulate_quasistatic(_params(), t, power, model=model)
    # the effect is there: it moves the displacement far beyond the tolerances below
    assert np.abs(full.displacement - nominal.displacement).max() > change
    diff = full.displacement - fast.displacement
    # as test_quasistatic.py: 10 um RMS; 60 um peak (measured 2-2.6 um RMS, 19-26 um
    # peak, the mass transients at power switches). Hysteresis 20 K: 5.4 um RMS and
    # 64 um peak, because the stroke starts to move where T leaves the play band,
    # between samples, and the inertia the massless lag omits (decaying in ~80 ms) is
    # sampled near its peak; with a 2 g mass the same record gives 7 um.
    peak = 100e-6 if values.get('effects.hysteresis_width', 0.0) > 10.0 else 60e-6
    assert np.sqrt(np.mean(diff ** 2)) < 10e-6
    assert np.abs(diff).max() < peak
    # RK4 on the record grid against RK4 at 1 kHz: measured <= 6e-4 K
    np.testing.assert_allclose(fast.temperature, full.temperature, atol=0.01)
    np.testing.assert_allclose(fast.resistance, full.resistance, rtol=1e-3)


@pytest.mark.parametrize('supply', ['power', 'voltage'])
def test_effects_together_equal_the_full_dynamics(supply):
    # creep under friction (the band's rod tension drives the creep), hysteresis with
    # nonlinear convection; a constant-voltage supply sees R(T, x) with the creep
    values = {'effects.creep_compliance': 0.02, 'effects.creep_time_constant': 15.0,
              'effects.hysteresis_width': 10.0}
    if supply == 'power':
        values.update({'effects.friction_force': 0.02, 'effects.convection_exponent': 0.25})
    else:
        values.update({'effects.emissivity': 0.9, 'electrical.strain_coefficient': -0.5})
    p = _params(**values)
    t, power = _profile(duration=40.0)
    full = simulate(p, t, power, model='cst', physics_rate=1000.0, supply=supply)
    fast = simulate_quasistatic(p, t, power, model='cst', supply=supply)
    diff = full.displacement - fast.displacement
    assert full.displacement.min() < -1e-3  # the creep shows
    # measured (60 s): 3.3 um RMS, 26 um peak (power); 3.6 um RMS, 29 um peak (voltage)
    assert np.sqrt(np.mean(diff ** 2)) < 10e-6
    assert np.abs(diff).max() < 60e-6
    np.testing.assert_allclose(fast.temperature, full.temperature, atol=0.05)


# one non-neutral value per parameter of each effect of the catalogue
EFFECT_VALUES = {
    'creep': {'effects.creep_compliance': 0.01, 'effects.creep_time_constant': 20.0},
    'hysteresis': {'effects.hysteresis_width': 10.0},
    'radiation': {'effects.emissivity': 0.9},
    'nonlinear_convection': {'effects.convection_exponent': 0.25},
    'modulus_softening': {'effects.extra_softening': 2e5},
    'coil_contact': {'coil.min_pitch_angle_deg': 15.0},
    'sensor_lag': {'effects.sensor_lag': 0.5},
    'ambient_offset': {'effects.ambient_offset': 3.0},
    'power_loss': {'effects.power_loss_fraction': 0.1},
    'dead_time': {'effects.dead_time': 0.4},
    'second_thermal_lag': {'effects.second_thermal_lag': 2.0},
    'friction': {'effects.friction_force': 0.01, 'effects.friction_start': -1.0},
}


def test_every_catalogue_effect_is_accepted():
    assert set(EFFECT_VALUES) == set(fx.CATALOGUE)
    t, power = _profile(duration=20.0)
    for name, values in EFFECT_VALUES.items():
        assert set(values) >= set(fx.CATALOGUE[name])
        for supply in ('power', 'voltage'):
            sim = simulate_quasistatic(_params(**values), t, power, model='cst', supply=supply)
            assert np.all(np.isfinite(sim.displacement)), (name, supply)
            assert np.all(np.isfinite(sim.temperature)), (name, supply)


@pytest.mark.parametrize('values', [{'effects.emissivity': 0.9},
                                    {'effects.convection_exponent': 0.25},
                                    {'effects.emissivity': 0.5, 'effects.convection_exponent': 1.0,
                                     'effects.convection_reference_dt': 20.0}])
def test_heat_loss_is_convection_and_radiation(values):
    p = load_params('free_stroke').with_values(**values)
    balance = HeatBalance.of(p)
    e = p.effects
    area = 2.0 * math.pi * p.fiber.radius * p.fiber.length  # m^2, A_0
    for temp in (-10.0, 24.0, 25.0, 25.5, 80.0, 200.0):
        # h c_s A_0 (T - T_inf) (|T - T_inf| / dT_ref)^n + eps sigma A_0 (T^4 - T_inf^4)
        rise = temp - 25.0
        expected = balance.conductance * rise * (abs(rise) / e.convection_reference_dt) ** (
            e.convection_exponent) + e.emissivity * 5.670374419e-8 * area * (
                (temp + 273.15) ** 4 - (25.0 + 273.15) ** 4)
        assert heat_loss(temp, balance) == pytest.approx(expected, rel=1e-12, abs=1e-15)
    for temp in (30.0, 90.0, 180.0):  # the slope against central differences (0.01 K)
        numeric = (heat_loss(temp + 0.01, balance) - heat_loss(temp - 0.01, balance)) / 0.02
        assert heat_loss_slope(temp, balance) == pytest.approx(numeric, rel=1e-5)


def test_linear_heat_balance_gives_the_closed_form_step():
    p = load_params('free_stroke')
    balance = HeatBalance.of(p)
    assert balance.linear
    t = np.arange(0.0, 20.0, 0.2)
    temp = qe.nonlinear_thermal_response(t, np.ones_like(t), balance)
    # RK4 at h / tau = 0.067: measured 4.8e-6 K from T_inf + P/G (1 - exp(-t/tau))
    np.testing.assert_allclose(temp, step_response(t, 1.0, p.fiber, p.thermal), atol=1e-5)


@pytest.mark.parametrize('values', [
    {'effects.emissivity': 0.9},
    # steep: h (dT / 2 K)^1, 20x the linear slope at 40 K: substeps needed at 0.5 s
    {'effects.convection_exponent': 1.0, 'effects.convection_reference_dt': 2.0}])
def test_nonlinear_heat_balance_matches_an_adaptive_solver(values):
    balance = HeatBalance.of(load_params('free_stroke').with_values(**values))
    t = np.arange(0.0, 20.0, 0.5)
    heating = np.where(t < 10.0, 1.0, 0.2)
    substeps = qe.rk4_substeps(np.diff(t), heating[:-1], balance)
    rate = heat_loss_slope(qe.equilibrium_bound(1.0, balance), balance) / balance.capacity
    assert np.all(0.5 / substeps * rate <= qe.RK4_STEP_RATE + 1e-12)
    assert (substeps.max() > 1) == ('effects.convection_exponent' in values)  # 1 or 11
    temp = qe.nonlinear_thermal_response(t, heating, balance)
    reference = [balance.ambient]
    for k in range(t.size - 1):
        def rate_of_change(_, y, power=heating[k]):
            return [(power - heat_loss(y[0], balance)) / balance.capacity]
        sol = solve_ivp(rate_of_change, (t[k], t[k + 1]), [reference[-1]], method='DOP853',
                        rtol=1e-12, atol=1e-12)
        reference.append(sol.y[0, -1])
    # measured 3.1e-4 K (radiation, one substep) and 1.3e-5 K (11 substeps)
    np.testing.assert_allclose(temp, reference, atol=1e-3)
    # held long enough, the temperature settles where Q(T) = P
    long = np.arange(0.0, 200.0, 0.5)
    settled = qe.nonlinear_thermal_response(long, np.ones_like(long), balance)[-1]
    assert settled == pytest.approx(qe.equilibrium_bound(1.0, balance), abs=1e-9)


def test_play_operator_follows_the_samples_and_inserts_the_onsets():
    t = np.arange(9.0)
    temp = np.array([25.0, 28.0, 40.0, 50.0, 45.0, 38.0, 30.0, 50.0, 20.0])
    grid, actuation, samples = qe.hysteretic_temperature(t, temp, 10.0)
    state, expected = temp[0], []
    for value in temp:
        state = fx.play_operator(value, state, 10.0)
        expected.append(state)
    np.testing.assert_array_equal(actuation[samples], expected)
    np.testing.assert_array_equal(grid[samples], t)
    # held at 25 until T reaches 30 (1 + 2/12 s); at 45 until T falls to 40 (4 + 5/7 s);
    # T turns within an interval and crosses the band: moving down at 6 s (35), held
    # until T rises to 40 (6.5 s); moving up at 7 s (45), held until T falls to 40 (7 1/3 s)
    inserted = np.setdiff1d(np.arange(grid.size), samples)
    np.testing.assert_allclose(grid[inserted], [1.0 + 2.0 / 12.0, 4.0 + 5.0 / 7.0, 6.5,
                                                7.0 + 1.0 / 3.0])
    np.testing.assert_array_equal(actuation[inserted], [25.0, 45.0, 35.0, 45.0])
    # zero width: the input itself, nothing inserted
    same = qe.hysteretic_temperature(t, temp, 0.0)
    assert np.array_equal(same[0], t) and np.array_equal(same[1], temp)
    assert same[2] == slice(None)


@pytest.mark.parametrize('uniform', [True, False])
def test_creep_is_the_kelvin_voigt_step_response(uniform):
    p = load_params('free_stroke').with_values(**{'effects.creep_compliance': 0.01,
                                                  'effects.creep_time_constant': 20.0})
    t = np.linspace(0.0, 60.0, 301) if uniform else np.sort(
        np.concatenate(([0.0, 60.0], np.random.default_rng(3).uniform(0.0, 60.0, 299))))
    creep = qe.creep_elongation(t, np.full_like(t, 0.2), p.effects)
    # tau_c dy/dt = C F - y from 0 under a constant F: C F (1 - exp(-t / tau_c))
    np.testing.assert_allclose(creep, 0.01 * 0.2 * (1.0 - np.exp(-t / 20.0)), atol=1e-15)


def test_a_fiber_in_vacuum_settles_where_radiation_carries_the_power():
    # h = 0 with emissivity > 0 is valid (params_checks._check_thermal): no convective term
    p = _params(**{'thermal.convection_coefficient': 0.0, 'effects.emissivity': 0.9})
    t = np.arange(0.0, 300.0, 1.0)  # 20 radiative time constants (~13 s at 130 degC)
    heated = np.full_like(t, 0.3)  # W
    voltage = simulate_quasistatic(p, t, heated, model='cst', supply='voltage')
    assert np.all(np.isfinite(voltage.temperature)) and voltage.temperature[-1] > 100.0
    # 0.3 W radiated: eps sigma A_0 ((T + 273.15)^4 - (T_inf + 273.15)^4) = 0.3 W
    balance = HeatBalance.of(p)
    radiation = balance.emissivity * fx.STEFAN_BOLTZMANN * balance.area  # W/K^4
    kelvin = (0.3 / radiation + (25.0 + 273.15) ** 4) ** 0.25
    power = simulate_quasistatic(p, t, heated, model='cst')
    assert power.temperature[-1] == pytest.approx(kelvin - 273.15, abs=1e-6)
