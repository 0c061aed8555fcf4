"""A fixed, versioned set of tracking tasks and the metrics controls papers report.

Each task gives a displacement reference (m) and an external load (N) as
functions of time. Amplitudes are fractions of the muscle's stroke scale
S = x(T_ref), its static contraction at REFERENCE_TEMPERATURE under the config's
load, so one task set serves any muscle; the overheat task aims at the static
contraction just below ``max_temperature``. Changing a task changes
TASKS_VERSION.

Metrics of one run (``score``): RMS and max tracking error (m), overshoot (% of
the step) and 5 % settling time (s) of the reference's steps, electrical energy
(J), peak temperature (degC) and time above ``max_temperature`` (s).
"""
from dataclasses import dataclass
import math

import numpy as np

TASKS_VERSION = 'v1'
REFERENCE_TEMPERATURE = 140.0  # degC whose static contraction is the stroke scale S
OVERHEAT_MARGIN = 5.0  # K below max_temperature the overheat task aims at
SETTLING_BAND = 0.05  # fraction of a step's size the error must stay within
RANDOM_SEED = 12  # the random-reference task's levels (fixed: part of the version)
RANDOM_HOLD = 2.0  # s each random level is held


@dataclass(frozen=True)
class Task:
    """One tracking task: reference and load as fractions of the scales, over time (s)."""

    name: str
    duration: float  # s
    description: str
    kind: str  # reference shape: steps | ramp | sine | random | overheat
    levels: tuple = ()  # (start time (s), fraction of S) for steps
    period: float = 0.0  # s, for sines
    load_steps: tuple = ()  # (start time (s), load factor), 1 = the config's load

    def reference(self, t, stroke, overheat_stroke=None):
        """Return the reference contraction (m) at times t (s) for stroke scale S (m)."""
        t = np.asarray(t, dtype=float)
        if self.kind == 'steps':
            return stroke * _held(t, self.levels)
        if self.kind == 'ramp':
            return stroke * 0.8 * np.clip((t - 1.0) / 10.0, 0.0, 1.0)
        if self.kind == 'sine':
            return stroke * (0.4 + 0.25 * np.sin(2.0 * math.pi * t / self.period))
        if self.kind == 'random':
            levels = np.random.default_rng(RANDOM_SEED).uniform(
                0.1, 0.9, int(math.ceil(self.duration / RANDOM_HOLD)) + 1)
            return stroke * levels[np.minimum((t // RANDOM_HOLD).astype(int), levels.size - 1)]
        if self.kind == 'overheat':
            return overheat_stroke * np.clip((t - 1.0) / 10.0, 0.0, 1.0)
        raise ValueError(f'task {self.name}: unknown kind {self.kind!r}')

    def load(self, t, base_load):
        """Return the external load (N) at times t (s) for the config's load (N)."""
        return base_load * _held(np.asarray(t, dtype=float), ((0.0, 1.0),) + self.load_steps)


def _held(t, steps):
    """Return the value of the last (start, value) with start <= t, per t."""
    out = np.zeros_like(t)
    for start, value in steps:
        out = np.where(t >= start, value, out)
    return out


#: The default task set, version TASKS_VERSION.
DEFAULT_TASKS = (
    Task('step_up', 15.0, 'step 0 -> 0.5 S at 1 s', 'steps', ((1.0, 0.5),)),
    Task('step_down', 20.0, 'step to 0.7 S at 1 s, down to 0.2 S at 11 s', 'steps',
         ((1.0, 0.7), (11.0, 0.2))),
    Task('ramp', 15.0, 'ramp 0 -> 0.8 S over 10 s from 1 s, then hold', 'ramp'),
    Task('sine_10s', 20.0, '0.4 S + 0.25 S sin, period 10 s', 'sine', period=10.0),
    Task('sine_2s', 10.0, '0.4 S + 0.25 S sin, period 2 s', 'sine', period=2.0),
    Task('random', 20.0, f'levels in [0.1, 0.9] S held {RANDOM_HOLD:g} s (seed {RANDOM_SEED})',
         'random'),
    Task('load_disturbance', 20.0, '0.5 S from 1 s; load x1.5 from 8 s to 14 s', 'steps',
         ((1.0, 0.5),), load_steps=((8.0, 1.5), (14.0, 1.0))),
    Task('near_overheat', 20.0, f'ramp to the contraction at max_temperature - '
         f'{OVERHEAT_MARGIN:g} K over 10 s, then hold', 'overheat'),
)
TASK_SETS = {'default': DEFAULT_TASKS}


def step_events(t, reference, min_jump):
    """Return [(index, size (m))] of the reference's jumps larger than min_jump (m)."""
    jumps = np.diff(reference)
    return [(int(i) + 1, float(jumps[i])) for i in np.flatnonzero(np.abs(jumps) > min_jump)]


def score(t, reference, displacement, temperature, power, max_temperature):
    """Return the metrics of one run; samples at times t (s), zero-order-hold power.

    Parameters
    ----------
    t : ndarray
        Sample times (s), increasing.
    reference, displacement : ndarray
        Reference and measured contraction (m).
    temperature : ndarray
        Temperature (degC).
    power : ndarray
        Electrical power (W) applied from each sample to the next.
    max_temperature : float
        Overheat limit (degC).

    Returns
    -------
    dict
        rms_error (m), max_error (m), overshoot (% of the largest step's size, NaN
        without steps), settling_time (s after the slowest step until the error stays
        within SETTLING_BAND of its size; inf if never), energy (J), peak_temperature
        (degC), time_above_max (s).
    """
    t, r, y = (np.asarray(a, dtype=float) for a in (t, reference, displacement))
    temp, p = np.asarray(temperature, dtype=float), np.asarray(power, dtype=float)
    dt = np.diff(t)
    error = r - y
    span = max(float(np.ptp(r)), 1e-12)
    events = step_events(t, r, 0.05 * span)
    ends = [i for i, _ in events[1:]] + [t.size]
    overshoot, settling = math.nan, math.nan
    for (i, size), end in zip(events, ends):
        after = slice(i, end)
        beyond = float(np.max(-error[after] * math.copysign(1.0, size)))
        share = 100.0 * max(beyond, 0.0) / abs(size)
        overshoot = share if math.isnan(overshoot) else max(overshoot, share)
        outside = np.flatnonzero(np.abs(error[after]) > SETTLING_BAND * abs(size))
        if outside.size == 0:
            seconds = 0.0
        elif outside[-1] == end - i - 1:
            seconds = math.inf
        else:
            seconds = float(t[i + outside[-1] + 1] - t[i])
        settling = seconds if math.isnan(settling) else max(settling, seconds)
    above = (temp[:-1] > max_temperature) | (temp[1:] > max_temperature)
    return {'rms_error': float(np.sqrt(np.mean(error ** 2))),
            'max_error': float(np.max(np.abs(error))),
            'overshoot': overshoot, 'settling_time': settling,
            'energy': float(np.sum(p[:-1] * dt)),
            'peak_temperature': float(np.max(temp)),
            'time_above_max': float(np.sum(dt[above]))}
