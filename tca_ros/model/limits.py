"""Physical limits of a TCA: where the thread breaks, melts, or its coils would overlap.

The models of [1] hold inside these limits; outside them a result would still come
out of the equations (a helix that solves 100 N at 574 mm, a coil of negative
length at 300 degC), but it would describe no muscle. Each limit here either
refuses a parameter set at load time (one line naming the field, the value and the
reason, see :func:`parameter_limit_violation`) or ends a run honestly
(:class:`ThreadBreakError`). docs/decisions.md (D17) gives the sources.

References
----------
[1] Sun et al., IEEE T-RO 2022: Sec. V-A (240 g breaks the thread while it is
    twisted), eqs. (4), (19), (24) (Love's heated helix).
"""
import math

from tca_ros.model.fiber import radius_ratio, unit_untwist

#: degC: nylon 6,6 melts near 260 degC; the models' temperature range ends here (the
#: node's default melt_temperature, 250 degC, lies inside it).
MELT_TEMPERATURE_DEGC = 260.0
#: K below the lowest ambient that the models must still cover (the rod table's margin).
BELOW_AMBIENT_MARGIN = 20.0


class ThreadBreakError(ValueError):
    """The thread carries more than its strength, ``fiber.break_force``: it breaks."""


def check_thread_strength(tension, fiber, time=None):
    """Raise ThreadBreakError if the tension (N) exceeds fiber.break_force (N).

    ``time`` (s), when given, is named in the one-line message.
    """
    if tension > fiber.break_force:
        at = '' if time is None else f' at t = {time:.6g} s'
        raise ThreadBreakError(
            f'tension {tension:.4g} N{at} exceeds fiber.break_force {fiber.break_force:g} N: '
            'the thread breaks')


def touching_pitch_angle(fiber, coil):
    """Return the pitch angle alpha_s (rad) at which neighbouring turns touch.

        sin(alpha_s) = r_t / (pi r*)

    On the developed coil cylinder neighbouring turns are 2 pi r* sin(alpha) apart
    normal to the fiber; they touch when that gap is the fiber diameter 2 r_t (the
    geometric contact of docs/describe.md). Below it the coils would pass through
    each other: no helical TCA is shorter than l_t sin(alpha_s).
    """
    return math.asin(min(fiber.radius / (math.pi * coil.radius), 1.0))


def temperature_range(params):
    """Return (low, high) (degC): the fiber temperatures a model must cover.

    From BELOW_AMBIENT_MARGIN under the lower of the nominal and true ambient (the
    fiber never cools below the air) to MELT_TEMPERATURE_DEGC.
    """
    ambient = params.thermal.ambient_temperature
    low = min(ambient, ambient + params.effects.ambient_offset) - BELOW_AMBIENT_MARGIN
    return low, MELT_TEMPERATURE_DEGC


def _radius_ratio_extremes(fiber, low, high):
    """Return the temperatures (degC) of the smallest and largest Gamma on [low, high]."""
    c2, c1, _ = fiber.gamma_coefficients
    candidates = [low, high]
    top = min(high, fiber.expansion_plateau_temperature)  # linear above T_p (G50)
    if c2 != 0.0 and low < -c1 / (2.0 * c2) < top:  # vertex of the parabola, eq. (4)
        candidates.append(-c1 / (2.0 * c2))
    ordered = sorted(candidates, key=lambda t: radius_ratio(t, fiber))
    return ordered[0], ordered[-1]


def parameter_limit_violation(p):
    """Return a one-line ParameterError message for ``p`` outside the limits, or ''.

    Rules: the turns of the reference helix do not overlap (alpha* > alpha_s); the
    hanging load is within the thread's strength; the unloaded softening of eq. (11)
    leaves E_f above its floor up to the melt (beyond it the load factor makes y(F)
    non-monotonic: no unique equilibrium); Gamma(T) of eq. (4) stays
    positive over the model's temperature range (the untwist divides by it); Love's
    heated helix, eqs. (19) and (24), exists over that range (|sin alpha^h| < 1).
    """
    fiber, coil = p.fiber, p.coil
    if coil.shape == 'helix' and touching_pitch_angle(fiber, coil) >= coil.pitch_angle:
        return (f"parameter 'coil.pitch_angle_deg' = {math.degrees(coil.pitch_angle):g}: the "
                f'turns of this coil overlap (they touch at '
                f'{math.degrees(touching_pitch_angle(fiber, coil)):.4g} deg: sin = r_t / (pi r*))')
    if p.dynamics.load > fiber.break_force:
        return (f"parameter 'dynamics.load' = {p.dynamics.load:g}: above fiber.break_force "
                f'({fiber.break_force:g} N), the thread breaks')
    low, high = temperature_range(p)
    m = p.moduli
    softening = m.fiber_softening * (high - p.thermal.ambient_temperature)  # Pa, eq. (11)
    if not m.constant and softening >= (1.0 - m.fiber_modulus_floor) * m.fiber_modulus:
        return (f"parameter 'moduli.fiber_softening' = {m.fiber_softening:g}: eq. (11) would "
                f'soften E_f by {softening:.3g} Pa by {high:g} degC, more than (1 - '
                f'moduli.fiber_modulus_floor) E_f0 = '
                f'{(1.0 - m.fiber_modulus_floor) * m.fiber_modulus:.3g} Pa: the fiber would '
                'lose its stiffness before it melts')
    smallest, largest = _radius_ratio_extremes(fiber, low, high)
    if radius_ratio(smallest, fiber) <= 0.0:
        return (f"parameter 'fiber.gamma_coefficients' = {list(fiber.gamma_coefficients)}: "
                f'Gamma(T) must stay positive over {low:g} to {high:g} degC (it is '
                f'{radius_ratio(smallest, fiber):.3g} at {smallest:g} degC)')
    if p.model == 'love' and coil.shape == 'helix':
        ambient = p.thermal.ambient_temperature
        for temp in (smallest, largest):  # the extremes of the untwist
            sine = math.sin(coil.pitch_angle) + unit_untwist(temp, fiber, ambient) \
                * coil.radius / math.cos(coil.pitch_angle)  # eqs. (19), (24)
            if not -1.0 < sine < 1.0:
                return (f"parameter 'model' = 'love': Love's heated helix (eqs. 19, 24) does "
                        f'not exist at {temp:g} degC (sin alpha^h = {sine:.3g}, coil.radius '
                        f'{coil.radius:g} m): use cst or rod')
    return ''
