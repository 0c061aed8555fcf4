"""Coulomb friction on the free end ('friction' in effects.py): dynamics and reduction."""
import math

import numpy as np
import pytest

from tca_ros.model import effects as fx
from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.quasistatic import simulate_quasistatic
from tca_ros.model.simulation import simulate
from tca_ros.model.tca_params import EffectParams
from tca_ros.params.files import load_params

MASS = 0.01  # kg, the 10 g weight of the recorded rigs
LOAD = MASS * 9.81  # N


def _params(friction=0.0, ratio=1.0, mass=MASS, **extra):
    return load_params('free_stroke').with_values(**{
        'dynamics.mass': mass, 'dynamics.load': LOAD, 'effects.friction_force': friction,
        'effects.static_friction_ratio': ratio, **extra})


def _cycle(rate, power=1.0, duration=80.0):
    """Return (time (s), power (W)): heat from 25 s to 55 s, then cool."""
    t = np.arange(0.0, duration, 1.0 / rate)
    return t, np.where((t >= 25.0) & (t < 55.0), power, 0.0)


def _bursts(displacement, still=1e-7):
    """Return (start, end) sample indices of each run of motion (|step| > still, m)."""
    moving = np.concatenate(([0], (np.abs(np.diff(displacement)) > still).astype(int), [0]))
    change = np.diff(moving)
    return list(zip(np.flatnonzero(change == 1), np.flatnonzero(change == -1)))


def test_coulomb_law_sticks_within_the_static_force():
    e = EffectParams(friction_force=0.02, static_friction_ratio=2.0)
    assert fx.coulomb_friction(0.03, True, e) == (0.03, True)  # at rest: F_s = 0.04 N holds
    assert fx.coulomb_friction(0.03, False, e) == (0.02, False)  # sliding: F_k = 0.02 N
    assert fx.coulomb_friction(-0.05, True, e) == (-0.02, False)  # breaks away
    assert fx.friction_play(1.0, (0.0, 2.0), (0.5, 1.5)) == 1.0
    assert fx.friction_play(2.5, (0.0, 2.0), (0.5, 1.5)) == 1.5  # slips to the kinetic edge
    assert fx.friction_play(-1.0, (0.0, 2.0), (0.5, 1.5)) == 0.5


@pytest.mark.parametrize('ratio', [1.0, 2.5])
def test_zero_friction_is_the_nominal_model_bit_for_bit(ratio):
    t, power = _cycle(5.0, duration=40.0)
    nominal = load_params('free_stroke').with_values(**{'dynamics.mass': MASS,
                                                        'dynamics.load': LOAD})
    off = _params(0.0, ratio)
    for run in (simulate, simulate_quasistatic):
        a = run(nominal, t, power, model='cst')
        b = run(off, t, power, model='cst')
        np.testing.assert_array_equal(a.displacement, b.displacement)
        np.testing.assert_array_equal(a.tension, b.tension)


@pytest.mark.parametrize('friction', [0.01, 0.04])
def test_heat_cool_cycle_keeps_an_offset_of_friction_over_stiffness(friction):
    t, power = _cycle(5.0)
    result = simulate(_params(friction), t, power, model='cst')
    sim = TcaSimulator(_params(friction), model='cst')
    q_ref = sim.reference_elongation
    k = sim.kinetostatics.stiffness(q_ref, sim.state.temperature)  # ~23 N/m at ambient
    # the end stops where f_rod = F - F_c on cooling: y_ref - y_eq(F - F_c, T_amb)
    expected = q_ref - sim.equilibrium(LOAD - friction, sim.state.temperature)
    assert result.displacement.max() > 5e-3  # a real stroke
    # 25 s after the power is off the fiber is within 0.01 K of ambient (tau ~ 3 s), the
    # end at rest on the band edge: 0.5 % covers the temperature left and the 1 ms step
    assert result.displacement[-1] == pytest.approx(expected, rel=5e-3)
    # F_c / k is the linear estimate; f_rod curves by < 3 % over the 0.4-1.7 mm offset
    assert result.displacement[-1] == pytest.approx(friction / k, rel=0.03)
    # it trails the kinetic edge (r = 1) as the last 0.01 K fade: no return to zero
    assert np.abs(result.velocity[-5:]).max() < 1e-6


def test_static_friction_above_kinetic_gives_a_staircase_on_heating():
    t, power = _cycle(100.0, duration=55.0)
    heating = t >= 25.0
    stick_slip = simulate(_params(0.02, 2.0), t, power, model='cst').displacement[heating]
    smooth = simulate(_params(0.02, 1.0), t, power, model='cst').displacement[heating]
    k = 23.2  # N/m, axial stiffness of the loaded free-stroke coil (cst) at ambient
    jumps = [stick_slip[b] - stick_slip[a] for a, b in _bursts(stick_slip)]
    # with F_s = 2 F_k the end slips by (F_s - F_k) / k = 0.86 mm past the static edge,
    # more with inertia (up to twice that undamped, zeta ~ 0.5 here): 6+ steps of 0.9-1.7 mm
    assert len(jumps) >= 6
    assert all(0.9 * 0.02 / k < jump < 2.0 * 0.02 / k for jump in jumps)
    assert len(_bursts(smooth)) <= 2  # r = 1: it follows the kinetic edge, no stairs
    assert stick_slip[-1] == pytest.approx(smooth[-1], abs=2.0 * 0.02 / k)


def test_friction_step_is_stable_with_mass_at_1khz():
    p = _params(0.05, 3.0, **{'dynamics.damping': 0.05})  # zeta ~ 0.05: a ringing slip
    sim = TcaSimulator(p, model='cst', dt=1e-3)
    assert sim.substeps() == 1  # 2 / omega ~ 40 ms >> 1 ms: friction adds no limit
    tensions, velocities = [], []
    for i in range(60000):  # 60 s at 1 kHz: 2 W for 20 s, then cooling
        s = sim.step(2.0 if 5000 <= i < 25000 else 0.0)
        tensions.append(s.tension)
        velocities.append(s.velocity)
    assert np.all(np.isfinite(tensions)) and np.all(np.isfinite(velocities))
    # a slip starts at rest (F_s - F_k) / k from the kinetic equilibrium: undamped, its
    # speed peaks at (F_s - F_k) / sqrt(k m) = 0.21 m/s (k ~ 23-24 N/m); the thermal
    # drive adds mm/s. A growing explicit step would pass it (measured 0.196 m/s)
    assert np.max(np.abs(velocities)) < 1.2 * 0.1 / math.sqrt(23.0 * MASS)
    assert sim.state.stuck and sim.state.velocity == 0.0
    assert abs(sim.state.load - sim.state.tension) <= 0.15 + 1e-9  # within F_s at rest


def test_massless_end_is_a_play_operator():
    # mass 0 and no damping: each step lands on the band edge y_eq(F -+ F_k, T)
    p = _params(0.02, 1.0, mass=0.0, **{'dynamics.damping': 0.0})
    sim = TcaSimulator(p, model='cst', dt=0.05)
    temps = []
    for i in range(400):  # 20 s: heat 8 s, cool 12 s
        sim.step(1.0 if i < 160 else 0.0)
        temps.append(sim.state.temperature)
        if i in (150, 399):
            edge = sim.equilibrium(LOAD + (0.02 if i == 150 else -0.02),
                                   sim.state.actuation_temperature)
            assert sim.state.elongation == pytest.approx(edge, abs=1e-9)
    # just after the power is off the temperature barely falls: the end is stuck
    sim2 = TcaSimulator(p, model='cst', dt=0.05)
    for _ in range(160):
        sim2.step(1.0)
    held = sim2.state.elongation
    sim2.step(0.0)
    assert sim2.state.stuck and sim2.state.elongation == held


@pytest.mark.parametrize('model', ['cst', 'rod'])
@pytest.mark.parametrize('friction', [0.005, 0.05])
def test_quasistatic_play_operator_matches_full_dynamics(model, friction):
    p = _params(friction)
    t, power = _cycle(5.0)
    full = simulate(p, t, power, model=model, physics_rate=1000.0)
    fast = simulate_quasistatic(p, t, power, model=model)
    diff = full.displacement - fast.displacement
    # measured ~1 um RMS and <= 11 um peak: the reduction's own transient error at the
    # power switches (as without friction); the play operator itself adds none
    assert np.sqrt(np.mean(diff ** 2)) < 10e-6
    assert np.abs(diff).max() < 60e-6
    assert fast.displacement[-1] > 0.8 * friction / 24.0  # the offset is there in both


def test_quasistatic_stick_slip_stays_within_the_static_band():
    # r > 1: the reduction slips to the kinetic edge and sticks (inertia-free stick-slip);
    # the full dynamics may keep sliding when the edge moves fast (cooling). Both stay in
    # the static band, so they differ by less than its half-width (F_s - F_k) / k + F_k / k
    p = _params(0.02, 2.0)
    t, power = _cycle(5.0)
    full = simulate(p, t, power, model='cst', physics_rate=1000.0)
    fast = simulate_quasistatic(p, t, power, model='cst')
    diff = full.displacement - fast.displacement
    assert np.abs(diff).max() < 2.0 * 0.02 / 23.0
    assert np.sqrt(np.mean(diff ** 2)) < 0.02 / 23.0


def test_quasistatic_voltage_supply_sees_the_position_held_by_friction():
    # constant voltage: R(T, x) falls as the coil contracts (beta_x = -1), so the power
    # follows the position; friction holds the end back and the stroke is 27 % shorter
    p = _params(0.02, 1.0, **{'electrical.strain_coefficient': -1.0})
    t, power = _cycle(5.0)
    full = simulate(p, t, power, model='cst', physics_rate=1000.0, supply='voltage')
    fast = simulate_quasistatic(p, t, power, model='cst', supply='voltage')
    free = simulate_quasistatic(_params(0.0, 1.0, **{'electrical.strain_coefficient': -1.0}),
                                t, power, model='cst', supply='voltage')
    stroke = full.displacement.max()
    assert stroke < 0.8 * free.displacement.max()
    # measured 11 um RMS of a 20 mm stroke (the nominal reduction: 36 um of 28 mm)
    assert np.sqrt(np.mean((full.displacement - fast.displacement) ** 2)) < 0.002 * stroke


@pytest.mark.parametrize('start', [-1.0, 1.0])
def test_the_start_in_the_band_moves_the_end_by_its_static_force_and_reads_zero(start):
    # effects.friction_start s puts the end at y_eq(F + s F_s) and the displacement
    # reads zero there (G45): every stepper starts the same way
    p = _params(0.02, **{'effects.friction_start': start})
    sim = TcaSimulator(p, model='cst')
    assert sim.state.displacement == 0.0
    assert sim.state.elongation == pytest.approx(sim.equilibrium(LOAD + start * 0.02, 25.0))
    t, power = _cycle(20.0, duration=40.0)
    dyn = simulate(p, t, power, model='cst')
    qs = simulate_quasistatic(p, t, power, model='cst')
    volt = simulate_quasistatic(p, t, power, model='cst', supply='voltage')
    for result in (dyn, qs, volt):
        assert abs(result.displacement[0]) < 1e-9  # m
    # the 10 g mass against its massless reduction: 0.1 % of the 8.7 mm stroke
    assert np.max(np.abs(dyn.displacement - qs.displacement)) < 1e-5  # m


def test_a_record_cut_after_a_heating_is_the_model_started_at_the_shortened_edge():
    # a muscle heated and cooled before its record: friction left its end short of the
    # equilibrium. The same plant recorded from there (re-zeroed) is the model started
    # with friction_start = -1, and not the one started at rest in its band
    rate = 20.0
    t = np.arange(0.0, 160.0, 1.0 / rate)
    power = np.where(((t >= 5.0) & (t < 30.0)) | ((t >= 85.0) & (t < 110.0)), 1.0, 0.0)
    p = _params(0.02)
    history = simulate(p, t, power, model='cst')
    cut = t >= 80.0
    recorded = history.displacement[cut] - history.displacement[cut][0]
    rms = {}
    for start in (-1.0, 0.0, 1.0):
        model = simulate(p.with_values(**{'effects.friction_start': start}), t[cut] - 80.0,
                         power[cut], model='cst')
        rms[start] = float(np.sqrt(np.mean((model.displacement - recorded) ** 2)))
    assert rms[-1.0] < 1e-9  # m: the same trajectory
    assert rms[0.0] > 2e-4 and rms[1.0] > rms[0.0]  # started at rest: 0.7 mm off


def test_a_start_held_beyond_the_thread_strength_is_refused_in_one_line():
    p = _params(0.5, ratio=10.0, **{'effects.friction_start': 1.0})  # 5 N held at the start
    with pytest.raises(ValueError) as err:
        TcaSimulator(p, model='cst')
    message = str(err.value)
    assert '\n' not in message and message.startswith('effects.friction_start = 1:')
    assert 'fiber.break_force' in message
    # held in compression by friction stronger than the weight: the coil closes, a state
    sim = TcaSimulator(_params(0.1, **{'effects.friction_start': -1.0}), model='cst')
    assert math.isfinite(sim.state.elongation) and sim.state.displacement == 0.0
