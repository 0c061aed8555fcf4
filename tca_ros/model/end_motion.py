"""The free end's motion, eq. (18) of [1]: its right-hand side and the schemes that step it.

    m q'' + b_t q' + f_rod(q - y_c, T) = F_load                           (18)
    dy_c/dt = (C f_rod - y_c) / tau_c                                  creep

with q the elongation (m) of the free end from l* (stretching positive), y_c the
creep ('creep' in effects.py) and coil contact a hard, inelastic stop (Sec. V-D1).
This module is the one home of eq. (18): its rates (``end_acceleration``,
``massless_speed``, ``creep_step``), its central differences (Sec. V-B4,
explicit in f_rod: one step, the acceleration, q_{i-1} moved when the substep
changes) and the contact stop take floats (one muscle) or NumPy arrays (N,)
(one value per muscle), so the scalar stepper (dynamics.py), the rigs
(rigs.py), the batch stepper (toolkit/batch.py) and the linearisation
(toolkit/state_equations.py) evaluate them alike. ``EndMotion`` adds the scalar
steps that need f_rod: backward Euler of the massless damped equation
b_t q' + f_rod = F, and Coulomb friction on the free end ('friction' in
effects.py) in time-stepping form. The stability limits are in substeps.py.
"""
import math

import numpy as np

from tca_ros.model import effects as fx


def end_acceleration(net, velocity, mass, damping):
    """Return q'' (m/s^2) of eq. (18): (F - f_rod - b_t q') / m; ``net`` F - f_rod (N)."""
    return (net - damping * velocity) / mass


def massless_speed(net, damping):
    """Return q' (m/s) of eq. (18) without mass: (F - f_rod) / b_t; ``net`` (N)."""
    return net / damping


def creep_step(creep, tension, h, effects):
    """Return y_c (m) after h (s) of the creep element (explicit Euler), tension F (N)."""
    return creep + h * fx.creep_rate(creep, tension, effects)


def contact_stop(q_next, q, creep, contact):
    """Return (q_{i+1}, q_i, in contact): the coil-contact stop of Sec. V-D1 applied.

    Where the coil q_{i+1} - y_c (m) passes the contact elongation (m), the end
    stops there and q_i moves with it: the coils absorb the momentum (inelastic).
    """
    if isinstance(q_next, np.ndarray):
        hit = q_next - creep < contact
        q_next = np.where(hit, creep + contact, q_next)
        return q_next, np.where(hit, q_next, q), hit
    if q_next - creep < contact:
        q_next = creep + contact
        return q_next, q_next, True
    return q_next, q, False


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


class EndMotion:
    """The steps of eq. (18) for one free end that need f_rod or the friction.

    Parameters
    ----------
    kinetostatics : KinetostaticModel
        f_rod(q, T) (N) and its stiffness (N/m).
    contact : float
        Elongation (m) at coil contact (Sec. V-D1): f_rod is not evaluated below it.
    params : TcaParams
        The TCA: dynamics (mass, damping) and effects (friction) are read.
    """

    def __init__(self, kinetostatics, contact, params):
        self.kinetostatics = kinetostatics
        self.contact = contact
        self.params = params

    def rescale_previous(self, state, q, load, old, h):
        """Move q_{i-1} (``state.previous_elongation``) from ``old`` to h (s) before q_i.

        Called when the substep length changes. The acceleration from eq. (18) at
        step i (load (N), q_i = ``q`` (m)) makes the rescaling second order; with
        friction the holding force is not known here, so the half-step velocity is
        kept instead (first order).
        """
        s, d = state, self.params.dynamics
        accel = 0.0
        if self.params.effects.friction_force == 0.0:
            accel = central_difference_acceleration(q, s.previous_elongation, load - s.tension,
                                                    d.mass, d.damping, old)
        s.previous_elongation = rescaled_previous(q, s.previous_elongation, old, h, accel)

    def friction_step(self, state, q, y_c, load, mass, damping, h):
        """Return q_{i+1} (m) of eq. (18) with Coulomb friction on the free end.

        With mass, the central-difference step is linear in the friction force f,
        q_{i+1} = q_free + f / (m / h^2 + b / (2 h)): the force holding the end at
        q_i follows, and ``effects.coulomb_friction`` keeps it or slides against
        F_k. Massless, the holding force is f_rod(q_i, T_{i+1}) - F and a sliding
        end moves under F -+ F_k (backward Euler, or the band edge when b = 0: the
        play operator of effects.friction_play). Sets ``state.stuck``.
        """
        s, e = state, self.params.effects
        model = self.kinetostatics
        temp = s.actuation_temperature
        if mass > 0.0:
            q_free = central_difference_step(q, s.previous_elongation, load - s.tension,
                                             mass, damping, h)
            inverse = mass / (h * h) + 0.5 * damping / h  # d(force) / d(q_{i+1}), N/m
            force, s.stuck = fx.coulomb_friction(inverse * (q - q_free), s.stuck, e)
            return q if s.stuck else q_free + force / inverse
        holding = model.tension(max(q - y_c, self.contact), temp, s.tension) - load
        force, s.stuck = fx.coulomb_friction(holding, s.stuck, e)
        if s.stuck:
            return q
        if damping > 0.0:
            return self.backward_euler(q, y_c, load + force, temp, damping, h)
        return y_c + model.equilibrium_elongation(load + force, temp, guess=q - y_c)

    def backward_euler(self, q, y_c, load, temp, damping, h):
        """Return q_{i+1} (m) of b (q_{i+1} - q_i)/h + f_rod(q_{i+1}) = F (Newton).

        ``y_c`` creep (m), ``load`` F (N), ``temp`` T (degC), ``damping`` b (N s/m),
        ``h`` step (s).
        """
        model = self.kinetostatics
        y = q - y_c
        for _ in range(20):
            residual = damping * (y + y_c - q) / h + model.tension(y, temp) - load
            slope = damping / h + model.stiffness(max(y, self.contact), temp)
            if not slope > 0.0:  # f_rod softening faster than b/h: keep the last iterate
                break
            step = residual / slope
            y -= step
            if abs(step) < 1e-12:
                break
        return y + y_c
