"""The gymnasium environment TcaTracking-v0 (tca_ros.toolkit.envs)."""
import gymnasium as gym
from gymnasium.utils.env_checker import check_env
import numpy as np
import pytest

from tca_ros.model.simulation import simulate
from tca_ros.toolkit import envs


@pytest.mark.parametrize('kwargs', [
    dict(model='cst'),
    dict(model='cst', action='voltage', observe=('resistance',)),
    dict(model='rod', observe=('displacement', 'velocity', 'temperature', 'resistance')),
])
def test_passes_the_gymnasium_checker(kwargs):
    env = gym.make(envs.ENV_ID, **kwargs)
    check_env(env.unwrapped)  # raises on a failed check
    assert env.observation_space.shape == (len(kwargs.get('observe', (1, 2, 3))) + 1,)
    env.close()


def test_normalized_actions_pass_without_warnings(recwarn):
    env = gym.make(envs.ENV_ID, model='cst', normalized_action=True)
    check_env(env.unwrapped)
    assert not [w for w in recwarn if 'WARN' in str(w.message)]
    assert env.action_space.high[0] == 1.0
    rows, _, _ = run(env, 0, 0.5, 3)
    assert rows[0][2]['power'] == pytest.approx(0.5 * envs.DRIVER_MAX_POWER)


def run(env, seed, power, steps):
    env.reset(seed=seed)
    rows = []
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(np.array([power], np.float32))
        rows.append((obs, reward, info))
        if terminated or truncated:
            break
    return rows, terminated, truncated


def test_same_seed_same_episode_other_seed_other_reference():
    env = gym.make(envs.ENV_ID, model='cst', episode_seconds=4.0)
    first, _, _ = run(env, 7, 1.0, 50)
    second, _, _ = run(env, 7, 1.0, 50)
    for (o1, r1, _), (o2, r2, _) in zip(first, second):
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2
    ref7 = env.unwrapped.reference.copy()
    env.reset(seed=8)
    assert not np.allclose(ref7, env.unwrapped.reference)
    reference = env.unwrapped.reference
    assert reference.min() >= 0.0 and reference.max() <= env.unwrapped.reference_max


def test_steps_the_same_simulator_as_dynamics_simulate(free_stroke):
    """Held power on the env = the same profile through simulation.simulate (cst)."""
    env = gym.make(envs.ENV_ID, config=free_stroke, model='cst',
                   observe=('displacement', 'temperature'), episode_seconds=5.0)
    rows, _, truncated = run(env, 0, 1.0, 250)
    assert truncated and len(rows) == 250  # 5 s at 50 Hz
    t = np.arange(251) * 0.02
    res = simulate(free_stroke, t, np.full(t.size, 1.0), model='cst', physics_rate=1000.0)
    got = np.array([obs[:2] for obs, _, _ in rows], dtype=float)
    # float32 observations: 6e-8 relative
    np.testing.assert_allclose(got[:, 0], res.displacement[1:], rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(got[:, 1], res.temperature[1:], rtol=1e-6)


def test_reward_is_tracking_error_energy_and_overheat():
    env = gym.make(envs.ENV_ID, model='cst', episode_seconds=20.0, energy_weight=0.1)
    rows, terminated, truncated = run(env, 1, 5.0, 1000)  # 5 W holds 400 degC: it melts
    unwrapped = env.unwrapped
    for _, reward, info in rows:
        error = info['error'] / unwrapped.reference_max
        overheat = max(0.0, info['temperature'] - envs.MAX_TEMPERATURE) / envs.OVERHEAT_SCALE
        expected = -(error ** 2 + 0.1 * info['power'] / unwrapped.max_power + overheat)
        assert reward == pytest.approx(expected, rel=1e-12)
    assert terminated and not truncated
    assert rows[-1][2]['temperature'] > envs.MELT_TEMPERATURE
    assert rows[-1][2]['energy'] == pytest.approx(5.0 * 0.02 * len(rows), rel=1e-12)


def test_voltage_action_is_clamped_to_the_driver_limit():
    env = gym.make(envs.ENV_ID, model='cst', action='voltage', max_power=2.0)
    high = env.action_space.high[0]
    assert high == pytest.approx(np.sqrt(2.0 * 25.0), rel=1e-6)  # sqrt(P_max R0), R0 25 ohm
    rows, _, _ = run(env, 0, 100.0, 5)  # far beyond the bound: clipped to it
    assert all(info['power'] <= 2.0 + 1e-12 for _, _, info in rows)
    assert rows[0][2]['power'] == pytest.approx(2.0, rel=1e-6)  # R starts at R0


@pytest.mark.parametrize('kwargs,needle', [
    (dict(observe=('strain',)), 'observe'), (dict(action='current'), 'action'),
    (dict(control_rate=30.0), 'physics_rate'), (dict(max_power=0.0), 'max_power')])
def test_bad_arguments_are_refused(kwargs, needle):
    with pytest.raises(ValueError, match=needle):
        envs.TcaTrackingEnv(model='cst', **kwargs)
