"""Statics of the rigs (tca_ros.model.rigs): where each one comes to rest.

Each relation is solved on the tension F (N) with the muscle's static elongation
y(T, F) (``static_elongation``: the model's own statics, coil contact included;
for the rod model the exact helix, not the dynamics table), so it checks the
dynamics of the rigs from outside the stepper:

- isometric, Eq. (R4): y(T, F) = q_0, the clamped length;
- spring, Eqs. (R2)-(R3): F = F_0 + k_s (q_0 - y(T, F)), the muscle's force
  curve meets the spring line;
- antagonistic, Eqs. (R5)-(R7): y(T_1, F) + y(T_2, F) = 2 q_0 (equal tensions,
  the pulley keeps the sum of the elongations), theta = (q_0 - y(T_1, F)) / r_p.

q_0 is the elongation under the pretension F_0 at ambient. Temperatures in degC.
"""
from scipy.optimize import brentq

from tca_ros.model.kinetostatics import static_elongation
from tca_ros.model.rigs import reference_elongation

BRACKET_GROWTH = 2.0  # widening factor of the tension bracket per try
BRACKET_TRIES = 60  # widenings before giving up (span x 1e18)
FORCE_TOLERANCE = 1e-12  # N, tension root


def _tension_root(gap, guess, span):
    """Return F (N) with gap(F) = 0, gap increasing; bracket widened around guess."""
    lo, hi = guess - span, guess + span
    for _ in range(BRACKET_TRIES):
        g_lo, g_hi = gap(lo), gap(hi)
        if g_lo <= 0.0 <= g_hi:
            return brentq(gap, lo, hi, xtol=FORCE_TOLERANCE, rtol=1e-13)
        span *= BRACKET_GROWTH
        if g_lo > 0.0:
            lo = guess - span
        if g_hi < 0.0:
            hi = guess + span
    raise ArithmeticError(f'rig statics: no tension within {guess:g} +- {span:g} N')


def isometric_force(model, temperature, pretension):
    """Return the force F (N) of a TCA clamped at q_0 at temperature (degC), Eq. (R4).

    ``model`` is a KinetostaticModel; ``pretension`` F_0 (N) sets q_0.
    """
    q0 = reference_elongation(model, pretension)
    return _tension_root(lambda f: static_elongation(model, f, temperature) - q0,
                         pretension, 0.1 + pretension)


def spring_rest_state(model, temperature, pretension, stiffness):
    """Return (contraction (m), force (N)) of the spring rig at rest, Eqs. (R2)-(R3).

    The contraction is q_0 - y from the reference q_0 (positive when shorter); the
    force is the TCA tension, equal to the spring's pull F_0 + k_s (q_0 - y).
    """
    q0 = reference_elongation(model, pretension)

    def gap(force):
        return force - pretension - stiffness * (q0 - static_elongation(model, force,
                                                                        temperature))
    force = _tension_root(gap, pretension, 0.1 + pretension)
    return q0 - static_elongation(model, force, temperature), force


def antagonistic_rest_angle(model, temp_1, temp_2, pretension, radius):
    """Return (theta (rad), F (N)) of the antagonistic pair at rest, Eqs. (R5)-(R7).

    Agonist at temp_1, antagonist at temp_2 (degC); pulley radius (m). Tendons
    taut (F > 0) is assumed, as with any positive pretension.
    """
    q0 = reference_elongation(model, pretension)

    def gap(force):
        return (static_elongation(model, force, temp_1)
                + static_elongation(model, force, temp_2) - 2.0 * q0)
    force = _tension_root(gap, pretension, 0.1 + pretension)
    return (q0 - static_elongation(model, force, temp_1)) / radius, force
