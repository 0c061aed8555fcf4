"""Whole-profile simulation on the stepper of dynamics.py: ``simulate`` and statics.

``simulate`` runs ``TcaSimulator`` (the thermal model (1) and the kinetostatic
dynamics (18) of [1], stepped as described in dynamics.py) over a sampled power
(W) and load (N) profile, inputs held between samples, and returns the sampled
outputs as a ``SimulationResult``. ``static_displacement`` is the loaded
equilibrium contraction (m) over a sequence of temperatures (degC), by
continuation in temperature (Algorithm 1 of [1]), coil contact applied.
"""
from dataclasses import dataclass

import numpy as np

from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import contact_elongation

# relative change of the sample interval below which the step is kept: a uniform grid read
# back from text varies by ~1e-12 (0.01 s written as 0.0100), and each re-planned step costs
# a stiffness evaluation (two fixed-point tension solves)
STEP_CHANGE_TOLERANCE = 1e-9


@dataclass
class SimulationResult:
    """Sampled simulation output; arrays of shape (n,), SI units, degC."""

    time: np.ndarray
    power: np.ndarray
    load: np.ndarray
    displacement: np.ndarray  # m, contraction as the sensor reads it
    temperature: np.ndarray  # degC
    resistance: np.ndarray  # ohm
    tension: np.ndarray  # N
    velocity: np.ndarray  # m/s, contraction rate
    true_displacement: np.ndarray  # m, contraction before the (lagged) sensor
    substeps: int  # substeps per physics step used at the start


def simulate(params, time, power, load=None, model=None, physics_rate=1000.0,
             kinetostatics=None, supply='power'):
    """Simulate a power (W) and load (N) profile; return samples at ``time`` (s).

    Inputs are held constant between samples (zero-order hold). The physics runs at
    ``physics_rate`` (Hz), or at the sample interval when that is finer. The state
    starts at the loaded equilibrium at ambient under ``load[0]``. A run that fails
    part-way (ThreadBreakError, a model leaving its range) raises with the samples
    before the failure as the exception's ``partial`` SimulationResult. ``supply``:
    'power' (the column is the power delivered) or 'voltage' (the column is the
    nominal power of a constant-voltage supply set at R0, so the power applied
    is P R0 / R(T, x), updated every physics step). With
    ``thermal.initial_temperature_rise`` > 0 the start is that much above ambient
    and the displacement is read from the start (:func:`read_from_start`).
    """
    if supply not in ('power', 'voltage'):
        raise ValueError(f"supply = {supply!r}: must be 'power' or 'voltage'")
    time = np.asarray(time, dtype=float)
    power = np.asarray(power, dtype=float)
    load = (np.full_like(time, params.dynamics.load) if load is None
            else np.asarray(load, dtype=float))
    if time.ndim != 1 or time.size < 1 or power.shape != time.shape or \
            load.shape != time.shape:
        raise ValueError('time, power and load must be 1-D arrays of equal length')
    if time.size > 1 and not np.all(np.diff(time) > 0.0):
        raise ValueError('time must be strictly increasing')
    intervals = np.diff(time)
    dt = min(1.0 / physics_rate, float(intervals.min())) if time.size > 1 \
        else 1.0 / physics_rate
    sim = TcaSimulator(params, model=model, dt=dt, kinetostatics=kinetostatics)
    state = sim.reset(load=load[0])
    n0 = sim.check_step()
    out = np.empty((6, time.size))
    out[:, 0] = _sample(state)

    def result(n):
        """Return the first n samples as a SimulationResult."""
        x = out[:, :n].copy()
        if params.thermal.initial_temperature_rise > 0.0 and n > 0:
            x[0], x[5] = read_from_start(x[0], x[5])
        return SimulationResult(time=time[:n], power=power[:n], load=load[:n],
                                displacement=x[0], temperature=x[1], resistance=x[2],
                                tension=x[3], velocity=x[4], true_displacement=x[5],
                                substeps=n0)
    i = 1
    try:
        for i in range(1, time.size):
            span = time[i] - time[i - 1]
            steps = max(1, int(round(span / dt)))
            if abs(sim.dt - span / steps) > STEP_CHANGE_TOLERANCE * sim.dt:
                sim.set_dt(span / steps)
            for _ in range(steps):
                applied = power[i - 1]
                if supply == 'voltage':
                    if not state.resistance > 0.0:
                        raise ArithmeticError(f'voltage supply: resistance '
                                              f'{state.resistance:g} ohm is not positive')
                    applied = applied * params.electrical.resistance / state.resistance
                state = sim.step(applied, load[i - 1])
            out[:, i] = _sample(state)
    except (ValueError, ArithmeticError) as exc:  # e.g. ThreadBreakError: the run ends
        exc.partial = result(i)  # the samples before the failure, for a caller to keep
        raise
    return result(time.size)


def read_from_start(measured, true_displacement):
    """Return both contractions (m) less their first value: zero at the start.

    A record's sensor reads zero where the record starts. At rest that is the
    loaded equilibrium at ambient, the simulators' reference, and nothing
    changes; a record that begins warm (``thermal.initial_temperature_rise`` > 0)
    starts at the contraction of that excess, and cooling reads below zero.
    """
    return measured - measured[0], true_displacement - true_displacement[0]


def _sample(s):
    return (s.measured_displacement, s.temperature, s.resistance, s.tension, -s.velocity,
            s.displacement)


def static_displacement(params, load, temperatures, model=None, kinetostatics=None):
    """Return the contraction (m) under load (N) at each temperature (degC).

    Zero at the first temperature (the loaded equilibrium there); coil contact
    applied. Continuation in temperature (Algorithm 1 of [1]).
    """
    km = kinetostatics or make_kinetostatic_model(params, model)
    stop = contact_elongation(params)
    temps = np.asarray(temperatures, dtype=float)
    out = np.empty_like(temps)
    guess = None
    for i, temp in enumerate(temps):
        guess = km.equilibrium_elongation(load, float(temp), guess=guess)
        out[i] = max(guess, stop)
    return out[0] - out
