"""Sampled simulation of a TCA on its rig (params.rig.mode; tca_ros.model.rigs).

``simulate_rig`` is ``simulation.simulate`` for every load mode: inputs held between
samples (zero-order hold), physics at ``physics_rate``, outputs sampled into the
columns of RIG_COLUMNS (units: time s, power and power_2 W, load N, displacement
m, temperature degC, resistance ohm, force N, angle rad, angular_velocity rad/s,
torque N m; docs/rigs.md).
"""
from dataclasses import dataclass

import numpy as np

from tca_ros.model.rigs import ANTAGONISTIC, DEAD_WEIGHT, ISOMETRIC, make_rig, SPRING
from tca_ros.model.rigs import start_load
from tca_ros.model.simulation import simulate

#: Output columns of simulate_rig per rig (units: docs/rigs.md).
RIG_COLUMNS = {
    DEAD_WEIGHT: ('time', 'power', 'load', 'displacement', 'temperature', 'resistance'),
    SPRING: ('time', 'power', 'load', 'displacement', 'temperature', 'resistance', 'force'),
    ISOMETRIC: ('time', 'power', 'temperature', 'resistance', 'force'),
    ANTAGONISTIC: ('time', 'power', 'power_2', 'angle', 'angular_velocity', 'torque',
                   'temperature', 'temperature_2', 'force', 'force_2', 'resistance',
                   'resistance_2'),
}


@dataclass
class RigResult:
    """Sampled output of a rig: ``columns`` maps RIG_COLUMNS[mode] to arrays (n,)."""

    mode: str
    columns: dict


def simulate_rig(params, time, power, load=None, power_2=None, model=None,
                 physics_rate=1000.0, kinetostatics=None):
    """Simulate params.rig.mode under power (W) and load (N) held between samples.

    ``load`` is the dead weight (N) or the spring's F_0 (N; default rig.pretension);
    the isometric and antagonistic rigs take none. ``power_2`` (W, default 0) heats
    the antagonist. Samples at ``time`` (s), physics at ``physics_rate`` (Hz) or
    the sample interval when finer; the state starts at rest at ambient. A run that
    fails part-way raises with the samples before it as the exception's ``partial``
    RigResult.
    """
    mode = params.rig.mode
    time = np.asarray(time, dtype=float)
    power = np.asarray(power, dtype=float)
    if mode == DEAD_WEIGHT:
        try:
            res = simulate(params, time, power, load, model=model,
                           physics_rate=physics_rate, kinetostatics=kinetostatics)
        except (ValueError, ArithmeticError) as exc:
            if hasattr(exc, 'partial'):
                exc.partial = _dead_weight(exc.partial)
            raise
        return _dead_weight(res)
    if load is not None and mode != SPRING:
        raise ValueError(f'rig.mode = {mode!r}: takes no load input (the load is the rig)')
    if power_2 is not None and mode != ANTAGONISTIC:
        raise ValueError(f'rig.mode = {mode!r}: power_2 heats the antagonist of the '
                         'antagonistic rig only')
    load = np.full_like(time, start_load(params)) if load is None else np.asarray(load, float)
    power_2 = np.zeros_like(time) if power_2 is None else np.asarray(power_2, float)
    if time.ndim != 1 or time.size < 1 or not (power.shape == load.shape == power_2.shape
                                               == time.shape):
        raise ValueError('time, power, load and power_2 must be 1-D arrays of equal length')
    if time.size > 1 and not np.all(np.diff(time) > 0.0):
        raise ValueError('time must be strictly increasing')
    dt = min(1.0 / physics_rate, float(np.diff(time).min())) if time.size > 1 \
        else 1.0 / physics_rate
    sim = make_rig(params, model=model, dt=dt, kinetostatics=kinetostatics)
    sim.reset(load=load[0])
    names = RIG_COLUMNS[mode]
    out = {name: np.empty(time.size) for name in names}
    _sample(sim, out, 0, time[0], power[0], load[0], power_2[0])
    i = 1
    try:
        for i in range(1, time.size):
            span = time[i] - time[i - 1]
            steps = max(1, int(round(span / dt)))
            if abs(sim.dt - span / steps) > 1e-12 * sim.dt:
                sim.set_dt(span / steps)
            for _ in range(steps):
                if mode == ANTAGONISTIC:
                    sim.step(power[i - 1], power_2=power_2[i - 1])
                else:
                    sim.step(power[i - 1], load[i - 1])
            _sample(sim, out, i, time[i], power[i], load[i], power_2[i])
    except (ValueError, ArithmeticError) as exc:  # the run ends: keep the samples before
        exc.partial = RigResult(mode, {name: column[:i] for name, column in out.items()})
        raise
    return RigResult(mode, out)


def _dead_weight(res):
    """Return the RigResult of a dead-weight SimulationResult."""
    return RigResult(DEAD_WEIGHT, {'time': res.time, 'power': res.power, 'load': res.load,
                                   'displacement': res.displacement,
                                   'temperature': res.temperature,
                                   'resistance': res.resistance})


def _sample(sim, out, i, time, power, load, power_2):
    s = sim.state
    values = dict(sim.outputs(), time=time, power=power, load=load, power_2=power_2,
                  displacement=s.measured_displacement, temperature=s.temperature,
                  resistance=s.resistance)
    for name, column in out.items():
        column[i] = values[name]
