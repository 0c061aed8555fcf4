"""Load rigs (tca_ros.model.rigs): each against its statics or a closed form."""
import math

import numpy as np
import pytest

from tca_ros.model.dynamics import StabilityError, TcaSimulator
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.params_schema import ParameterError
from tca_ros.model.rig_simulation import RIG_COLUMNS, simulate_rig
from tca_ros.model.rig_statics import antagonistic_rest_angle, isometric_force
from tca_ros.model.rig_statics import spring_rest_state
from tca_ros.model.rigs import AntagonisticPair, HeldMuscle, make_rig, SpringLoadedMuscle
from tca_ros.model.simulation import static_displacement
from tca_ros.params.files import load_params

# The rod model's dynamics reads a table of exact helices; the statics here solve the
# exact helix itself. docs/rod.md measures the table within ~1e-4 of it: 1e-3 below.
TABLE_RTOL = {'cst': 1e-5, 'rod': 1e-3}


def _rig(mode, model='cst', **values):
    return load_params('free_stroke', model=model, **{'rig.mode': mode, **values})


def _steady_run(params, seconds=25.0, power=1.0, physics_rate=1000.0, **inputs):
    t = np.arange(0.0, seconds + 1e-9, 0.5)
    extra = {k: np.full_like(t, v) for k, v in inputs.items()}
    return simulate_rig(params, t, np.full_like(t, power), physics_rate=physics_rate,
                        **extra).columns


def test_rig_keys_are_read_from_the_params_file_and_checked():
    p = load_params('free_stroke')
    assert p.rig.mode == 'dead_weight'  # today's behaviour by default
    assert isinstance(make_rig(p), TcaSimulator)
    spring = p.with_values(**{'rig.mode': 'spring', 'rig.spring_stiffness': 35.0})
    assert spring.rig.spring_stiffness == 35.0
    with pytest.raises(ParameterError, match=r"'rig.mode' = 'hanging'.*one of dead_weight"):
        p.with_values(**{'rig.mode': 'hanging'})
    with pytest.raises(ParameterError, match=r"'rig.pulley_radius' = 0.0: .*\[0.0001, 1\] m"):
        p.with_values(**{'rig.pulley_radius': 0.0})
    # the spring would see the coil without its creep: refused in one line
    with pytest.raises(ParameterError, match='creep_compliance.*rig.mode spring'):
        make_rig(spring.with_values(**{'effects.creep_compliance': 1e-3}))


@pytest.mark.parametrize('model', ['cst', 'rod'])
def test_spring_rig_rests_where_the_force_curve_meets_the_spring_line(model):
    """Eqs. (R2)-(R3) at rest equal the statics intersection at the reached T."""
    params = _rig('spring', model)
    out = _steady_run(params)
    km = make_kinetostatic_model(params)
    contraction, force = spring_rest_state(km, out['temperature'][-1], 0.05, 20.0)
    assert contraction > 3e-3  # the muscle contracted and stretched the spring
    rtol = TABLE_RTOL[model]
    assert out['displacement'][-1] == pytest.approx(contraction, rel=rtol)
    assert out['force'][-1] == pytest.approx(force, rel=rtol)
    # the spring line itself: F = F_0 + k_s x
    assert out['force'][-1] == pytest.approx(0.05 + 20.0 * out['displacement'][-1], rel=rtol)


def test_spring_rig_without_stiffness_is_the_dead_weight_of_its_pretension():
    """k_s = 0: the spring rig is eq. (18) under the constant load F_0."""
    params = _rig('spring', **{'rig.spring_stiffness': 0.0, 'rig.pretension': 0.2})
    out = _steady_run(params)
    expected = static_displacement(params, 0.2, [25.0, out['temperature'][-1]])[-1]
    # T still rises 0.006 K/s at 25 s: the end trails its equilibrium by ~2e-8 m (b / k)
    assert out['displacement'][-1] == pytest.approx(expected, rel=1e-5)
    assert out['force'][-1] == pytest.approx(0.2, rel=1e-5)  # + b_t q' of that drift


def test_massless_spring_rig_rests_at_the_same_point():
    """The quasi-static mode (mass 0, Case 2 of the paper) solves the same statics."""
    params = _rig('spring', **{'dynamics.mass': 0.0})
    out = _steady_run(params, physics_rate=20.0)  # backward Euler: stable at any step
    km = make_kinetostatic_model(params)
    contraction, _ = spring_rest_state(km, out['temperature'][-1], 0.05, 20.0)
    assert out['displacement'][-1] == pytest.approx(contraction, rel=1e-5)


@pytest.mark.parametrize('model', ['cst', 'rod'])
def test_isometric_force_equals_the_statics_force_at_the_clamped_length(model):
    params = _rig('isometric', model)
    sim = make_rig(params)
    assert isinstance(sim, HeldMuscle)
    assert sim.outputs()['force'] == pytest.approx(0.05, rel=1e-6)  # pretension at ambient
    out = _steady_run(params)
    km = make_kinetostatic_model(params)
    expected = isometric_force(km, out['temperature'][-1], 0.05)
    assert expected > 0.2  # heating a clamped muscle builds force
    assert out['force'][-1] == pytest.approx(expected, rel=TABLE_RTOL[model])
    assert tuple(out) == RIG_COLUMNS['isometric']  # no displacement: the length is held


def test_pair_with_equal_powers_stays_at_its_equilibrium_angle():
    """Identical muscles, identical heat: the torques cancel at theta = 0."""
    out = _steady_run(_rig('antagonistic'), power=0.8, power_2=0.8, physics_rate=200.0)
    assert np.max(np.abs(out['angle'])) < 1e-12
    assert out['force'][-1] == pytest.approx(out['force_2'][-1], rel=1e-12)
    assert out['force'][-1] > 0.15  # both pull harder when both are hot (co-contraction)


@pytest.mark.parametrize('model', ['cst', 'rod'])
def test_pair_step_turns_the_joint_to_the_statics_angle_of_both_muscles(model):
    params = _rig('antagonistic', model)
    km = make_kinetostatic_model(params)
    # the joint is stable up to ~0.09 s: 200 Hz reaches the same rest (exact eq. (1))
    out = _steady_run(params, power=1.0, power_2=0.3, physics_rate=200.0)
    angle, force = antagonistic_rest_angle(km, out['temperature'][-1],
                                           out['temperature_2'][-1], 0.05, 0.01)
    assert angle > 0.2  # the hotter agonist wins
    assert out['angle'][-1] == pytest.approx(angle, rel=TABLE_RTOL[model])
    assert out['force'][-1] == pytest.approx(force, rel=TABLE_RTOL[model])
    assert out['torque'][-1] == pytest.approx(0.0, abs=1e-6)  # at rest: F_1 = F_2
    mirrored = _steady_run(params, power=0.3, power_2=1.0, physics_rate=200.0)
    assert mirrored['angle'][-1] == pytest.approx(-out['angle'][-1], rel=1e-9)


def test_undamped_pair_oscillates_at_its_pulley_frequency():
    """Small angles: J theta'' = -r^2 (k_1 + k_2) theta, omega = r sqrt(2 k / J)."""
    params = _rig('antagonistic', **{'dynamics.damping': 0.0, 'rig.joint_damping': 0.0})
    pair = AntagonisticPair(params, dt=1e-4)
    pair.reset(angle=1e-3)
    k = pair.kinetostatics.stiffness(pair.reference, 25.0)
    omega = 0.01 * math.sqrt(2.0 * k / 1e-5)
    angles = np.empty(12000)
    for i in range(angles.size):
        pair.step(0.0, power_2=0.0)
        angles[i] = pair.angle
    up = np.flatnonzero((angles[:-1] < 0.0) & (angles[1:] >= 0.0))
    period = (up[-1] - up[0]) * 1e-4 / (up.size - 1)
    # central differences: period error (omega h)^2 / 24 ~ 2e-7; the amplitude is 10 um
    # of a 0.1 N muscle, so the stiffness is constant to ~1e-4 over a swing
    assert period == pytest.approx(2.0 * math.pi / omega, rel=1e-3)
    assert np.max(np.abs(angles)) == pytest.approx(1e-3, rel=1e-3)  # no damping, no gain


def test_pair_splits_a_step_beyond_its_stability_limit_and_refuses_far_beyond():
    params = _rig('antagonistic', **{'rig.joint_inertia': 1e-8})
    pair = AntagonisticPair(params, dt=1e-2)
    limit = pair.stability_limit()  # 2 sqrt(J / (r^2 (k_1 + k_2))) = 3 ms
    assert limit < 5e-3
    assert pair.check_step() == math.ceil(1e-2 / (0.9 * limit))
    out = _steady_run(params, seconds=2.0, physics_rate=100.0)
    assert np.all(np.isfinite(out['angle'])) and out['angle'][-1] > 0.1
    with pytest.raises(StabilityError, match='rig.joint_inertia'):
        AntagonisticPair(params.with_values(**{'rig.joint_inertia': 1e-9}), dt=1.0)


def test_rigs_refuse_inputs_they_do_not_take():
    t = np.arange(0.0, 1.0, 0.1)
    with pytest.raises(ValueError, match="'isometric': takes no load input"):
        simulate_rig(_rig('isometric'), t, np.zeros_like(t), load=np.zeros_like(t))
    with pytest.raises(ValueError, match='power_2 heats the antagonist'):
        simulate_rig(_rig('spring'), t, np.zeros_like(t), power_2=np.zeros_like(t))
    assert isinstance(make_rig(_rig('spring')), SpringLoadedMuscle)
