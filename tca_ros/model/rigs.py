"""Load rigs of the free end: dead weight, series spring, isometric, antagonistic pair.

The dynamics (18) of [1] loads the TCA with a dead weight. A controller meets other
rigs; each is written here as the equations that replace the right-hand side of
(18), with q the elongation (m) of the free end from l* (stretching positive),
f_rod(q, T) the kinetostatic force (N) and b_t the TCA's damping (N s/m).
Parameters ``rig.*`` (tca_params.py); derivations and checks: docs/rigs.md.

dead_weight (eq. (18) as printed; ``dynamics.load`` or the load input F_w)::

    m q'' + b_t q' + f_rod(q, T) = F_w                                  (R1)

spring (Case 2 of [1], Fig. 11: a spring of stiffness k_s in series, anchored so
that it pulls with the pretension F_0 while the TCA is at its reference q_0, the
equilibrium under F_0 at ambient)::

    F_s(q) = F_0 + k_s (q_0 - q)                                        (R2)
    m q'' + b_t q' + f_rod(q, T) = F_s(q)                               (R3)

i.e. (18) with the model f_rod(q, T) + k_s (q - q_0) under the constant load F_0,
so the central differences, the quasi-static modes, friction and coil contact
apply unchanged. At rest f_rod = F_s: the muscle's force curve meets the spring
line. The load input is F_0 (the anchor's force at q_0); the output is the TCA
tension f_rod, which a force gauge in series reads.

isometric (the free end clamped at q_0, the length under the pretension F_0 at
ambient)::

    q = q_0,    F = f_rod(q_0 - y_c, T)                                 (R4)

with y_c the creep elongation (effect 'creep': stress relaxation). The output is
the force F (N); eq. (1) and the thermal effects run as in (18).

antagonistic (two identical TCAs on a pulley of radius r_p; the agonist (1)
turns the joint to positive theta, the antagonist (2) back; both at q_0 when
theta = 0)::

    q_1 = q_0 - r_p theta,    q_2 = q_0 + r_p theta                     (R5)
    F_i = max(f_rod(q_i - y_c,i, T_i), 0)   (a tendon only pulls)       (R6)
    J theta'' + (c + 2 r_p^2 b_t) theta' = r_p (F_1 - F_2)              (R7)

stepped with the central differences of (18) on theta; stable for h < 2 / omega,
omega^2 = r_p^2 (k_1 + k_2) / J, k_i = df_rod/dq. A coil that reaches contact
(Sec. V-D1) stops the joint (inelastic). At rest F_1 = F_2: the angle where the
two muscles' statics balance.

References
----------
[1] J. Sun and J. Zhao, IEEE Trans. Robot., 2022, Eqs. (1), (18), Sec. V-D3.
"""
import math

import numpy as np

from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.end_motion import central_difference_step, creep_step
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import KinetostaticModel
from tca_ros.model.kinetostatics import static_elongation
from tca_ros.model.params_schema import ParameterError, RIG_MODES
from tca_ros.model.substeps import central_difference_limit, MAX_SUBSTEPS
from tca_ros.model.substeps import StabilityError, substep_count, SubstepPlan

DEAD_WEIGHT, SPRING, ISOMETRIC, ANTAGONISTIC = RIG_MODES


def check_rig(params):
    """Raise ParameterError (one line) for a rig this TCA cannot be put on."""
    mode = params.rig.mode
    if mode == SPRING and params.effects.creep_compliance > 0.0:
        raise ParameterError(
            f"parameter 'effects.creep_compliance' = {params.effects.creep_compliance:g}: "
            "must be 0 with rig.mode spring (the spring would see the coil's elongation "
            'without the creep in series)')


def start_load(params):
    """Return the load input (N) a rig starts with: F_w (dead weight), F_0 (spring), else 0."""
    if params.rig.mode == DEAD_WEIGHT:
        return params.dynamics.load
    if params.rig.mode == SPRING:
        return params.rig.pretension
    return 0.0


def reference_elongation(model, pretension):
    """Return q_0 (m): the static elongation under the pretension (N) at ambient."""
    return static_elongation(model, pretension, model.ambient)


def spring_force(elongation, reference, pretension, stiffness):
    """Return F_s = F_0 + k_s (q_0 - q) (N), Eq. (R2): the series spring's pull."""
    return pretension + stiffness * (reference - elongation)


def tendon_force(tension):
    """Return max(f_rod, 0) (N), Eq. (R6): a tendon only pulls (NaN kept); float or array."""
    if isinstance(tension, np.ndarray):
        return np.where(0.0 > tension, 0.0, tension)
    return 0.0 if 0.0 > tension else tension


class SeriesSpringModel(KinetostaticModel):
    """f_rod(q, T) + k_s (q - q_0): a TCA and its series spring as one model, Eq. (R3).

    Under the constant load F_0 (N) the dynamics (18) of this model is the spring
    rig. ``muscle_tension`` recovers the TCA's own force f_rod.

    Parameters
    ----------
    muscle : KinetostaticModel
        The TCA's model (rod, cst or love).
    stiffness : float
        k_s (N/m).
    pretension : float
        F_0 (N); q_0 is the muscle's equilibrium under it at ambient.
    """

    def __init__(self, muscle, stiffness, pretension):
        super().__init__(muscle.params)
        self.name = muscle.name
        self.muscle = muscle
        self.spring_stiffness = float(stiffness)
        self.reference = reference_elongation(muscle, pretension)

    def tension(self, elongation, temperature, force_guess=None):
        """Return f_rod + k_s (q - q_0) (N) at elongation (m) and temperature (degC)."""
        offset = self.spring_stiffness * (elongation - self.reference)
        guess = None if force_guess is None else force_guess - offset
        return self.muscle.tension(elongation, temperature, guess) + offset

    def stiffness(self, elongation, temperature):
        """Return d f_rod / dq + k_s (N/m)."""
        return self.muscle.stiffness(elongation, temperature) + self.spring_stiffness

    def muscle_tension(self, combined, elongation):
        """Return f_rod (N) from the combined force (N) at elongation q (m)."""
        return combined - self.spring_stiffness * (elongation - self.reference)


class SpringLoadedMuscle(TcaSimulator):
    """The spring rig, Eqs. (R2)-(R3): a TcaSimulator of the SeriesSpringModel.

    The load input of ``step`` and ``reset`` is F_0 (N, default rig.pretension);
    ``outputs()['force']`` is the TCA tension f_rod (N).
    """

    def __init__(self, params, model=None, dt=1e-3, kinetostatics=None):
        check_rig(params)
        muscle = kinetostatics or make_kinetostatic_model(params, model)
        self.spring = SeriesSpringModel(muscle, params.rig.spring_stiffness,
                                        params.rig.pretension)
        super().__init__(params, dt=dt, kinetostatics=self.spring)

    def reset(self, load=None, temperature=None):
        """Return to equilibrium at temperature (degC) with the spring at F_0 = load (N)."""
        load = self.params.rig.pretension if load is None else load
        return super().reset(load=load, temperature=temperature)

    def outputs(self):
        """Return {'force': f_rod (N)}: the TCA tension a gauge in series reads."""
        s = self.state
        return {'force': self.spring.muscle_tension(s.tension, s.elongation - s.creep)}


class HeldMuscle(TcaSimulator):
    """A TCA whose free end a rig holds at a prescribed elongation, Eq. (R4).

    Eq. (1) and the thermal effects advance as in ``TcaSimulator``; instead of
    (18) the elongation is set by the rig (``hold``) and the tension follows from
    f_rod. Alone it is the isometric rig: held at q_0, the elongation under
    rig.pretension at ambient. No free mass, so no mechanical stability limit.
    Friction on the free end does not act (the end is clamped).
    """

    def __init__(self, params, model=None, dt=1e-3, kinetostatics=None):
        self._creeps = params.effects.creep_compliance > 0.0  # off at its default
        super().__init__(params, model=model, dt=dt, kinetostatics=kinetostatics)

    def stability_limit(self):
        """Return inf (s): the rig, not a free mass, moves the end."""
        return math.inf

    def reset(self, load=None, temperature=None, elongation=None):
        """Hold the end at elongation (m, default q_0) at temperature (degC, default ambient).

        ``load`` is not used (the clamp sets the length). The displacement and the
        resistance are referred to q_0.
        """
        super().reset(load=self.params.rig.pretension)
        s = self.state
        q = s.elongation if elongation is None else float(elongation)
        self.hold_elongation = q
        if temperature is not None:
            s.temperature = s.actuation_temperature = s.fiber_temperature = float(temperature)
        s.elongation = s.previous_elongation = q
        s.tension = self.kinetostatics.tension(max(q, self._contact), s.actuation_temperature)
        s.load = s.tension
        self._update_outputs(s, 0.0)
        s.measured_displacement = s.displacement
        self.plan.replan(restart=False)
        return s

    def _substep(self, power, load, h):
        self.hold(power, self.hold_elongation, h)

    def hold(self, power, elongation, h):
        """Advance h (s) under power (W) with the end at elongation q (m); return state."""
        s = self.state
        self._heat.advance(s, power, h)
        y_c = s.creep
        s.previous_elongation = s.elongation
        s.velocity = (elongation - s.elongation) / h
        s.elongation = elongation
        if self._creeps:
            s.creep = creep_step(y_c, s.tension, h, self.params.effects)
        coil = elongation - s.creep
        contact = self._contact
        s.in_contact = coil <= contact
        s.time += h
        s.power = power
        s.tension = self.kinetostatics.tension(contact if contact > coil else coil,
                                               s.actuation_temperature, s.tension)
        s.load = s.tension
        self._update_outputs(s, h)
        return s

    def outputs(self):
        """Return {'force': F (N)}: the tension the clamp holds, Eq. (R4)."""
        return {'force': self.state.tension}


class AntagonisticPair:
    """Two identical TCAs pulling a pulley joint against each other, Eqs. (R5)-(R7).

    ``step(power, load, power_2)``: power (W) heats the agonist (muscle 1), which
    turns the joint to positive angles; ``power_2`` (W, default: the last one
    given, initially 0) the antagonist. ``load`` is not used. ``state`` is the
    agonist's TcaState (its displacement is r_p theta); ``outputs()`` the joint's.
    The joint's inertia J (rig.joint_inertia) includes all that turns with it;
    the muscles' own mass (~30 mg at r_p) is neglected, their damping b_t is not.

    Parameters
    ----------
    params : TcaParams
        Both muscles; rig.pulley_radius (m), rig.joint_inertia (kg m^2),
        rig.joint_damping (N m s/rad), rig.pretension (N) at theta = 0.
    model : str, optional
        Kinetostatic model rod | cst | love.
    dt : float
        Physics step (s).
    kinetostatics : KinetostaticModel, optional
        A prebuilt model shared by both muscles.
    """

    def __init__(self, params, model=None, dt=1e-3, kinetostatics=None):
        self.params = params
        self.kinetostatics = kinetostatics or make_kinetostatic_model(params, model)
        self.agonist = HeldMuscle(params, dt=dt, kinetostatics=self.kinetostatics)
        self.antagonist = HeldMuscle(params, dt=dt, kinetostatics=self.kinetostatics)
        rig = params.rig
        self.radius = rig.pulley_radius
        self.inertia = rig.joint_inertia
        # the muscles' damping b_t acts on their end speed r_p theta'
        self.damping = rig.joint_damping + 2.0 * rig.pulley_radius ** 2 * params.dynamics.damping
        self.dt = self.agonist.dt
        self.power_2 = 0.0
        self.plan = SubstepPlan(self.check_step)  # the joint's and both muscles' substeps
        self.reset()

    @property
    def state(self):
        """Return the agonist's TcaState (temperature degC, displacement r_p theta m)."""
        return self.agonist.state

    def reset(self, load=None, temperature=None, angle=0.0):
        """Set the joint at rest at angle (rad), both muscles at temperature (degC).

        ``load`` is not used. At angle 0 both muscles sit at q_0, their length
        under rig.pretension at ambient.
        """
        self.reference = self.agonist.reset().elongation  # q_0, m
        shift = self.radius * float(angle)
        self.agonist.reset(temperature=temperature, elongation=self.reference - shift)
        self.antagonist.reset(temperature=temperature, elongation=self.reference + shift)
        self.angle = self.previous_angle = float(angle)  # rad
        self.velocity = 0.0  # rad/s
        self.plan.replan()
        return self.state

    def set_dt(self, dt):
        """Change the physics step (s), keeping the state (StabilityError keeps the old)."""
        old = self.dt
        self.agonist.set_dt(dt)
        self.antagonist.set_dt(dt)
        self.dt = self.agonist.dt
        try:
            self.plan.replan(restart=False)
        except StabilityError:
            self.dt = old
            self.agonist.set_dt(old)
            self.antagonist.set_dt(old)
            raise

    def forces(self):
        """Return (F_1, F_2) (N), Eq. (R6): tendon tensions, zero when slack."""
        return (tendon_force(self.agonist.state.tension),
                tendon_force(self.antagonist.state.tension))

    def joint_stiffness(self):
        """Return r_p^2 (k_1 + k_2) (N m/rad) at the state; a slack tendon adds nothing."""
        total = 0.0
        for muscle in (self.agonist, self.antagonist):
            s = muscle.state
            if s.tension > 0.0:
                coil = max(s.elongation - s.creep, muscle._contact)
                total += self.kinetostatics.stiffness(coil, s.actuation_temperature)
        return self.radius ** 2 * total

    def stability_limit(self):
        """Return the central-difference limit 2 sqrt(J / (r_p^2 (k_1 + k_2))) (s)."""
        return central_difference_limit(self.joint_stiffness(), self.inertia)

    def substeps(self):
        """Return the equal substeps one dt needs (joint, thermal and creep limits)."""
        n = substep_count(self.dt, self.stability_limit())
        return max(n, self.agonist.substeps(), self.antagonist.substeps())

    def check_step(self):
        """Return substeps(); raise StabilityError beyond MAX_SUBSTEPS."""
        n = self.substeps()
        if n > MAX_SUBSTEPS:
            raise StabilityError(
                f'rig.joint_inertia = {self.inertia:g} kg m^2: explicit limit '
                f'{self.stability_limit():.3g} s needs more than {MAX_SUBSTEPS} substeps '
                f'of dt = {self.dt:g} s (a larger inertia or a smaller dt)')
        return n

    def step(self, power, load=None, power_2=None):
        """Advance one dt with powers (W) of agonist and antagonist; return its state."""
        if power_2 is not None:
            self.power_2 = float(power_2)
        n = self.plan.next_step()
        h = self.dt / n
        for _ in range(n):
            self._substep(power, self.power_2, h)
        return self.agonist.state

    def _substep(self, power_1, power_2, h):
        a, b = self.agonist, self.antagonist
        r = self.radius
        force_1 = tendon_force(a.state.tension)  # Eq. (R6), as forces()
        force_2 = tendon_force(b.state.tension)
        theta = self.angle
        nxt = central_difference_step(theta, self.previous_angle, r * (force_1 - force_2),
                                      self.inertia, self.damping, h)  # Eq. (R7)
        # joint stops where a coil reaches contact (Sec. V-D1), Eq. (R5): inelastic
        stop = a._contact
        high = (self.reference - a.state.creep - stop) / r
        low = (b.state.creep + stop - self.reference) / r
        if not low <= nxt <= high:
            nxt = min(max(nxt, low), high)
            theta = nxt
        self.previous_angle, self.angle = theta, nxt
        self.velocity = (nxt - theta) / h
        a.hold(power_1, self.reference - r * nxt, h)  # Eq. (R5)
        b.hold(power_2, self.reference + r * nxt, h)

    def outputs(self):
        """Return the joint's outputs: angle (rad), angular_velocity (rad/s), torque (N m).

        Also force, force_2 (N), temperature_2 (degC), resistance_2 (ohm), power_2 (W).
        """
        force_1, force_2 = self.forces()
        s2 = self.antagonist.state
        return {'angle': self.angle, 'angular_velocity': self.velocity,
                'torque': self.radius * (force_1 - force_2), 'force': force_1,
                'force_2': force_2, 'temperature_2': s2.temperature,
                'resistance_2': s2.resistance, 'power_2': s2.power}


def make_rig(params, model=None, dt=1e-3, kinetostatics=None):
    """Return the simulator of params.rig.mode: TcaSimulator (dead weight) or a rig.

    Raises ParameterError for a rig the TCA cannot be put on.
    """
    check_rig(params)
    kind = {DEAD_WEIGHT: TcaSimulator, SPRING: SpringLoadedMuscle, ISOMETRIC: HeldMuscle,
            ANTAGONISTIC: AntagonisticPair}[params.rig.mode]
    return kind(params, model=model, dt=dt, kinetostatics=kinetostatics)
