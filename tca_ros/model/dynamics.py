"""TCA dynamics: thermal model (1) and the kinetostatic dynamics (18) of [1].

    m_t c_p dT/dt = -h c_s A_0 (T - T_inf) + P_in                        (1)
    m x'' + b_t x' + f_rod(x, T) = F_load                                 (18)

Eq. (18) is stepped with the central differences of Sec. V-B4,

    x'' ~ (x_{i+1} - 2 x_i + x_{i-1}) / dt^2,  x' ~ (x_{i+1} - x_{i-1}) / (2 dt),

explicit in f_rod, so each step needs one evaluation of f_rod. The scheme is
stable for dt < 2 / omega, omega = sqrt(k / m) (k = d f_rod / d x); a step beyond
0.9 of that limit is split into equal substeps automatically. A massless load
(m = 0) is quasi-static: the damped first-order equation b_t x' + f_rod = F is
stepped with backward Euler (unconditionally stable), or solved for equilibrium
when b_t = 0 too. Coil contact (Sec. V-D1) is a hard, inelastic stop. Coulomb
friction on the free end ('friction' in effects.py) holds the end while the
friction that keeps it at rest over a step is within the static force, and
otherwise acts against the motion with the kinetic force (time-stepping form).

The temperature (1) is updated exactly under zero-order-hold power while eq. (1)
is linear, and by classical Runge-Kutta when radiation or nonlinear convection
make it nonlinear (error below 1e-9 K per step for dt <= 10 ms, tau = 3 s).

f_rod is evaluated once per step, at (q_i, T_i), its moduli taken at the previous
step's tension (eq. (11) fixed point reached over steps).

State coordinate: q, the elongation (m) of the free end from the natural length
l*, positive when stretched; the displacement published is the contraction
x = q_ref - q from the loaded equilibrium at ambient (positive when shorter).

This module holds the stepper (``TcaSimulator``) and its central-difference
kernels; a whole sampled profile is run by ``simulate`` in simulation.py, which
also holds ``static_displacement``.
"""
import collections
from dataclasses import dataclass
import math

from tca_ros.model import effects as fx
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import contact_elongation, static_elongation
from tca_ros.model.limits import check_thread_strength
from tca_ros.model.resistance import resistance
from tca_ros.model.thermal import heat_capacity, surface_area, thermal_conductance

STABILITY_SAFETY = 0.9  # fraction of the central-difference limit 2/omega used per substep
MAX_SUBSTEPS = 1000  # beyond this, ask for the quasi-static mode instead
STABILITY_RECHECK = 100  # steps between re-evaluations of the stability limit (k drifts slowly)
RK4_REAL_LIMIT = 2.785  # h lambda on the negative real axis where classical RK4 turns unstable
THERMAL_CHECK_RISE = 300.0  # K above ambient at which the nonlinear thermal limit is also taken
EQUILIBRIUM_TOLERANCE = 0.05  # relative tension error beyond which a start state is refused


class StabilityError(ValueError):
    """The step is beyond the explicit stability limit by more than MAX_SUBSTEPS."""


@dataclass
class TcaState:
    """Simulator state after a step. SI units, temperatures in degC."""

    time: float = 0.0  # s
    temperature: float = 25.0  # degC, fiber temperature T
    actuation_temperature: float = 25.0  # degC, T seen by the untwist (hysteresis)
    fiber_temperature: float = 25.0  # degC, T behind the second thermal lag (effect)
    elongation: float = 0.0  # m, q of the free end from l* (includes creep)
    previous_elongation: float = 0.0  # m, q one step earlier
    velocity: float = 0.0  # m/s, dq/dt (stretching positive)
    creep: float = 0.0  # m, creep elongation y_c
    tension: float = 0.0  # N, f_rod
    displacement: float = 0.0  # m, true contraction from the reference
    measured_displacement: float = 0.0  # m, displacement seen by the (lagged) sensor
    resistance: float = 25.0  # ohm
    power: float = 0.0  # W, electrical power input
    load: float = 0.0  # N, external tensile force
    in_contact: bool = False
    stuck: bool = True  # the free end is held by static friction ('friction' effect)


def central_difference_step(q, q_prev, force, mass, damping, dt):
    """Return q_{i+1} (m) of m q'' + b q' = force (N), central differences [1, V-B4].

    ``force`` is the net force F_load - f_rod(q_i) (N) at step i.
    """
    a = mass / (dt * dt)
    c = damping / (2.0 * dt)
    return (force + a * (2.0 * q - q_prev) + c * q_prev) / (a + c)


def central_difference_acceleration(q, q_prev, force, mass, damping, h):
    """Return q'' (m/s^2) at step i of m q'' + b q' = force (N), q' = v_{i-1/2} + q'' h/2.

    ``q``, ``q_prev`` (m) are q_i and q_{i-1} at spacing ``h`` (s): their difference
    is the velocity half a step back, and the acceleration carries it to step i.
    """
    half_velocity = (q - q_prev) / h
    return (force - damping * half_velocity) / (mass + 0.5 * damping * h)


def rescaled_previous(q, q_prev, h_old, h_new, acceleration=0.0):
    """Return q_{i-1} (m) at spacing h_new (s) from q_i, q_{i-1} (m) at spacing h_old (s).

    The central difference keeps its velocity in q_i - q_{i-1}; when the substep
    changes, q_{i-1} moves to q(t_i - h_new), a Taylor expansion about t_i:

        v_i = (q_i - q_{i-1}) / h_old + a_i h_old / 2
        q(t_i - h_new) = q_i - h_new v_i + a_i h_new^2 / 2

    so the next step sees the same motion (no kick). ``acceleration`` a_i (m/s^2):
    zero keeps the half-step velocity (first order in h_new - h_old).
    """
    velocity = (q - q_prev) / h_old + 0.5 * acceleration * h_old
    return q - h_new * velocity + 0.5 * acceleration * h_new * h_new


def critical_damping(stiffness, mass):
    """Return the critical damping 2 sqrt(k m) (N s/m) of eq. (18) about an equilibrium.

    ``stiffness`` k = d f_rod / d y (N/m) there, ``mass`` m (kg); b_t above it
    gives no overshoot, b_t / k (s) is the mechanical lag behind the statics.
    """
    return 2.0 * math.sqrt(max(stiffness, 0.0) * max(mass, 0.0))


def central_difference_limit(stiffness, mass):
    """Return the stability limit 2 / omega (s) of the central-difference step."""
    if mass <= 0.0 or stiffness <= 0.0:
        return math.inf
    return 2.0 * math.sqrt(mass / stiffness)


class TcaSimulator:
    """Step a TCA: power and load in; temperature, displacement, resistance out.

    Parameters
    ----------
    params : TcaParams
        The TCA (config/*.yaml).
    model : str, optional
        Kinetostatic model rod | cst | love (default ``params.model``).
    dt : float
        Physics step (s), e.g. 1e-3 for 1 kHz.
    kinetostatics : KinetostaticModel, optional
        A prebuilt model (shares the rod table between simulators).
    """

    def __init__(self, params, model=None, dt=1e-3, kinetostatics=None):
        self.params = params
        self.dt = self._checked_dt(dt)
        self.kinetostatics = kinetostatics or make_kinetostatic_model(params, model)
        self._heat_capacity = heat_capacity(params.fiber)
        self._conductance = thermal_conductance(params.fiber, params.thermal)
        self._area = surface_area(params.fiber)
        self._ambient = fx.true_ambient(params.thermal, params.effects)
        self._contact = contact_elongation(params)
        self._linear_thermal = (params.effects.emissivity == 0.0
                                and params.effects.convection_exponent == 0.0)
        self._decay_step = None  # s, the substep self._decay (-) was computed for
        self._decay = None
        # W heating the fiber per W logged (heating_power is linear in P)
        self._heating_gain = fx.heating_power(1.0, params.effects,
                                              params.thermal.delivered_power_ratio)
        self._dead_time = params.effects.dead_time  # s
        self._sensor_lag = params.effects.sensor_lag != 0.0
        self._substeps = 1
        self._steps_since_check = 0
        self._step_length = None  # s, length of the last substep (q_{i-1} is that far back)
        self.state = TcaState()
        self.reference_elongation = 0.0
        self.loaded_length = 1.0
        self.reset()

    # -- set-up -------------------------------------------------------------------
    def reset(self, load=None, temperature=None):
        """Return to equilibrium at ``temperature`` (degC, default ambient) under load (N).

        The displacement reference is this loaded equilibrium at ambient.
        """
        p = self.params
        load = p.dynamics.load if load is None else float(load)
        temp = self._ambient if temperature is None else float(temperature)
        q = self.equilibrium(load, temp)
        self.reference_elongation = self.equilibrium(load, self._ambient)
        self.loaded_length = self.kinetostatics.natural_length + self.reference_elongation
        self._drive = collections.deque()  # (start time (s), power (W)) for the dead time
        self.state = TcaState(time=0.0, temperature=temp, actuation_temperature=temp,
                              fiber_temperature=temp,
                              elongation=q, previous_elongation=q, load=load)
        self.state.tension = self.kinetostatics.tension(q, temp)
        self._check_equilibrium(load, temp, q, self.state.tension)
        self._update_outputs(self.state, 0.0)
        self.state.measured_displacement = self.state.displacement
        self._step_length = None  # at rest: q_{i-1} = q_i holds for any step
        self._substeps = self.check_step()
        return self.state

    def _check_equilibrium(self, load, temp, elongation, tension):
        """Raise ValueError unless (elongation, tension) is a finite static state.

        A load the coil cannot hold (it straightens) or a model that is not finite
        there would otherwise surface as a division by zero in the first steps.
        """
        values = (elongation, tension, self.reference_elongation)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(
                f'dynamics.load = {load:g} N: no finite static equilibrium at {temp:g} degC '
                f'(elongation {elongation:g} m, tension {tension:g} N)')
        in_contact = elongation <= self._contact
        if not in_contact and abs(tension - load) > EQUILIBRIUM_TOLERANCE * max(load, 1e-3):
            raise ValueError(
                f'dynamics.load = {load:g} N: beyond the range of the coil at {temp:g} degC '
                f'(it straightens; the model holds {tension:.3g} N there)')

    def equilibrium(self, load, temperature):
        """Return the static elongation (m) under load (N) at temperature (degC).

        Coil contact (Sec. V-D1) bounds it from below.
        """
        return static_elongation(self.kinetostatics, load, temperature)

    @staticmethod
    def _checked_dt(dt):
        if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0.0):
            raise ValueError(f'dt = {dt!r}: must be a positive number of seconds')
        return float(dt)

    def set_dt(self, dt):
        """Change the physics step (s), keeping the state; re-plan the substeps.

        Raises StabilityError (and keeps the old step) when dt needs more than
        MAX_SUBSTEPS substeps.
        """
        old, self.dt = self.dt, self._checked_dt(dt)
        try:
            self._substeps = self.check_step()
        except StabilityError:
            self.dt = old
            raise
        self._steps_since_check = 0

    def stability_limit(self):
        """Return the central-difference stability limit 2/omega (s) at the state."""
        s = self.state
        k = self.kinetostatics.stiffness(max(s.elongation - s.creep, self._contact),
                                         s.actuation_temperature)
        return central_difference_limit(k, self.params.dynamics.mass)

    def thermal_limit(self):
        """Return the largest stable substep (s) of the RK4 thermal update (inf if exact).

        The linear eq. (1) is updated exactly. With radiation or nonlinear convection
        RK4 needs h lambda < 2.785, lambda = d(loss)/dT / (m c_p), taken at the state
        and THERMAL_CHECK_RISE above ambient (the temperature rises between re-checks).
        """
        if self._linear_thermal:
            return math.inf
        e = self.params.effects
        rate = 0.0
        for temp in (self.state.temperature, self._ambient + THERMAL_CHECK_RISE):
            convection = self._conductance * (1.0 + e.convection_exponent) \
                * fx.convection_factor(temp, self._ambient, e)
            radiation = 4.0 * e.emissivity * fx.STEFAN_BOLTZMANN * self._area * (
                abs(temp) + fx.KELVIN) ** 3
            rate = max(rate, (convection + radiation) / self._heat_capacity)
        return RK4_REAL_LIMIT / rate if rate > 0.0 else math.inf

    def _creep_limit(self):
        """Return the substep (s) below which explicit Euler creep decays monotonically.

        The creep element in series with the coil (stiffness k) relaxes at the rate
        (1 + C k) / tau_c, not 1 / tau_c: a compliant creep on a stiff coil is stiff.
        """
        e = self.params.effects
        if e.creep_compliance <= 0.0:
            return math.inf
        s = self.state
        k = self.kinetostatics.stiffness(max(s.elongation - s.creep, self._contact),
                                         s.actuation_temperature)
        return e.creep_time_constant / (1.0 + e.creep_compliance * max(k, 0.0))

    def substeps(self):
        """Return the number of equal substeps one step of dt needs to stay stable.

        MAX_SUBSTEPS + 1 when a limit is zero or not a number, or needs more.
        """
        limit = STABILITY_SAFETY * min(self.stability_limit(), self.thermal_limit(),
                                       self._creep_limit())
        if limit == math.inf:
            return 1
        if not limit > 0.0 or self.dt / limit > MAX_SUBSTEPS:  # also a NaN limit
            return MAX_SUBSTEPS + 1
        return max(1, math.ceil(self.dt / limit))

    def check_step(self):
        """Raise StabilityError when dt needs more than MAX_SUBSTEPS substeps."""
        n = self.substeps()
        if n > MAX_SUBSTEPS:
            mechanical = self.stability_limit()
            others = min(self.thermal_limit(), self._creep_limit())
            if not mechanical > others:
                raise StabilityError(
                    f'dynamics.mass = {self.params.dynamics.mass:g} kg: explicit limit '
                    f'2/omega = {mechanical:.3g} s needs more than {MAX_SUBSTEPS} substeps '
                    f'of dt = {self.dt:g} s; allowed at most {MAX_SUBSTEPS} '
                    '(use mass 0 for the quasi-static mode or a smaller dt)')
            raise StabilityError(
                f'thermal or creep limit {others:.3g} s needs more than {MAX_SUBSTEPS} '
                f'substeps of dt = {self.dt:g} s (check thermal.*, effects.emissivity, '
                'effects.convection_exponent, effects.creep_time_constant, or a smaller dt)')
        return n

    # -- stepping -----------------------------------------------------------------
    def step(self, power, load=None):
        """Advance one dt with power (W) and external tensile load (N); return state."""
        s = self.state
        load = s.load if load is None else float(load)
        self._steps_since_check += 1
        if self._steps_since_check >= STABILITY_RECHECK:
            self._steps_since_check = 0
            self._substeps = self.check_step()
        n = self._substeps
        h = self.dt / n
        for _ in range(n):
            self._substep(power, load, h)
        return s

    def _substep(self, power, load, h):
        p, s = self.params, self.state
        model = self.kinetostatics
        mass, damping = p.dynamics.mass, p.dynamics.damping
        q, y_c = s.elongation, s.creep
        # eq. (1) first; the explicit step below still uses f_rod(q_i, T_i) (s.tension),
        # the implicit quasi-static steps use T_{i+1}
        s.temperature = self._thermal_step(s.temperature, self._delayed(power, h), h)
        s.fiber_temperature = fx.second_lag_step(s.fiber_temperature, s.temperature, h,
                                                 p.effects)
        s.actuation_temperature = fx.play_operator(
            s.fiber_temperature, s.actuation_temperature, p.effects.hysteresis_width)
        if mass > 0.0 and self._step_length not in (None, h):
            self._rescale_previous(q, load, h)
        self._step_length = h
        if p.effects.friction_force > 0.0:
            q_next = self._friction_step(q, y_c, load, mass, damping, h)
        elif mass > 0.0:
            q_next = central_difference_step(q, s.previous_elongation, load - s.tension,
                                             mass, damping, h)
        elif damping > 0.0:
            q_next = self._backward_euler(q, y_c, load, s.actuation_temperature, damping, h)
        else:
            q_next = y_c + model.equilibrium_elongation(load, s.actuation_temperature,
                                                        guess=q - y_c)
        s.in_contact = q_next - y_c < self._contact
        if s.in_contact:
            q_next = y_c + self._contact
            q = q_next  # inelastic stop: the coils absorb the momentum
        s.previous_elongation = q
        s.elongation = q_next
        s.velocity = (q_next - q) / h
        if p.effects.creep_compliance > 0.0:
            s.creep = y_c + h * fx.creep_rate(y_c, s.tension, p.effects)
        s.time += h
        s.power, s.load = power, load
        s.tension = model.tension(s.elongation - s.creep, s.actuation_temperature, s.tension)
        check_thread_strength(s.tension, p.fiber, s.time)  # the thread breaks: end the run
        self._update_outputs(s, h)

    def _rescale_previous(self, q, load, h):
        """Move q_{i-1} to h (s) before q_i when the substep length changes.

        The acceleration from eq. (18) at step i makes the rescaling second order;
        with friction the holding force is not known here, so the half-step velocity
        is kept instead (first order).
        """
        s, d = self.state, self.params.dynamics
        old = self._step_length
        accel = 0.0
        if self.params.effects.friction_force == 0.0:
            accel = central_difference_acceleration(q, s.previous_elongation, load - s.tension,
                                                    d.mass, d.damping, old)
        s.previous_elongation = rescaled_previous(q, s.previous_elongation, old, h, accel)

    def _friction_step(self, q, y_c, load, mass, damping, h):
        """Return q_{i+1} (m) of eq. (18) with Coulomb friction on the free end.

        With mass, the central-difference step is linear in the friction force f,
        q_{i+1} = q_free + f / (m / h^2 + b / (2 h)): the force holding the end at
        q_i follows, and ``effects.coulomb_friction`` keeps it or slides against
        F_k. Massless, the holding force is f_rod(q_i, T_{i+1}) - F and a sliding
        end moves under F -+ F_k (backward Euler, or the band edge when b = 0: the
        play operator of effects.friction_play).
        """
        s, e = self.state, self.params.effects
        model = self.kinetostatics
        temp = s.actuation_temperature
        if mass > 0.0:
            q_free = central_difference_step(q, s.previous_elongation, load - s.tension,
                                             mass, damping, h)
            inverse = mass / (h * h) + 0.5 * damping / h  # d(force) / d(q_{i+1}), N/m
            force, s.stuck = fx.coulomb_friction(inverse * (q - q_free), s.stuck, e)
            return q if s.stuck else q_free + force / inverse
        holding = model.tension(max(q - y_c, self._contact), temp, s.tension) - load
        force, s.stuck = fx.coulomb_friction(holding, s.stuck, e)
        if s.stuck:
            return q
        if damping > 0.0:
            return self._backward_euler(q, y_c, load + force, temp, damping, h)
        return y_c + model.equilibrium_elongation(load + force, temp, guess=q - y_c)

    def _delayed(self, power, h):
        """Return the mean power (W) over [t - d, t - d + h]: the drive's dead time d (s).

        The commanded power is held over each step; before the first command it is
        zero. Averaging over the delayed interval keeps the heat delivered and
        makes the result continuous in d (a fit can move d by less than a step).
        """
        delay = self._dead_time
        if delay <= 0.0:
            return power
        now = self.state.time
        self._drive.append((now, power))
        start, end = now - delay, now - delay + h
        # drop segments that ended before the interval (a segment ends where the next starts)
        while len(self._drive) > 1 and self._drive[1][0] <= start:
            self._drive.popleft()
        energy = 0.0
        for i, (t0, p) in enumerate(self._drive):
            t1 = self._drive[i + 1][0] if i + 1 < len(self._drive) else math.inf
            overlap = min(t1, end) - max(t0, start)
            if overlap > 0.0:
                energy += p * overlap
            if t1 >= end:
                break
        return energy / h

    def _backward_euler(self, q, y_c, load, temp, damping, h):
        """Return q_{i+1} of b (q_{i+1} - q_i)/h + f_rod(q_{i+1}) = F (Newton)."""
        model = self.kinetostatics
        y = q - y_c
        for _ in range(20):
            residual = damping * (y + y_c - q) / h + model.tension(y, temp) - load
            slope = damping / h + model.stiffness(max(y, self._contact), temp)
            if not slope > 0.0:  # f_rod softening faster than b/h: keep the last iterate
                break
            step = residual / slope
            y -= step
            if abs(step) < 1e-12:
                break
        return y + y_c

    def _thermal_rate(self, temp, power):
        """Return dT/dt (K/s) of eq. (1) with the thermal effects."""
        e = self.params.effects
        ambient = self._ambient
        loss = self._conductance * (temp - ambient) * fx.convection_factor(temp, ambient, e)
        loss += fx.radiation_loss(temp, ambient, self._area, e)
        heating = fx.heating_power(power, e, self.params.thermal.delivered_power_ratio)
        return (heating - loss) / self._heat_capacity

    def _thermal_step(self, temp, power, h):
        """Return T after h (s), power held constant: exact if linear, else RK4."""
        if self._linear_thermal:
            target = self._ambient + self._heating_gain * power / self._conductance
            if h != self._decay_step:  # exp(-h G / C) is kept while h is (G, C are fixed)
                self._decay_step = h
                self._decay = math.exp(-h * self._conductance / self._heat_capacity)
            return target + (temp - target) * self._decay
        k1 = self._thermal_rate(temp, power)
        k2 = self._thermal_rate(temp + 0.5 * h * k1, power)
        k3 = self._thermal_rate(temp + 0.5 * h * k2, power)
        k4 = self._thermal_rate(temp + h * k3, power)
        return temp + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0

    def _update_outputs(self, s, h):
        p = self.params
        s.displacement = self.reference_elongation - s.elongation
        if self._sensor_lag:
            s.measured_displacement = fx.lag_filter(s.measured_displacement, s.displacement,
                                                    h, p.effects)
        else:  # lag_filter without the lag
            s.measured_displacement = s.displacement
        s.resistance = resistance(s.temperature, s.displacement, self.loaded_length,
                                  p.electrical, p.thermal.ambient_temperature)
