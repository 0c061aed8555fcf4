"""Step N TCAs at once with NumPy: eqs. (1) and (18) as TcaSimulator steps them.

Each muscle may have its own parameters. One physics step calls the equations
TcaSimulator calls, written once for floats and arrays (eq. (1) and the lags in
model/thermal.py, eq. (18) and the contact stop in model/end_motion.py, the
substeps planned by model/substeps.py); without effects it is

    T_{i+1} = T_ss + (T_i - T_ss) exp(-h / tau),  T_ss = T_inf + P_in / (h c_s A_0)   (1)
    m (q_{i+1} - 2 q_i + q_{i-1}) / h^2 + b (q_{i+1} - q_{i-1}) / (2 h)
        = F - f_rod(q_i, T_i)                                                      (18)

with the coil-contact stop, f_rod re-evaluated once per step with the moduli
at the previous tension (eq. (11)), and outputs x = q_ref - q, R(T, x). f_rod is
CST (29) or the rod model's table (batch_forces). Supported effects: the linear
thermal ones (ambient offset, power loss), the second thermal lag, the sensor
lag and modulus softening; the others (creep, hysteresis, friction, dead time,
radiation, nonlinear convection) and a massless end raise ValueError: use
TcaSimulator for those. All muscles share the substep h = dt / n, n the largest
any muscle needs for the central-difference limit (as TcaSimulator plans it,
re-planned every STABILITY_RECHECK steps).
"""
from dataclasses import dataclass
import math

import numpy as np

from tca_ros.model.end_motion import central_difference_step, contact_stop
from tca_ros.model.kinetostatics import contact_elongation
from tca_ros.model.resistance import resistance
from tca_ros.model.rod_model import helix_elongation
from tca_ros.model.substeps import central_difference_limit, MAX_SUBSTEPS, StabilityError
from tca_ros.model.substeps import substep_count, SubstepPlan
from tca_ros.model.thermal import heat_decay, heat_step_exact, HeatBalance, lag_step
from tca_ros.toolkit.batch_forces import cst_tension, MuscleArrays, RodTables

BATCH_MODELS = ('cst', 'rod')
UNSUPPORTED = (('creep_compliance', 'creep'), ('hysteresis_width', 'hysteresis'),
               ('friction_force', 'friction'), ('dead_time', 'dead_time'),
               ('emissivity', 'radiation'), ('convection_exponent', 'nonlinear_convection'))
EQUILIBRIUM_ITERATIONS = 60  # secant steps of the start equilibrium (converges in < 10)
STIFFNESS_STEP = 1e-7  # m, central difference of f_rod for the stability limit


def _checked(params_list, model):
    if model not in BATCH_MODELS:
        raise ValueError(f'model = {model!r}: the batch simulator steps cst or rod')
    for k, p in enumerate(params_list):
        for name, effect in UNSUPPORTED:
            if getattr(p.effects, name) > 0.0:
                raise ValueError(f'muscle {k}: effects.{name} = {getattr(p.effects, name):g} '
                                 f"('{effect}'): not in the batch simulator; use TcaSimulator")
        if p.dynamics.mass <= 0.0:
            raise ValueError(f'muscle {k}: dynamics.mass = {p.dynamics.mass:g} kg: the batch '
                             'simulator steps eq. (18) with mass; use TcaSimulator')
        if model == 'rod' and p.coil.shape != 'helix':
            raise ValueError(f'muscle {k}: coil.shape = {p.coil.shape!r}: the rod model needs '
                             'a helix')


@dataclass(frozen=True)
class ElectricalArrays:
    """The resistance law's parameters (model/resistance.py), arrays (N,)."""

    resistance: np.ndarray  # ohm, R0
    temperature_coefficient: np.ndarray  # 1/K, beta_T
    strain_coefficient: np.ndarray  # -, beta_x


@dataclass
class BatchState:
    """State of N muscles, arrays of shape (N,); SI units, temperatures in degC."""

    time: float
    temperature: np.ndarray  # degC, T of eq. (1)
    fiber_temperature: np.ndarray  # degC, T_f behind the second lag (T without it)
    elongation: np.ndarray  # m, q from l*
    previous_elongation: np.ndarray  # m
    velocity: np.ndarray  # m/s, dq/dt (stretching positive)
    tension: np.ndarray  # N, f_rod
    displacement: np.ndarray  # m, contraction from the loaded equilibrium at ambient
    measured_displacement: np.ndarray  # m, behind the sensor lag
    resistance: np.ndarray  # ohm
    load: np.ndarray  # N


class BatchSimulator:
    """Step N TCAs (one TcaParams each, or one for all) by dt (s) per call.

    Parameters
    ----------
    params : TcaParams or sequence of TcaParams
        One per muscle, or one shared by ``n`` muscles.
    n : int, optional
        Number of muscles when ``params`` is a single TcaParams.
    model : str
        'cst' or 'rod'.
    dt : float
        Physics step (s).
    """

    def __init__(self, params, n=None, model='cst', dt=1e-3):
        plist = [params] * int(n or 1) if not isinstance(params, (list, tuple)) \
            else list(params)
        if not plist:
            raise ValueError('params: need at least one muscle')
        _checked(plist, model)
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt = {dt!r}: must be a positive number of seconds')
        self.params_list, self.model, self.dt = plist, model, float(dt)
        self.n = len(plist)
        self.c = MuscleArrays(plist)
        self._rod = RodTables(plist) if model == 'rod' else None

        def gather(getter):
            return np.array([float(getter(p)) for p in plist])
        self.mass = gather(lambda p: p.dynamics.mass)  # kg
        self.damping = gather(lambda p: p.dynamics.damping)  # N s/m
        self.heat = HeatBalance.gather(plist)  # eq. (1)'s coefficients, (N,) each
        self.contact = gather(contact_elongation)  # m (-inf: none)
        self.second_lag = gather(lambda p: p.effects.second_thermal_lag)  # s
        self.sensor_lag = gather(lambda p: p.effects.sensor_lag)  # s
        # R0 (ohm), beta_T (1/K), beta_x (-) of model/resistance.py, (N,) each
        self.electrical = ElectricalArrays(
            gather(lambda p: p.electrical.resistance),
            gather(lambda p: p.electrical.temperature_coefficient),
            gather(lambda p: p.electrical.strain_coefficient))
        self.default_load = gather(lambda p: p.dynamics.load)  # N
        self.plan = SubstepPlan(self.check_step)  # substeps per step, re-planned
        self.reset()

    # -- f_rod -------------------------------------------------------------------------
    def tension(self, elongation, temp, previous):
        """Return f_rod (N) per muscle; CST takes its moduli at ``previous`` (N)."""
        if self._rod is not None:
            return self._rod.evaluate(elongation, temp)[0]
        return cst_tension(elongation, temp, previous, self.c)

    def stiffness(self, elongation, temp, tension):
        """Return d f_rod / d y (N/m) per muscle (moduli held at ``tension``)."""
        if self._rod is not None:
            return self._rod.evaluate(elongation, temp)[1]
        h = STIFFNESS_STEP
        return (cst_tension(elongation + h, temp, tension, self.c)
                - cst_tension(elongation - h, temp, tension, self.c)) / (2.0 * h)

    def equilibrium(self, load, temp):
        """Return the static elongation (m) under load (N) at T (degC), contact applied.

        As TcaSimulator.equilibrium: the rod model's exact helix; CST solved by the
        secant method with the moduli at F = load (at rest the tension is the load).
        """
        load = np.broadcast_to(np.asarray(load, dtype=float), (self.n,))
        temp = np.broadcast_to(np.asarray(temp, dtype=float), (self.n,))
        if self.model == 'rod':
            y = self._rod_equilibrium(load, temp)
        else:
            y = self._cst_equilibrium(load, temp)
        return np.maximum(y, self.contact)

    def _rod_equilibrium(self, load, temp):
        """Exact helices, solved together for muscles of one table and temperature."""
        groups = {}
        for k, (owner, t) in enumerate(zip(self._rod.owner, temp)):
            groups.setdefault((int(owner), float(t)), []).append(k)
        y = np.empty(self.n)
        for (_, t), members in groups.items():
            members = np.array(members)
            y[members] = helix_elongation(self.params_list[members[0]], t, load[members])
        return y

    def _cst_equilibrium(self, load, temp):
        y0 = np.zeros(self.n)
        g0 = cst_tension(y0, temp, load, self.c) - load
        y1 = y0 + 1e-6 * self.c.fiber_length
        for _ in range(EQUILIBRIUM_ITERATIONS):
            g1 = cst_tension(y1, temp, load, self.c) - load
            moving = (np.abs(y1 - y0) >= 1e-13) & (g1 != g0)
            if not moving.any():
                break
            step = np.where(moving, g1 * (y1 - y0) / np.where(moving, g1 - g0, 1.0), 0.0)
            y0, g0, y1 = y1, g1, y1 - step
        if not np.all(np.isfinite(y1)):
            bad = int(np.flatnonzero(~np.isfinite(y1))[0])
            raise ValueError(f'muscle {bad}: no static equilibrium under {load[bad]:g} N')
        return y1

    # -- set-up ------------------------------------------------------------------------
    def reset(self, load=None):
        """Return every muscle to its loaded equilibrium at ambient under load (N)."""
        load = self.default_load if load is None else np.broadcast_to(
            np.asarray(load, dtype=float), (self.n,)).copy()
        temp = self.heat.ambient.copy()
        q = self.equilibrium(load, temp)
        self.reference_elongation = q.copy()
        self.loaded_length = self.c.natural_length + q
        tension = self.tension(q, temp, load)
        zero = np.zeros(self.n)
        self.state = BatchState(time=0.0, temperature=temp, fiber_temperature=temp.copy(),
                                elongation=q, previous_elongation=q.copy(), velocity=zero,
                                tension=tension, displacement=zero.copy(),
                                measured_displacement=zero.copy(),
                                resistance=self._resistance(temp, zero), load=load)
        self.plan.replan()
        return self.state

    def check_step(self):
        """Return the substeps per dt the stiffest muscle needs (2/omega limit, eq. (18))."""
        s = self.state
        k = self.stiffness(np.maximum(s.elongation, self.contact), s.fiber_temperature,
                           s.tension)
        n = substep_count(self.dt, central_difference_limit(k, self.mass))
        if n > MAX_SUBSTEPS:
            raise StabilityError(f'dt = {self.dt:g} s needs more than {MAX_SUBSTEPS} substeps '
                                 'for the stiffest muscle; use a smaller dt')
        return n

    def _resistance(self, temp, contraction):
        """Return R (ohm) per muscle, the law of model/resistance.py (D10)."""
        return resistance(temp, contraction, self.loaded_length, self.electrical,
                          self.c.ambient)

    # -- stepping ----------------------------------------------------------------------
    def step(self, power, load=None):
        """Advance every muscle by dt under power (W) and load (N), each (N,) or scalar."""
        s = self.state
        power = np.broadcast_to(np.asarray(power, dtype=float), (self.n,))
        if load is not None:
            s.load = np.broadcast_to(np.asarray(load, dtype=float), (self.n,)).copy()
        n = self.plan.next_step()
        h = self.dt / n
        for _ in range(n):
            self._substep(power, h)
        return s

    def step_voltage(self, voltage, load=None, max_power=math.inf):
        """Advance by dt under a voltage (V): P = V^2 / R(T, x) per substep, clamped."""
        voltage = np.broadcast_to(np.asarray(voltage, dtype=float), (self.n,))
        r = self.state.resistance
        power = np.where(r > 0.0, voltage * voltage / np.where(r > 0.0, r, 1.0), 0.0)
        return self.step(np.minimum(power, max_power), load)

    def _substep(self, power, h):
        s = self.state
        s.temperature = heat_step_exact(s.temperature, power, heat_decay(h, self.heat),
                                        self.heat)  # Eq. (1), exact under held power
        s.fiber_temperature = lag_step(s.fiber_temperature, s.temperature, h, self.second_lag)
        q = s.elongation
        q_next = central_difference_step(q, s.previous_elongation, s.load - s.tension,
                                         self.mass, self.damping, h)  # Eq. (18)
        q_next, q, _ = contact_stop(q_next, q, 0.0, self.contact)  # inelastic stop
        s.previous_elongation = q
        s.elongation = q_next
        s.velocity = (q_next - q) / h
        s.time += h
        s.tension = self.tension(q_next, s.fiber_temperature, s.tension)
        s.displacement = self.reference_elongation - q_next
        s.measured_displacement = lag_step(s.measured_displacement, s.displacement, h,
                                           self.sensor_lag)
        s.resistance = self._resistance(s.temperature, s.displacement)


def simulate_batch(params, time, power, load=None, model='cst', physics_rate=1000.0, n=None):
    """Simulate N muscles over ``time`` (s); return dict of (N, n_samples) arrays.

    ``power`` (W) and ``load`` (N) are (n_samples,) or (N, n_samples), held over
    each interval (zero-order hold) as in simulation.simulate; physics at
    ``physics_rate`` (Hz) on a uniform ``time`` grid. Keys: displacement (m, as
    the sensor reads it), temperature (degC), resistance (ohm), tension (N).
    """
    time = np.asarray(time, dtype=float)
    span = np.diff(time)
    if time.ndim != 1 or time.size < 2 or np.ptp(span) > 1e-9 * span.mean() or span[0] <= 0:
        raise ValueError('time: need a uniform, increasing grid of at least 2 samples')
    steps = max(1, int(round(span[0] * physics_rate)))
    sim = BatchSimulator(params, n=n, model=model, dt=span[0] / steps)
    power = np.broadcast_to(np.asarray(power, dtype=float), (sim.n, time.size))
    load_in = None if load is None else np.broadcast_to(np.asarray(load, dtype=float),
                                                        (sim.n, time.size))
    state = sim.reset(None if load_in is None else load_in[:, 0])
    keys = ('measured_displacement', 'temperature', 'resistance', 'tension')
    out = {k: np.empty((sim.n, time.size)) for k in keys}
    for k in keys:
        out[k][:, 0] = getattr(state, k)
    for i in range(1, time.size):
        for _ in range(steps):
            state = sim.step(power[:, i - 1], None if load_in is None else load_in[:, i - 1])
        for k in keys:
            out[k][:, i] = getattr(state, k)
    out['displacement'] = out.pop('measured_displacement')
    return out
