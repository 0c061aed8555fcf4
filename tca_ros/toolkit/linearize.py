"""Small-signal plant of the TCA at an operating point, Eqs. (1) and (18) of [1].

The simulator's state equations, written as x' = f(x, u) in python-control's
order (t, x, u, params) and linearised by central differences around the
equilibrium under constant power P0 and load F:

    m_t c_p dT/dt  = (1 - eta) r P - h c_s A_0 (T - T_inf) phi(T) - Q_rad(T)  (1)
    tau_2 dT_f/dt  = T - T_f                  second thermal lag, when on
    dq/dt          = v
    m dv/dt        = F - f_rod(q - y_c, T_f) - b_t v                         (18)
    tau_c dy_c/dt  = C_c f_rod - y_c          creep, when on
    tau_s dx_m/dt  = x - x_m                  sensor lag, when on

with q the elongation (m) of the free end, x = q_ref - q the contraction from
the loaded equilibrium at ambient (the published displacement) and outputs
[x_m (x without a sensor lag), T, R(T, x)]. Massless (m = 0) the velocity is
no state and b_t dq/dt = F - f_rod; with b_t = 0 too, q is the static
equilibrium of T_f and no state either. Under a voltage drive the input is V
and P = V^2 / R(T, x), so the resistance feeds back into eq. (1). A dead time
of the drive (effects.dead_time) is kept apart as ``dead_time``; the play
operators (hysteresis, friction) have no small-signal gain and are refused.
Assumptions and their reasons: docs/toolkit.md.

References
----------
[1] J. Sun and J. Zhao, IEEE Trans. Robot., 2022.
"""
from dataclasses import dataclass
import math

import numpy as np
from scipy.optimize import brentq

from tca_ros.model import effects as fx
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import contact_elongation, KinetostaticModel
from tca_ros.model.resistance import power_from_voltage, resistance
from tca_ros.model.thermal import heat_capacity, surface_area, thermal_conductance

DRIVES = ('power', 'voltage')
OUTPUTS = ('displacement', 'temperature', 'resistance')
OUTPUT_UNITS = {'displacement': 'm', 'temperature': 'K', 'resistance': 'ohm'}
INPUT_UNITS = {'power': 'W', 'voltage': 'V', 'load': 'N'}
# central-difference steps per variable: large enough that the eq. (11) fixed point
# (solved to 1e-9 N) is far below the tension change, small against the curvature
FD_STEPS = {'temperature': 0.05, 'fiber_temperature': 0.05, 'elongation': 1e-6,
            'velocity': 1e-5, 'creep': 1e-6, 'sensor': 1e-6,
            'power': 1e-3, 'voltage': 1e-3, 'load': 1e-4}
EQUILIBRIUM_RATE_TOLERANCE = 1e-3  # |f(x0, u0)| allowed, relative to |A| times the FD steps
TF_ROUNDING = 1e-9  # numerator coefficients below this share of the largest are noise
MAX_RISE = 5000.0  # K above ambient searched for the nonlinear thermal equilibrium


class OperatingPointError(ValueError):
    """No small-signal plant there: coil contact, or a play operator switched on."""


class PlantModel:
    """The TCA's state equations at one load and drive (what f(x, u) needs).

    Parameters
    ----------
    params : TcaParams
        The TCA (config/*.yaml).
    model : str, optional
        Kinetostatic model rod | cst | love (default ``params.model``).
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
        self.capacity = heat_capacity(params.fiber)  # J/K
        self.conductance = thermal_conductance(params.fiber, params.thermal)  # W/K
        self.area = surface_area(params.fiber)  # m^2
        self.ambient = fx.true_ambient(params.thermal, e)  # degC
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


def thermal_rate(temp, power, plant):
    """Return dT/dt (K/s) of Eq. (1) with the thermal effects at T (degC), P (W)."""
    p, e = plant.params, plant.params.effects
    loss = plant.conductance * (temp - plant.ambient) * fx.convection_factor(
        temp, plant.ambient, e)
    loss += fx.radiation_loss(temp, plant.ambient, plant.area, e)
    heating = fx.heating_power(power, e, p.thermal.delivered_power_ratio)
    return (heating - loss) / plant.capacity


def state_rate(t, x, u, plant):
    """Return dx/dt of the plant (SI units per s) at state x, input u = [P or V, F].

    Eqs. (1) and (18) with the effects listed in the module docstring.
    """
    p, e = plant.params, plant.params.effects
    d = p.dynamics
    rate = np.zeros(len(plant.states))
    temp = x[0]
    fiber = _get(x, plant, 'fiber_temperature', temp)
    rate[0] = thermal_rate(temp, applied_power(x, u, plant), plant)  # Eq. (1)
    if 'fiber_temperature' in plant.index:
        rate[plant.index['fiber_temperature']] = (temp - fiber) / e.second_thermal_lag
    q, creep = coil_elongation(x, u, plant)
    tension = plant.kinetostatics.tension(q - creep, fiber)
    if 'elongation' in plant.index:
        net = u[1] - tension  # N, Eq. (18)
        if d.mass > 0.0:
            v = x[plant.index['velocity']]
            rate[plant.index['elongation']] = v
            rate[plant.index['velocity']] = (net - d.damping * v) / d.mass
        else:
            rate[plant.index['elongation']] = net / d.damping
    if 'creep' in plant.index:
        rate[plant.index['creep']] = fx.creep_rate(creep, tension, e)
    if 'sensor' in plant.index:
        true_x = plant.reference_elongation - q
        rate[plant.index['sensor']] = (true_x - x[plant.index['sensor']]) / e.sensor_lag
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
    e = plant.params.effects
    heating = fx.heating_power(power, e, plant.params.thermal.delivered_power_ratio)
    if e.emissivity == 0.0 and e.convection_exponent == 0.0:
        return plant.ambient + heating / plant.conductance
    if heating <= 0.0:
        return plant.ambient
    return brentq(lambda temp: thermal_rate(temp, power, plant), plant.ambient,
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


def central_jacobian(func, x0, steps):
    """Return d func / d x (n_out, n_x) at x0 by central differences of ``steps``."""
    x0 = np.asarray(x0, dtype=float)
    columns = []
    for i, h in enumerate(steps):
        up, down = x0.copy(), x0.copy()
        up[i] += h
        down[i] -= h
        columns.append((np.asarray(func(up)) - np.asarray(func(down))) / (2.0 * h))
    return np.column_stack(columns)


@dataclass
class LinearPlant:
    """x' = A dx + B du, dy = C dx + D du about an OperatingPoint (SI units, K for T).

    Inputs [P (W) or V (V), F (N)]; outputs [displacement (m), temperature (K),
    resistance (ohm)]; ``dead_time`` (s) delays the electrical input.
    """

    point: OperatingPoint
    drive: str
    model: str
    states: tuple
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    dead_time: float  # s

    @property
    def inputs(self):
        """Input names: the drive ('power' or 'voltage') and 'load'."""
        return (self.drive, 'load')

    def system(self):
        """Return the MIMO python-control StateSpace (named signals)."""
        import control
        return control.ss(self.A, self.B, self.C, self.D, inputs=list(self.inputs),
                          outputs=list(OUTPUTS), states=list(self.states),
                          name=f'tca_{self.drive}')

    def channel(self, output='displacement', inp=None):
        """Return the SISO StateSpace from input ``inp`` (default the drive) to output."""
        import control
        i = self.inputs.index(inp or self.drive)
        j = OUTPUTS.index(output)
        return control.ss(self.A, self.B[:, i:i + 1], self.C[j:j + 1], self.D[j:j + 1, i:i + 1],
                          inputs=[self.inputs[i]], outputs=[output],
                          states=list(self.states))

    def transfer_function(self, output='displacement', inp=None):
        """Return the SISO TransferFunction (minimal) from ``inp`` to ``output``."""
        import control
        siso = control.minreal(control.ss2tf(self.channel(output, inp)), verbose=False)
        num, den = (np.asarray(c[0][0], dtype=float) for c in (siso.num, siso.den))
        # coefficients at rounding level (relative TF_ROUNDING) are the differences' noise
        num = np.where(np.abs(num) > TF_ROUNDING * np.abs(num).max(), num, 0.0)
        return control.tf(np.trim_zeros(num, 'f'), den, inputs=[inp or self.drive],
                          outputs=[output])

    def dc_gain(self, output='displacement', inp=None):
        """Return the static gain -C A^-1 B + D (output unit per input unit)."""
        i = self.inputs.index(inp or self.drive)
        j = OUTPUTS.index(output)
        return float(self.D[j, i] - self.C[j] @ np.linalg.solve(self.A, self.B[:, i]))

    def mean_delay(self, output='displacement', inp=None):
        """Return the mean (Elmore) delay -G'(0)/G(0) + dead time (s) of a channel.

        For first-order lags in series it is the sum of their time constants, so it
        measures how much of the response time each lag accounts for.
        """
        i = self.inputs.index(inp or self.drive)
        j = OUTPUTS.index(output)
        a_inv_b = np.linalg.solve(self.A, self.B[:, i])
        slope = float(self.C[j] @ np.linalg.solve(self.A, a_inv_b))  # -G'(0) = C A^-2 B
        return slope / self.dc_gain(output, inp) + self.dead_time

    def frequency_response(self, omega, output='displacement', inp=None):
        """Return G(j omega) (complex, output unit per input unit) at omega (rad/s).

        G(s) = C (s I - A)^-1 B + D, without the dead time.
        """
        i = self.inputs.index(inp or self.drive)
        j = OUTPUTS.index(output)
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        eye = np.eye(self.A.shape[0])
        pencil = 1j * omega[:, None, None] * eye - self.A
        rhs = np.broadcast_to(self.B[:, i], (omega.size, self.A.shape[0]))[..., None]
        return np.linalg.solve(pencil, rhs)[..., 0] @ self.C[j] + self.D[j, i]

    def bandwidth(self, output='displacement', inp=None):
        """Return the -3 dB bandwidth (rad/s) of a channel, NaN if none below 1e6.

        The lowest frequency where |G(j omega)| falls to |G(0)| / sqrt(2).
        """
        target = abs(self.dc_gain(output, inp)) / math.sqrt(2.0)
        grid = np.logspace(-6.0, 6.0, 1201)
        below = np.abs(self.frequency_response(grid, output, inp)) < target
        if target == 0.0 or not below.any() or below[0]:
            return math.nan
        k = int(np.argmax(below))

        def excess(omega):
            return abs(self.frequency_response(omega, output, inp)[0]) - target
        return brentq(excess, grid[k - 1], grid[k], xtol=1e-12, rtol=1e-12)

    def thermal_time_constant(self):
        """Return -1 / (d T' / d T) (s): the time constant of Eq. (1) at the point."""
        return -1.0 / self.A[0, 0]


def linearize(params, power, load=None, model=None, drive='power'):
    """Return the LinearPlant of the TCA at power P0 (W) and load F (N).

    The Jacobians are central differences of ``state_rate`` and ``plant_outputs``
    (steps FD_STEPS) at the equilibrium; ``load`` defaults to ``dynamics.load``.
    """
    if not (math.isfinite(power) and power >= 0.0):
        raise ValueError(f'power = {power!r}: must be a finite power >= 0 W')
    load = params.dynamics.load if load is None else float(load)
    plant = PlantModel(params, model, drive)
    point = operating_point(plant, float(power), load)
    x0, u0 = np.array(point.state), np.array(point.inputs)
    x_steps = [FD_STEPS[name] for name in plant.states]
    u_steps = [FD_STEPS[drive], FD_STEPS['load']]

    def rate_x(x):
        return state_rate(0.0, x, u0, plant)

    def rate_u(u):
        return state_rate(0.0, x0, u, plant)

    def out_x(x):
        return plant_outputs(0.0, x, u0, plant)

    def out_u(u):
        return plant_outputs(0.0, x0, u, plant)

    a = central_jacobian(rate_x, x0, x_steps)
    rest = state_rate(0.0, x0, u0, plant)
    if np.any(np.abs(rest) > EQUILIBRIUM_RATE_TOLERANCE * (np.abs(a) @ x_steps)):
        raise ArithmeticError(f'the operating point is not at rest: dx/dt = {rest}')
    return LinearPlant(point=point, drive=drive, model=plant.model, states=plant.states,
                       A=a, B=central_jacobian(rate_u, u0, u_steps),
                       C=central_jacobian(out_x, x0, x_steps),
                       D=central_jacobian(out_u, u0, u_steps),
                       dead_time=params.effects.dead_time)
