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

This module holds the stepper (``TcaSimulator``). The equations it steps are
written once, for every stepper: eq. (1) and the lags in thermal.py (stepped, under
the drive's dead time, by thermal_step.py's ThermalStepper), eq. (18), its schemes (central
differences, backward Euler, friction) and the contact stop in end_motion.py;
its substeps are planned by substeps.py.
A whole sampled profile is run by ``simulate`` in simulation.py, which also holds
``static_displacement``.
"""
from dataclasses import dataclass
import math

from tca_ros.model import effects as fx
from tca_ros.model.end_motion import central_difference_step, contact_stop, creep_step
from tca_ros.model.end_motion import EndMotion
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import contact_elongation, static_elongation
from tca_ros.model.limits import check_thread_strength
from tca_ros.model.resistance import resistance
from tca_ros.model.substeps import central_difference_limit, creep_limit, MAX_SUBSTEPS
from tca_ros.model.substeps import stability_error, StabilityError, substep_count, SubstepPlan
from tca_ros.model.thermal import lag_step
from tca_ros.model.thermal_step import ThermalStepper

EQUILIBRIUM_TOLERANCE = 0.05  # relative tension error beyond which a start state is refused


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


def checked_dt(dt):
    """Return the physics step dt (s) as a float; ValueError unless positive and finite."""
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0.0):
        raise ValueError(f'dt = {dt!r}: must be a positive number of seconds')
    return float(dt)


def check_start_state(load, temp, elongation, tension, reference, contact, held=None):
    """Raise ValueError unless (elongation, tension) is a finite static state.

    ``load`` (N) at ``temp`` (degC); ``elongation``, the ``reference`` elongation
    at ambient and the ``contact`` elongation in m, ``tension`` f_rod (N) there.
    ``held`` (N, default ``load``): the rod tension at the start, the load plus the
    friction that holds the end (effects.friction_start_load).
    A load the coil cannot hold (it straightens) or a model that is not finite
    there would otherwise surface as a division by zero in the first steps.
    """
    held = load if held is None else held
    where = '' if held == load else f' (the rod held under {held:.4g} N by friction)'
    values = (elongation, tension, reference)
    if not all(math.isfinite(v) for v in values):
        raise ValueError(
            f'dynamics.load = {load:g} N{where}: no finite static equilibrium at {temp:g} '
            f'degC (elongation {elongation:g} m, tension {tension:g} N)')
    in_contact = elongation <= contact
    if not in_contact and abs(tension - held) > EQUILIBRIUM_TOLERANCE * max(held, 1e-3):
        raise ValueError(
            f'dynamics.load = {load:g} N{where}: beyond the range of the coil at {temp:g} '
            f'degC (it straightens; the model holds {tension:.3g} N there)')


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
        self.dt = checked_dt(dt)
        self.kinetostatics = kinetostatics or make_kinetostatic_model(params, model)
        self._heat = ThermalStepper(params)  # eq. (1), the drive's dead time, T_f and T_a
        self._contact = contact_elongation(params)
        self._motion = EndMotion(self.kinetostatics, self._contact, params)
        self._sensor_lag = params.effects.sensor_lag != 0.0
        self.plan = SubstepPlan(self.check_step)  # substeps per step, re-planned
        self._step_length = None  # s, length of the last substep (q_{i-1} is that far back)
        self.state = TcaState()
        self.reference_elongation = 0.0
        self.loaded_length = 1.0
        self.reset()

    # -- set-up -------------------------------------------------------------------
    def reset(self, load=None, temperature=None):
        """Return to equilibrium at ``temperature`` (degC) under load (N).

        The default temperature is ambient plus ``thermal.initial_temperature_rise``
        (K; 0: at rest). The displacement reference is the loaded equilibrium at
        ambient, so a warm start reads the contraction of its excess; with
        friction both are taken under F + s F_s (effects.friction_start_load).
        """
        p = self.params
        load = p.dynamics.load if load is None else float(load)
        ambient = self._heat.ambient
        temp = (ambient + p.thermal.initial_temperature_rise if temperature is None
                else float(temperature))
        # with friction the end may start held at an edge of its band (effects.py)
        start_load = fx.friction_start_load(p.effects)
        held = load + start_load
        if start_load != 0.0 and not held <= p.fiber.break_force:
            raise ValueError(
                f'effects.friction_start = {p.effects.friction_start:g}: the rod would start '
                f'under {held:.4g} N (load {load:g} N + s F_s {start_load:.4g} N), beyond '
                f'fiber.break_force {p.fiber.break_force:g} N; allowed: a start the thread holds')
        q = self.equilibrium(held, temp)
        self.reference_elongation = self.equilibrium(held, ambient)
        self.loaded_length = self.kinetostatics.natural_length + self.reference_elongation
        self._heat.reset()
        self.state = TcaState(time=0.0, temperature=temp, actuation_temperature=temp,
                              fiber_temperature=temp,
                              elongation=q, previous_elongation=q, load=load)
        self.state.tension = self.kinetostatics.tension(q, temp)
        check_start_state(load, temp, q, self.state.tension, self.reference_elongation,
                          self._contact, held)
        self._update_outputs(self.state, 0.0)
        self.state.measured_displacement = self.state.displacement
        self._step_length = None  # at rest: q_{i-1} = q_i holds for any step
        self.plan.replan(restart=False)
        return self.state

    def equilibrium(self, load, temperature):
        """Return the static elongation (m) under load (N) at temperature (degC).

        Coil contact (Sec. V-D1) bounds it from below.
        """
        return static_elongation(self.kinetostatics, load, temperature)

    def set_dt(self, dt):
        """Change the physics step (s), keeping the state; re-plan the substeps.

        Raises StabilityError (and keeps the old step) when dt needs more than
        MAX_SUBSTEPS substeps.
        """
        old, self.dt = self.dt, checked_dt(dt)
        try:
            self.plan.replan()
        except StabilityError:
            self.dt = old
            raise

    def _stiffness(self):
        """Return the coil's k = d f_rod / d q (N/m) at the state (contact bounds q)."""
        s = self.state
        return self.kinetostatics.stiffness(max(s.elongation - s.creep, self._contact),
                                            s.actuation_temperature)

    def stability_limit(self):
        """Return the central-difference stability limit 2/omega (s) at the state."""
        return central_difference_limit(self._stiffness(), self.params.dynamics.mass)

    def thermal_limit(self):
        """Return the largest stable substep (s) of the RK4 thermal update (inf if exact).

        See ``ThermalStepper.limit``; taken at the state's temperature.
        """
        return self._heat.limit(self.state.temperature)

    def _creep_limit(self):
        """Return the creep's explicit-Euler limit (s) at the state (``creep_limit``)."""
        e = self.params.effects
        return math.inf if e.creep_compliance <= 0.0 else creep_limit(self._stiffness(), e)

    def substeps(self):
        """Return the number of equal substeps one step of dt needs to stay stable.

        MAX_SUBSTEPS + 1 when a limit is zero or not a number, or needs more.
        """
        return substep_count(self.dt, min(self.stability_limit(), self.thermal_limit(),
                                          self._creep_limit()))

    def check_step(self):
        """Raise StabilityError when dt needs more than MAX_SUBSTEPS substeps."""
        n = self.substeps()
        if n > MAX_SUBSTEPS:
            raise stability_error(self.params.dynamics.mass, self.stability_limit(),
                                  min(self.thermal_limit(), self._creep_limit()), self.dt)
        return n

    # -- stepping -----------------------------------------------------------------
    def step(self, power, load=None):
        """Advance one dt with power (W) and external tensile load (N); return state."""
        s = self.state
        load = s.load if load is None else float(load)
        n = self.plan.next_step()
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
        self._heat.advance(s, power, h)
        if mass > 0.0 and self._step_length not in (None, h):
            self._motion.rescale_previous(s, q, load, self._step_length, h)
        self._step_length = h
        if p.effects.friction_force > 0.0:
            q_next = self._motion.friction_step(s, q, y_c, load, mass, damping, h)
        elif mass > 0.0:
            q_next = central_difference_step(q, s.previous_elongation, load - s.tension,
                                             mass, damping, h)
        elif damping > 0.0:
            q_next = self._motion.backward_euler(q, y_c, load, s.actuation_temperature,
                                                 damping, h)
        else:
            q_next = y_c + model.equilibrium_elongation(load, s.actuation_temperature,
                                                        guess=q - y_c)
        q_next, q, s.in_contact = contact_stop(q_next, q, y_c, self._contact)
        s.previous_elongation = q
        s.elongation = q_next
        s.velocity = (q_next - q) / h
        if p.effects.creep_compliance > 0.0:
            s.creep = creep_step(y_c, s.tension, h, p.effects)
        s.time += h
        s.power, s.load = power, load
        s.tension = model.tension(s.elongation - s.creep, s.actuation_temperature, s.tension)
        check_thread_strength(s.tension, p.fiber, s.time)  # the thread breaks: end the run
        self._update_outputs(s, h)

    def _update_outputs(self, s, h):
        p = self.params
        s.displacement = self.reference_elongation - s.elongation
        if self._sensor_lag:
            s.measured_displacement = lag_step(s.measured_displacement, s.displacement, h,
                                               p.effects.sensor_lag)
        else:  # the lag off
            s.measured_displacement = s.displacement
        s.resistance = resistance(s.temperature, s.displacement, self.loaded_length,
                                  p.electrical, p.thermal.ambient_temperature)
