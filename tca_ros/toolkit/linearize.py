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
The state equations and operating points are in state_equations.py; assumptions
and their reasons: docs/toolkit.md.

References
----------
[1] J. Sun and J. Zhao, IEEE Trans. Robot., 2022.
"""
from dataclasses import dataclass
import math

import numpy as np
from scipy.optimize import brentq

from tca_ros.toolkit.state_equations import DRIVES, operating_point, OperatingPoint, \
    OperatingPointError, plant_outputs, PlantModel, state_rate  # noqa: F401 (API)

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


def figure_unit(key):
    """Return the unit of a drawn_figures key ('power->displacement': 'm/W'; tau: 's')."""
    if key == 'thermal_time_constant':
        return 's'
    inp, output = key.split('->')
    return f'{OUTPUT_UNITS[output]}/{INPUT_UNITS[inp]}'


def drawn_figures(samples, power, load=None):
    """Return the DC gains and thermal time constant of each params in ``samples``.

    {'figures': {'power->displacement': array, ..., 'thermal_time_constant':
    array (s)}, 'draws': linearised, 'requested': len(samples)}; a sample whose
    operating point or linearisation fails is left out. The gains are those of
    `tca_sim linearize`'s table (unit: figure_unit).
    """
    keys = [('power', 'displacement'), ('power', 'temperature'), ('power', 'resistance'),
            ('load', 'displacement'), ('voltage', 'displacement')]
    figures = {f'{i}->{o}': [] for i, o in keys}
    figures['thermal_time_constant'] = []
    for params in samples:
        try:
            plants = {d: linearize(params, power, load, drive=d) for d in ('power', 'voltage')}
            row = {f'{i}->{o}': plants['voltage' if i == 'voltage' else 'power'].dc_gain(o, i)
                   for i, o in keys}
            row['thermal_time_constant'] = plants['power'].thermal_time_constant()
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            continue
        for key, value in row.items():
            figures[key].append(value)
    return {'figures': {k: np.array(v) for k, v in figures.items()},
            'draws': len(figures['thermal_time_constant']), 'requested': len(samples)}
