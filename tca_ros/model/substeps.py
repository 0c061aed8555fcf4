"""The substep planner of every stepper: equal substeps within the explicit limits.

A step dt (s) of the steppers (dynamics.py, rigs.py, toolkit/batch.py) is split
into n equal substeps h = dt / n, n the smallest that keeps h within
STABILITY_SAFETY of the binding limit: the central differences of eq. (18) (or
of the joint (R7)) need h < 2 / omega, the RK4 thermal update of a nonlinear
eq. (1) h lambda < 2.785, the explicit creep h < tau_c / (1 + C k). The limits
drift slowly with the state, so a ``SubstepPlan`` re-plans every
STABILITY_RECHECK steps; beyond MAX_SUBSTEPS the step is refused
(``StabilityError``).
"""
import math

import numpy as np

STABILITY_SAFETY = 0.9  # fraction of the central-difference limit 2/omega used per substep
MAX_SUBSTEPS = 1000  # beyond this, ask for the quasi-static mode instead
STABILITY_RECHECK = 100  # steps between re-evaluations of the stability limit (k drifts slowly)


class StabilityError(ValueError):
    """The step is beyond the explicit stability limit by more than MAX_SUBSTEPS."""


def central_difference_limit(stiffness, mass):
    """Return the stability limit 2 / omega (s) of the central-difference step.

    omega = sqrt(k / m), ``stiffness`` k (N/m), ``mass`` m (kg; or the inertia
    and the rotational stiffness of a joint); inf (s) without mass or stiffness.
    Floats or arrays (one limit per muscle).
    """
    if isinstance(stiffness, np.ndarray) or isinstance(mass, np.ndarray):
        with np.errstate(divide='ignore', invalid='ignore'):
            return np.where((stiffness > 0.0) & (mass > 0.0),
                            2.0 * np.sqrt(mass / stiffness), math.inf)
    if mass <= 0.0 or stiffness <= 0.0:
        return math.inf
    return 2.0 * math.sqrt(mass / stiffness)


def creep_limit(stiffness, effects):
    """Return the substep (s) below which explicit Euler creep decays monotonically.

    The creep element in series with the coil (``stiffness`` k, N/m) relaxes at the
    rate (1 + C k) / tau_c, not 1 / tau_c: a compliant creep on a stiff coil is
    stiff. inf (s) without creep.
    """
    e = effects
    if e.creep_compliance <= 0.0:
        return math.inf
    return e.creep_time_constant / (1.0 + e.creep_compliance * max(stiffness, 0.0))


def substep_count(dt, limit):
    """Return the number of equal substeps of dt (s) within STABILITY_SAFETY * limit (s).

    ``limit`` may be an array (one per muscle): its smallest binds. MAX_SUBSTEPS + 1
    when the limit is zero or not a number, or needs more.
    """
    if isinstance(limit, np.ndarray):
        limit = float(np.min(limit))
    limit = STABILITY_SAFETY * limit
    if limit == math.inf:
        return 1
    if not limit > 0.0 or dt / limit > MAX_SUBSTEPS:  # also a NaN limit
        return MAX_SUBSTEPS + 1
    return max(1, math.ceil(dt / limit))


def stability_error(mass, mechanical, others, dt):
    """Return the StabilityError naming the binding limit of a step dt (s).

    ``mechanical`` is 2/omega (s) of a free ``mass`` (kg), ``others`` the thermal
    and creep limits (s).
    """
    if not mechanical > others:
        return StabilityError(
            f'dynamics.mass = {mass:g} kg: explicit limit '
            f'2/omega = {mechanical:.3g} s needs more than {MAX_SUBSTEPS} substeps '
            f'of dt = {dt:g} s; allowed at most {MAX_SUBSTEPS} '
            '(use mass 0 for the quasi-static mode or a smaller dt)')
    return StabilityError(
        f'thermal or creep limit {others:.3g} s needs more than {MAX_SUBSTEPS} '
        f'substeps of dt = {dt:g} s (check thermal.*, effects.emissivity, '
        'effects.convection_exponent, effects.creep_time_constant, or a smaller dt)')


class SubstepPlan:
    """The substeps n (-) a stepper takes per step, re-planned every STABILITY_RECHECK steps.

    Parameters
    ----------
    check : callable
        check() -> n: the stepper's own planner (its limits through ``substep_count``);
        it raises StabilityError beyond MAX_SUBSTEPS.
    """

    def __init__(self, check):
        self.check = check
        self.count = 1  # substeps per step
        self.since_check = 0  # steps since the last re-plan

    def replan(self, restart=True):
        """Plan now; ``restart`` counts the STABILITY_RECHECK steps from here."""
        self.count = self.check()
        if restart:
            self.since_check = 0
        return self.count

    def next_step(self):
        """Return n for the coming step, re-planned when STABILITY_RECHECK steps passed."""
        self.since_check += 1
        if self.since_check >= STABILITY_RECHECK:
            self.since_check = 0
            self.count = self.check()
        return self.count
