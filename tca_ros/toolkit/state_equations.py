"""The TCA's state equations x' = f(x, u) and their equilibria, Eqs. (1) and (18) of [1].

The nonlinear side of the small-signal toolkit (linearize.py differentiates it):
``PlantModel`` (the params and kinetostatics a state equation needs),
``state_rate`` and ``plant_outputs`` in python-control's order (t, x, u, plant),
and ``operating_point``, the equilibrium under constant power (or voltage) and
load. The equations, the states and the outputs are listed in linearize.py's
docstring; their right-hand sides are the steppers' own (eq. (1) and the lags
in model/thermal.py, eq. (18) and the creep in model/end_motion.py);
assumptions and their reasons: docs/toolkit.md.

References
----------
[1] J. Sun and J. Zhao, IEEE Trans. Robot., 2022.
"""
from dataclasses import dataclass
import math

import numpy as np
from scipy.optimize import brentq

from tca_ros.model import effects as fx
from tca_ros.model.end_motion import end_acceleration, massless_speed
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import contact_elongation, KinetostaticModel
from tca_ros.model.resistance import power_from_voltage, resistance
from tca_ros.model.thermal import heat_rate, HeatBalance, lag_rate, steady_temperature

DRIVES = ('power', 'voltage')
MAX_RISE = 5000.0  # K above ambient searched for the nonlinear thermal equilibrium


class OperatingPointError(ValueError):
    """No small-signal plant there: coil contact, or a play operator switched on."""


class PlantModel:
    """The TCA's state equations at one load and drive (what f(x, u) needs).

    Parameters
    ----------
    params : TcaParams
        The TCA whose plant is wanted (a config/*.yaml loaded).
    model : str, optional
        Its kinetostatic model: rod | cst | love (default ``params.model``).
    drive : str
        'power' (input P in W) or 'voltage' (input V in V, P = V^2 / R).
    """

    def __init__(self, params, model=None, drive='power'):
        e = params.effects
        if drive not in DRIVES:
            raise ValueError(f"drive = {drive!r}: must be 'power' or 'voltage'")
        for name, value in (('effects.hysteresis_width', e.hysteresis_width),
                            ('effects.friction_force', e.friction_force)):
            if value > 0.0:
                raise OperatingPointError(
                    f'{name} = {value:g}: a play operator has no small-signal gain; '
                    'linearise with it set to 0 (docs/toolkit.md)')
        self.params = params
        self.drive = drive
        self.kinetostatics = make_kinetostatic_model(params, model)
        self.model = self.kinetostatics.name
        self.heat = HeatBalance.of(params)  # eq. (1)'s coefficients
        self.ambient = self.heat.ambient  # degC, T_inf with the offset
        self.contact = contact_elongation(params)  # m
        d = params.dynamics
        names = ['temperature']
        if e.second_thermal_lag > 0.0:
            names.append('fiber_temperature')
        if d.mass > 0.0 or d.damping > 0.0:
            names.append('elongation')
        if d.mass > 0.0:
            names.append('velocity')
        if e.creep_compliance > 0.0:
            names.append('creep')
        if e.sensor_lag > 0.0:
            names.append('sensor')
        self.states = tuple(names)
        self.index = {name: i for i, name in enumerate(names)}
        self.reference_elongation = math.nan  # m, set per load by operating_point
        self.loaded_length = math.nan  # m

    def set_reference(self, load):
        """Set q_ref (m) and l0 (m): the loaded equilibrium at ambient under load (N)."""
        q_ref = max(self.kinetostatics.equilibrium_elongation(load, self.ambient),
                    self.contact)
        self.reference_elongation = q_ref
        self.loaded_length = self.kinetostatics.natural_length + q_ref


def _get(x, plant, name, default):
    i = plant.index.get(name)
    return default if i is None else x[i]


def coil_elongation(x, u, plant):
    """Return (q (m), y_c (m)): the free end's elongation and the creep in it.

    Massless and undamped, q is the static equilibrium of eq. (18) at T_f.
    """
    temp = x[0]
    fiber = _get(x, plant, 'fiber_temperature', temp)
    creep = _get(x, plant, 'creep', 0.0)
    if 'elongation' in plant.index:
        return x[plant.index['elongation']], creep
    y = plant.kinetostatics.equilibrium_elongation(u[1], fiber)
    return creep + max(y, plant.contact), creep


def applied_power(x, u, plant):
    """Return the electrical power (W): u[0], or V^2 / R(T, x) under a voltage drive."""
    if plant.drive == 'power':
        return u[0]
    return power_from_voltage(u[0], plant_outputs(0.0, x, u, plant, true=True)[2])


def state_rate(t, x, u, plant):
    """Return dx/dt of the plant (SI units per s) at state x, input u = [P or V, F].

    Eqs. (1) and (18) with the effects listed in the module docstring.
    """
    p, e = plant.params, plant.params.effects
    d = p.dynamics
    rate = np.zeros(len(plant.states))
    temp = x[0]
    fiber = _get(x, plant, 'fiber_temperature', temp)
    rate[0] = heat_rate(temp, applied_power(x, u, plant), plant.heat)  # Eq. (1)
    if 'fiber_temperature' in plant.index:
        rate[plant.index['fiber_temperature']] = lag_rate(fiber, temp, e.second_thermal_lag)
    q, creep = coil_elongation(x, u, plant)
    tension = plant.kinetostatics.tension(q - creep, fiber)
    if 'elongation' in plant.index:
        net = u[1] - tension  # N, Eq. (18)
        if d.mass > 0.0:
            v = x[plant.index['velocity']]
            rate[plant.index['elongation']] = v
            rate[plant.index['velocity']] = end_acceleration(net, v, d.mass, d.damping)
        else:
            rate[plant.index['elongation']] = massless_speed(net, d.damping)
    if 'creep' in plant.index:
        rate[plant.index['creep']] = fx.creep_rate(creep, tension, e)
    if 'sensor' in plant.index:
        true_x = plant.reference_elongation - q
        rate[plant.index['sensor']] = lag_rate(x[plant.index['sensor']], true_x, e.sensor_lag)
    return rate


def plant_outputs(t, x, u, plant, true=False):
    """Return [displacement (m), temperature (degC), resistance (ohm)] at x, u.

    The displacement is the sensor's (lagged) reading unless ``true``; the
    resistance always sees the true contraction (as in the simulator).
    """
    p = plant.params
    q, _ = coil_elongation(x, u, plant)
    contraction = plant.reference_elongation - q
    measured = contraction if true or 'sensor' not in plant.index \
        else x[plant.index['sensor']]
    r = resistance(x[0], contraction, plant.loaded_length, p.electrical,
                   p.thermal.ambient_temperature)
    return np.array([measured, x[0], r])


@dataclass(frozen=True)
class OperatingPoint:
    """Equilibrium under constant power and load; SI units, temperatures in degC."""

    power: float  # W
    load: float  # N
    voltage: float  # V, sqrt(P R) at the point
    temperature: float  # degC
    elongation: float  # m, q of the free end from l*
    creep: float  # m
    displacement: float  # m, contraction from the loaded equilibrium at ambient
    resistance: float  # ohm
    stiffness: float  # N/m, d f_rod / d y there
    state: tuple  # the state vector x0
    inputs: tuple  # u0 = [P or V, F]


def equilibrium_temperature(power, plant):
    """Return T (degC) where Eq. (1) is at rest under power (W); brentq if nonlinear."""
    heat = plant.heat
    if heat.linear:
        return steady_temperature(power, heat)
    if heat.gain * power <= 0.0:
        return plant.ambient
    return brentq(lambda temp: heat_rate(temp, power, heat), plant.ambient,
                  plant.ambient + MAX_RISE, xtol=1e-10)


def operating_point(plant, power, load):
    """Return the OperatingPoint of ``plant`` under power (W) and load (N).

    Raises OperatingPointError when the coils touch there (a hard stop has no gain).
    """
    plant.set_reference(load)
    temp = equilibrium_temperature(power, plant)
    km = plant.kinetostatics
    # Newton on the dynamics' own f_rod from the statics' solution: the rod model's
    # statics solve the exact helix, its dynamics interpolate a table of them
    y = KinetostaticModel.equilibrium_elongation(
        km, load, temp, guess=km.equilibrium_elongation(load, temp))
    if not math.isfinite(y):
        raise ValueError(f'load = {load:g} N: no static equilibrium at {temp:.4g} degC')
    if y <= plant.contact:
        raise OperatingPointError(
            f'power = {power:g} W: the coils touch at {temp:.4g} degC under {load:g} N (coil '
            'contact, zero small-signal gain); choose a lower power or a larger load')
    creep = plant.params.effects.creep_compliance * load
    q = y + creep
    contraction = plant.reference_elongation - q
    values = {'temperature': temp, 'fiber_temperature': temp, 'elongation': q,
              'velocity': 0.0, 'creep': creep, 'sensor': contraction}
    x0 = np.array([values[name] for name in plant.states])
    r = float(plant_outputs(0.0, x0, (power, load), plant, true=True)[2])
    voltage = math.sqrt(power * r) if r > 0.0 else math.nan
    u0 = (power if plant.drive == 'power' else voltage, load)
    return OperatingPoint(power=power, load=load, voltage=voltage, temperature=temp,
                          elongation=q, creep=creep, displacement=contraction,
                          resistance=r, stiffness=km.stiffness(y, temp),
                          state=tuple(x0), inputs=tuple(u0))
