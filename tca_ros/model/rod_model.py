"""The Cosserat rod kinetostatic model 'rod': f_rod(y, T) of Eq. (18) from exact helices.

Away from its clamp a helical TCA under an axial load is a uniform helix whose
strains solve the algebraic equilibrium of :mod:`tca_ros.rod.helix` exactly (all four
strains, geometrically exact, end free to rotate as in the paper's BVP with
M_e = 0). The full-length BVP (:mod:`tca_ros.rod.statics`) agrees with it to the
clamp boundary layer (test/test_rod_statics.py); solving the algebraic problem is
what makes the model fast.

For the dynamics f_rod must cost microseconds: it is read from a table of exact
solutions (:mod:`tca_ros.model.rod_table`, cached per parameter set).

References
----------
[1] Sun et al., IEEE T-RO 2022, Eqs. (4), (8)-(18), Algorithm 1, Appendix C.
"""
from dataclasses import replace
import functools
import math

import numpy as np
from scipy.optimize import brentq

from tca_ros.model.fiber import unit_untwist
from tca_ros.model.kinetostatics import KinetostaticModel
from tca_ros.model.limits import check_thread_strength, touching_pitch_angle
from tca_ros.model.moduli import section_stiffness
from tca_ros.model.rod_table import _helix_state, _linear_stiffness, _natural_length
from tca_ros.model.rod_table import build_table, helix_elongation  # noqa: F401 (API)
from tca_ros.model.rod_table import RodTableError  # noqa: F401 (raised by the table)
from tca_ros.model.tca_params import EffectParams, RigParams
from tca_ros.rod.helix import helix_centreline
from tca_ros.rod.reference import conical_spiral_reference, helix_reference
from tca_ros.rod.statics import solve_continuation


class RodKinetostatics(KinetostaticModel):
    """Cosserat rod kinetostatics (exact uniform helix), the model 'rod'.

    ``tension(y, T)`` and ``stiffness(y, T)`` interpolate a cached table of exact
    solutions (a few microseconds); ``direct_tension`` solves exactly (the reference
    the table is tested against). Elongation y (m) is from l* = l_t sin(alpha*),
    positive when stretched; tension F (N) positive when the TCA pulls.

    Parameters
    ----------
    params : TcaParams
        A helical TCA.
    rotation_locked : bool
        Hold the coil count (end cannot rotate) instead of the free end (M_e = 0).
    """

    name = 'rod'

    def __init__(self, params, rotation_locked=False):
        if params.coil.shape != 'helix':
            raise ValueError(f'coil.shape = {params.coil.shape!r}: the rod kinetostatic '
                             'model needs a helix; use conical_shapes for a conical TCA')
        super().__init__(params)
        self.rotation_locked = bool(rotation_locked)
        # the table does not read the strength: share it across break forces
        table_params = replace(params, fiber=replace(params.fiber, break_force=1.0))
        self._table = build_table(table_params, self.rotation_locked)

    @property
    def temperature_range(self):
        """Return (first, last) temperature (degC) of the table's rows."""
        return self._table.temp0, self._table.top

    def tension(self, elongation, temperature, force_guess=None):
        """Return f_rod (N) at elongation y (m) and temperature T (degC), Eq. (18).

        ``force_guess`` is accepted for interface compatibility and ignored: the
        table already satisfies the moduli fixed point of Eq. (11).
        """
        return self._table.force_at(elongation, temperature)

    def stiffness(self, elongation, temperature):
        """Return d f_rod / d y (N/m) at elongation (m) and temperature (degC)."""
        return self._table.evaluate(elongation, temperature)[1]

    def free_elongation(self, temperature):
        """Return the unloaded elongation y_free(T) (m) (exact helix, F = 0)."""
        return float(helix_elongation(self.params, temperature, 0.0, self.rotation_locked))

    def equilibrium_elongation(self, load, temperature, guess=None):
        """Return y (m) where f_rod(y, T) = load (N), solved exactly; no coil contact.

        ThreadBreakError when the load exceeds ``fiber.break_force``.
        """
        check_thread_strength(load, self.params.fiber)
        return float(helix_elongation(self.params, temperature, load, self.rotation_locked))

    def direct_tension(self, elongation, temperature):
        """Return f_rod (N) by an exact solve (Brent on F of the exact y(T, F)).

        The moduli are evaluated at the root F itself (the fixed point of Eq. (11)).
        """
        def gap(force):
            return float(helix_elongation(self.params, temperature, force,
                                          self.rotation_locked)) - elongation
        k = _linear_stiffness(self.params)
        guess = self.tension(elongation, temperature)
        span = 0.05 * abs(guess) + 1e-3 * k * self.params.fiber.length
        lo, hi = guess - span, guess + span
        for _ in range(40):
            if gap(lo) < 0.0 < gap(hi):
                break
            lo, hi = lo - span, hi + span
            span *= 2.0
        return brentq(gap, lo, hi, xtol=1e-13, rtol=1e-13)


def cached_rod_model(params):
    """Return the RodKinetostatics of ``params``, built once per mechanical state.

    The table depends only on the fiber, coil, moduli, ambient temperature and the
    modulus-softening effect; parameter sets differing elsewhere (thermal constants,
    mass, resistance, other effects) share one table.
    """
    return _rod_model_for(mechanical_params(params))


def mechanical_params(params):
    """Return ``params`` with every field the rod table does not read set to default."""
    thermal = replace(params.thermal, convection_coefficient=0.0, surface_factor=1.0,
                      delivered_power_ratio=1.0)
    fiber = replace(params.fiber, density=1.0, specific_heat=1.0)
    return replace(params, tca_type='', model='rod', source='', thermal=thermal, fiber=fiber,
                   dynamics=replace(params.dynamics, mass=0.0, load=0.0, damping=0.0),
                   electrical=replace(params.electrical, resistance=1.0,
                                      temperature_coefficient=0.0, strain_coefficient=0.0),
                   effects=EffectParams(extra_softening=params.effects.extra_softening),
                   rig=RigParams())


@functools.lru_cache(maxsize=8)
def _rod_model_for(params):
    return RodKinetostatics(params)


def helix_centreline_at(params, elongation, temperature, n_points=200):
    """Return the centreline (m) of a helical TCA at elongation y (m) and T (degC).

    The exact uniform helix at the tension f_rod(y, T), on the global Z axis, from the
    clamp at z = 0 downwards (z = -l at the free end): shape (3, n_points), n_points >= 2.
    """
    model = cached_rod_model(params)
    force = model.tension(elongation, temperature)
    eq = _helix_state(params, temperature, force)
    return helix_centreline(eq, params.fiber.length, int(n_points))


def rod_reference(params, temperature):
    """Return the heated RodReference of ``params`` at T (degC), Eqs. (15), (40)."""
    untwist = unit_untwist(temperature, params.fiber, params.thermal.ambient_temperature)
    c = params.coil
    if c.shape == 'helix':
        return helix_reference(c.radius, c.pitch_angle, params.fiber.length, untwist)
    return conical_spiral_reference(c.spiral_pitch, c.cone_angle, params.fiber.length,
                                    untwist)


def stiffness_vector(params, temperature, tension):
    """Return diag(K) = [EI, EI, GJ, GA, GA, EA] (N m^2, N) at (T, F), Eq. (8)."""
    s = section_stiffness(temperature, tension, params)
    return np.array([s.EI, s.EI, s.GJ, s.GA, s.GA, s.EA])


def rod_statics_sweep(params, load, temperatures, n_steps=None, **solver_options):
    """Solve the full-length rod BVP over temperatures (Algorithm 1 of [1]).

    The load (N, tensile) hangs below the free end along -Z through a rigid cap
    whose hook is on the coil axis of the end (offset r* along the end frame's
    principal normal; docs/rod.md). Each temperature is warm-started from the
    previous one; the moduli use F = load (Eq. (11)).

    Returns
    -------
    list of RodSolution
        One per temperature; check ``success``. A solution whose coils would pass
        through each other (length below l_t sin(alpha_s)) is marked failed.
    """
    offset = (params.coil.radius, 0.0, 0.0) if params.coil.shape == 'helix' else (0, 0, 0)

    def problem(temp):
        return dict(reference=rod_reference(params, temp),
                    stiffness=stiffness_vector(params, temp, load),
                    end_force=np.array([0.0, 0.0, -load]), end_load_offset=offset)
    sols = solve_continuation(problem, list(temperatures), n_steps=n_steps, **solver_options)
    if params.coil.shape != 'helix':
        return sols
    return [_refuse_overlapping_coils(params, temp, sol) for temp, sol in zip(temperatures, sols)]


def _refuse_overlapping_coils(params, temperature, solution):
    """Return ``solution``, marked failed when its coils would pass through each other.

    The rod BVP has no self-contact: past the length at which neighbouring turns touch
    (limits.touching_pitch_angle) it still converges, to a coil whose turns overlap
    and finally to a negative length. Such a solution describes no TCA.
    """
    if not solution.success:
        return solution
    touching = params.fiber.length * math.sin(touching_pitch_angle(params.fiber, params.coil))
    length = solution_elongation(params, solution) + _natural_length(params)
    if length >= touching:
        return solution
    return replace(solution, success=False, message=(
        f'at {float(temperature):g} degC the coil length {length:.4g} m is below '
        f'{touching:.4g} m, where its turns touch: the coils would pass through each other '
        '(the BVP has no self-contact)'))


def solution_elongation(params, solution):
    """Return y (m) of a helical BVP solution: axial drop of the free end minus l*."""
    return float(solution.positions[2, 0] - solution.positions[2, -1]) - _natural_length(
        params)
