"""A gymnasium environment: track a displacement reference with one simulated TCA.

Importing this module registers ``TcaTracking-v0``::

    import gymnasium as gym
    import tca_ros.toolkit.envs  # noqa: F401  (registers the id)
    env = gym.make('TcaTracking-v0', config='free_stroke', model='cst',
                   observe=('displacement', 'temperature'), action='power')

The plant is tca_ros.model.dynamics.TcaSimulator (eqs. (1) and (18)), stepped at
``physics_rate`` with the action held for one control period (zero-order hold).
A voltage action gives P = V^2 / R(T, x) every physics step, clamped to the
driver limit, as the node applies ``voltage_cmd``. The reference is drawn per
episode from the seeded generator: a sequence of holds, ramps and sines within
[0, reference_max]. Reward per control step (dimensionless, <= 0):

    r = -(e / e_ref)^2 - w_E P / P_max - w_T max(0, T - T_max) / 10 K

with e the tracking error (m), e_ref = reference_max, P the mean power (W) of
the step, P_max the driver limit; the episode ends (terminated) above the melt
temperature and is truncated after ``episode_seconds``. Choices: docs/toolkit.md.
"""
import math

import gymnasium as gym
from gymnasium import spaces
import numpy as np

from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.resistance import power_from_voltage
from tca_ros.model.simulation import static_displacement
from tca_ros.model.tca_params import TcaParams
from tca_ros.params.files import load_params

ENV_ID = 'TcaTracking-v0'
OBSERVABLES = ('displacement', 'velocity', 'temperature', 'resistance')
ACTIONS = ('power', 'voltage')
DRIVER_MAX_POWER = 5.0  # W, the node's default max_power (node_params.NODE_SCHEMA)
MAX_TEMPERATURE = 180.0  # degC, the node's default overheat limit
MELT_TEMPERATURE = 250.0  # degC, the node's default melt temperature: episode ends
OVERHEAT_SCALE = 10.0  # K of overheat that costs as much as a full-scale tracking error
REFERENCE_TEMPERATURE = 140.0  # degC whose static contraction is the largest reference
SEGMENT_SECONDS = (2.0, 6.0)  # s, range of one reference segment's duration
SINE_PERIODS = (1.0, 10.0)  # s, range of the reference sines' periods
# observation bounds (SI): generous physical limits, so a valid state is inside
BOUNDS = {'displacement': (-1.0, 1.0), 'velocity': (-100.0, 100.0),
          'temperature': (-273.15, 2000.0), 'resistance': (-1e6, 1e6)}


def draw_reference(rng, n_steps, dt, amplitude):
    """Return a reference displacement (m) of n_steps samples dt (s) apart.

    Segments of SEGMENT_SECONDS each: a hold at a new level (a step), a ramp to
    it, or a sine about the mid level with a period in SINE_PERIODS, all within
    [0, amplitude] (m). ``rng`` is a numpy Generator (the episode's).
    """
    out = np.empty(n_steps)
    level, k = 0.0, 0
    while k < n_steps:
        length = max(1, int(rng.uniform(*SEGMENT_SECONDS) / dt))
        t = np.arange(min(length, n_steps - k)) * dt
        kind = rng.integers(3)
        target = rng.uniform(0.0, amplitude)
        if kind == 0:
            seg = np.full(t.size, target)
        elif kind == 1:
            seg = level + (target - level) * np.minimum(t / (length * dt), 1.0)
        else:
            period = rng.uniform(*SINE_PERIODS)
            half = 0.5 * amplitude * rng.uniform(0.2, 1.0)
            seg = 0.5 * amplitude + half * np.sin(2.0 * math.pi * t / period)
        out[k:k + t.size] = seg
        level, k = float(seg[-1]), k + t.size
    return out


class TcaTrackingEnv(gym.Env):
    """Track a random displacement reference with a simulated TCA.

    Parameters
    ----------
    config : str or TcaParams
        Params file (path or shipped name) or parameters.
    model : str, optional
        Kinetostatic model rod | cst | love (default the config's).
    observe : sequence of str
        Among displacement (m), velocity (m/s, contraction rate), temperature
        (degC), resistance (ohm); the reference (m) is always appended last.
    action : str
        'power' (W, in [0, max_power]) or 'voltage' (V, in [0, sqrt(max_power R0)]).
    control_rate, physics_rate : float
        Action rate and physics rate (Hz); physics_rate a multiple of control_rate.
    episode_seconds : float
        Episode length (s).
    max_power : float
        Driver limit (W); the action bound and the clamp of a voltage action.
    energy_weight, overheat_weight : float
        w_E and w_T of the reward (module docstring).
    normalized_action : bool
        Take actions in [0, 1] (a fraction of the physical bound), as many RL
        libraries prefer; the info's 'power' stays in W.
    """

    metadata = {'render_modes': []}

    def __init__(self, config='free_stroke', model=None,
                 observe=('displacement', 'velocity', 'temperature'), action='power',
                 control_rate=50.0, physics_rate=1000.0, episode_seconds=20.0,
                 max_power=DRIVER_MAX_POWER, energy_weight=0.01, overheat_weight=1.0,
                 normalized_action=False):
        self.params = config if isinstance(config, TcaParams) else load_params(config)
        self.observe = tuple(observe)
        bad = [name for name in self.observe if name not in OBSERVABLES]
        if bad or not self.observe:
            raise ValueError(f'observe = {observe!r}: choose among {", ".join(OBSERVABLES)}')
        if action not in ACTIONS:
            raise ValueError(f"action = {action!r}: must be 'power' or 'voltage'")
        substeps = physics_rate / control_rate
        if not (control_rate > 0.0 and abs(substeps - round(substeps)) < 1e-9
                and substeps >= 1):
            raise ValueError(f'physics_rate = {physics_rate:g} Hz: must be a multiple of '
                             f'control_rate = {control_rate:g} Hz')
        if not max_power > 0.0:
            raise ValueError(f'max_power = {max_power!r}: must be > 0 W')
        self.action_kind = action
        self.substeps = int(round(substeps))
        self.dt = 1.0 / control_rate  # s, one env step
        self.n_steps = max(1, int(round(episode_seconds * control_rate)))
        self.max_power = float(max_power)
        self.energy_weight = float(energy_weight)
        self.overheat_weight = float(overheat_weight)
        self.sim = TcaSimulator(self.params, model=model, dt=1.0 / physics_rate)
        p = self.params
        self.reference_max = float(static_displacement(
            p, p.dynamics.load, [p.thermal.ambient_temperature, REFERENCE_TEMPERATURE],
            kinetostatics=self.sim.kinetostatics)[1])
        high = self.max_power if action == 'power' else math.sqrt(
            self.max_power * p.electrical.resistance)
        self.action_bound = float(high)  # W or V
        self.action_scale = self.action_bound if normalized_action else 1.0
        self.action_space = spaces.Box(0.0, high / self.action_scale, shape=(1,),
                                       dtype=np.float32)
        low = [BOUNDS[name][0] for name in self.observe] + [BOUNDS['displacement'][0]]
        high = [BOUNDS[name][1] for name in self.observe] + [BOUNDS['displacement'][1]]
        self.observation_space = spaces.Box(np.array(low, dtype=np.float32),
                                            np.array(high, dtype=np.float32),
                                            dtype=np.float32)
        self.reference = np.zeros(self.n_steps + 1)
        self._k = 0
        self._energy = 0.0

    def _observation(self):
        s = self.sim.state
        values = {'displacement': s.measured_displacement, 'velocity': -s.velocity,
                  'temperature': s.temperature, 'resistance': s.resistance}
        obs = [values[name] for name in self.observe] + [self.reference[self._k]]
        return np.clip(np.array(obs, dtype=np.float32), self.observation_space.low,
                       self.observation_space.high)

    def _info(self, power=0.0):
        s = self.sim.state
        return {'time': s.time, 'reference': float(self.reference[self._k]),
                'displacement': s.measured_displacement, 'temperature': s.temperature,
                'power': power, 'energy': self._energy,
                'error': float(self.reference[self._k] - s.measured_displacement)}

    def reset(self, *, seed=None, options=None):
        """Return (observation, info) at the loaded equilibrium at ambient, new reference."""
        super().reset(seed=seed)
        self.sim.reset()
        self._k = 0
        self._energy = 0.0
        self.reference = np.concatenate((
            [0.0], draw_reference(self.np_random, self.n_steps, self.dt, self.reference_max)))
        return self._observation(), self._info()

    def step(self, action):
        """Apply the action for one control period; return the gymnasium 5-tuple."""
        value = self.action_scale * float(np.clip(
            np.asarray(action, dtype=float).reshape(-1)[0], 0.0, self.action_space.high[0]))
        state, delivered = self.sim.state, 0.0
        for _ in range(self.substeps):
            power = value
            if self.action_kind == 'voltage':
                r = state.resistance
                power = min(power_from_voltage(value, r), self.max_power) if r > 0.0 else 0.0
            state = self.sim.step(power)
            delivered += power / self.substeps
        self._energy += delivered * self.dt
        self._k = min(self._k + 1, self.n_steps)
        finite = all(math.isfinite(v) for v in (state.temperature, state.displacement))
        error = (self.reference[self._k] - state.measured_displacement) / self.reference_max
        overheat = max(0.0, state.temperature - MAX_TEMPERATURE) / OVERHEAT_SCALE
        reward = -(error * error + self.energy_weight * delivered / self.max_power
                   + self.overheat_weight * overheat)
        terminated = not finite or state.temperature > MELT_TEMPERATURE
        truncated = self._k >= self.n_steps and not terminated
        if not math.isfinite(reward):
            reward = -1e6
        return self._observation(), float(reward), terminated, truncated, self._info(delivered)


if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point='tca_ros.toolkit.envs:TcaTrackingEnv')
