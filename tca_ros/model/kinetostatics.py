"""Coil kinetostatic models: Love's equation (19)-(27) and CST (28)-(29) of [1].

A kinetostatic model gives the axial force f_rod that the TCA exerts at an axial
elongation y and temperature T, the term f_rod(x, T) of the dynamics (18).

Conventions (docs/decisions.md)
-------------------------------
- Elongation y = l - l* (m) is measured from the natural reference length
  l* = l_t sin(alpha*) (eq. (26) at the reference state), positive when stretched.
- Tension F (N) is positive when the TCA pulls (the hanging weight gives F = m g,
  i.e. F_e = -F in the paper's sign).
- The untwist of eq. (4) is negative when hot; the coil then contracts.
- Love's equation keeps the coil count fixed (eq. (24), end cannot rotate); CST and
  the rod model let the end rotate (M_e = 0). CST coefficients are evaluated at the
  current pitch angle sin(alpha) = l / l_t and the coil radius of eq. (24),
  r = r* cos(alpha) / cos(alpha*) (Sec. IV-B allows updating r and alpha; eq. (24) is
  the paper's relation between them and the authors' CST code uses it; D9).
- Moduli follow eq. (11) with F the current tension (a fixed point, solved by
  iteration).
"""
import math

import numpy as np

from tca_ros.model.fiber import radius_ratio, unit_untwist
from tca_ros.model.limits import check_thread_strength, touching_pitch_angle
from tca_ros.model.moduli import section_stiffness

_MODULI_TOLERANCE = 1e-9  # N, fixed point of F in eq. (11)
_MODULI_MAX_ITERATIONS = 50  # secant iterations on F; 3-6 are typical
_STIFFNESS_STEP = 1e-7  # m, central-difference step for d tension / d y


def natural_length(fiber, coil):
    """Return the natural TCA length l* = l_t sin(alpha*) (m), Eq. (26)."""
    return fiber.length * math.sin(coil.pitch_angle)


def pitch_angle_of_length(length, fiber):
    """Return the pitch angle alpha (rad) of a helix of axial length (m), Eq. (26)."""
    return math.asin(min(max(length / fiber.length, -1.0), 1.0))


def fixed_count_radius(alpha, coil):
    """Return the coil radius r (m) at pitch angle alpha (rad) for a fixed coil count, Eq. (24).

        cos(alpha) / r = cos(alpha*) / r*
    """
    return coil.radius * math.cos(alpha) / math.cos(coil.pitch_angle)


def love_heated_pitch_sine(untwist, coil):
    """Return sin(alpha^h) (-) from Love's equation (19) with fixed coils (24).

        Delta theta_bar^h = cos(alpha*)/r* (sin alpha^h - sin alpha*)
    """
    return math.sin(coil.pitch_angle) + untwist * coil.radius / math.cos(coil.pitch_angle)


def love_tension(sin_alpha, sin_alpha_h, section, coil):
    """Return the tension F (N) balancing a helix at pitch sine ``sin_alpha``, Eq. (25).

        F = cos^2 a* / r*^2 [GJ (sin a - sin a^h) - EI tan a (cos a - cos a^h)]
    """
    cos_a = math.sqrt(max(1.0 - sin_alpha * sin_alpha, 0.0))
    cos_h = math.sqrt(max(1.0 - sin_alpha_h * sin_alpha_h, 0.0))
    scale = math.cos(coil.pitch_angle) ** 2 / coil.radius ** 2
    return scale * (section.GJ * (sin_alpha - sin_alpha_h)
                    - section.EI * sin_alpha / cos_a * (cos_a - cos_h))


def love_compliance(alpha, alpha_h, section, fiber, coil):
    """Return 1/K_lv (m/N) of Eq. (27) in its linearised form (docs/decisions.md, D7).

        K_lv = (GJ cos^2 a + EI sin^2 a) / (l_t r^2), r = r* cos a / cos a*
    """
    r = fixed_count_radius(alpha, coil)
    return fiber.length * r * r / (section.GJ * math.cos(alpha) ** 2
                                   + section.EI * math.sin(alpha) ** 2)


def love_kinematic_coefficient(fiber, coil):
    """Return A_lv = l_t r* / cos(alpha*) (m^2), Eq. (27)."""
    return fiber.length * coil.radius / math.cos(coil.pitch_angle)


def cst_compliance(radius, alpha, section, fiber):
    """Return 1/K_cst (m/N), Eq. (29).

        1/K = l_t (r^2 cos^2 a / GJ + r^2 sin^2 a / EI + cos^2 a / GA + sin^2 a / EA)
    """
    c2 = math.cos(alpha) ** 2
    s2 = 1.0 - c2
    r2 = radius * radius
    return fiber.length * (r2 * c2 / section.GJ + r2 * s2 / section.EI
                           + c2 / section.GA + s2 / section.EA)


def cst_kinematic_coefficient(radius, alpha, fiber):
    """Return A_cst = l_t r cos(alpha) (m^2), Eq. (29)."""
    return fiber.length * radius * math.cos(alpha)


class KinetostaticModel:
    """Base of the coil kinetostatic models (the f_rod of Eq. (18)).

    Subclasses implement ``_tension_at(y, T, F_guess)``: the tension (N) at
    elongation y (m) and temperature T (degC) for moduli evaluated at F_guess.
    """

    name = ''

    def __init__(self, params):
        self.params = params
        self.natural_length = natural_length(params.fiber, params.coil)
        self.ambient = params.thermal.ambient_temperature

    def untwist(self, temperature):
        """Return Delta theta_bar^h (rad/m) at temperature (degC), Eq. (4)."""
        return unit_untwist(temperature, self.params.fiber, self.ambient)

    def section(self, temperature, tension):
        """Return the Section of Eq. (8) at temperature (degC) and tension (N)."""
        return section_stiffness(temperature, tension, self.params)

    def tension(self, elongation, temperature, force_guess=None):
        """Return f_rod (N): the axial force at elongation (m) and temperature (degC).

        The moduli depend on the force itself (eq. (11)); the fixed point
        F = g(F) is solved by the secant method. With ``force_guess`` (N, e.g. the
        previous step's tension in a time loop) a single pass g(force_guess) is
        returned instead: the dynamics then converges to the fixed point over
        steps, at a cost of one evaluation per step.
        """
        if force_guess is not None:
            return self._tension_at(elongation, temperature, force_guess)
        f0 = self._tension_at(elongation, temperature, 0.0)
        r0 = self._tension_at(elongation, temperature, f0) - f0
        f1 = f0 + r0
        for _ in range(_MODULI_MAX_ITERATIONS):
            r1 = self._tension_at(elongation, temperature, f1) - f1
            if abs(r1) < _MODULI_TOLERANCE or r1 == r0:
                break
            f0, f1, r0 = f1, f1 - r1 * (f1 - f0) / (r1 - r0), r1
        return f1

    def stiffness(self, elongation, temperature):
        """Return d f_rod / d y (N/m) at elongation (m) and temperature (degC)."""
        h = _STIFFNESS_STEP
        return (self.tension(elongation + h, temperature)
                - self.tension(elongation - h, temperature)) / (2.0 * h)

    def equilibrium_elongation(self, load, temperature, guess=None):
        """Return y (m) with f_rod(y, T) = load (N); coil contact not applied.

        Newton's method from ``guess`` (m), safeguarded by bisection within the
        geometric range of eq. (26). A load above ``fiber.break_force`` raises
        ThreadBreakError: the thread breaks before it gets there.
        """
        check_thread_strength(load, self.params.fiber)
        lo = -self.natural_length + 1e-9 * self.params.fiber.length
        hi = self.params.fiber.length * 0.999 - self.natural_length
        y = 0.0 if guess is None else min(max(guess, lo), hi)
        for _ in range(60):
            residual = self.tension(y, temperature) - load
            if residual > 0.0:
                hi = y
            else:
                lo = y
            k = self.stiffness(y, temperature)
            step = -residual / k if k > 0.0 else 0.5 * (hi - lo)
            y_new = y + step
            if not lo < y_new < hi:
                y_new = 0.5 * (lo + hi)
            if abs(y_new - y) < 1e-13:
                return y_new
            y = y_new
        return y

    def loaded_equilibrium(self, load, temperature, guess=None):
        """Return y (m) with f_rod(y, T) = load (N), the moduli taken at F = load.

        At equilibrium the tension equals the load, so eq. (11) is evaluated at
        the load itself and no fixed point on F is needed: a secant solve on y
        alone (what the quasi-static reduction calls on every temperature).
        Coil contact not applied; ThreadBreakError above ``fiber.break_force``.
        """
        check_thread_strength(load, self.params.fiber)
        y0 = 0.0 if guess is None else guess
        g0 = self._tension_at(y0, temperature, load) - load
        y1 = y0 + 1e-6 * self.params.fiber.length
        for _ in range(60):
            g1 = self._tension_at(y1, temperature, load) - load
            if abs(y1 - y0) < 1e-13 or g1 == g0:
                break
            y0, y1, g0 = y1, y1 - g1 * (y1 - y0) / (g1 - g0), g1
        if not math.isfinite(y1):
            return self.equilibrium_elongation(load, temperature, guess)
        return y1


class LoveModel(KinetostaticModel):
    """Love's equation with rod bending and torsion, Eqs. (19)-(27)."""

    name = 'love'

    def _tension_at(self, elongation, temperature, force):
        p = self.params
        sin_h = love_heated_pitch_sine(self.untwist(temperature), p.coil)
        sin_a = (self.natural_length + elongation) / p.fiber.length
        if not -1.0 < sin_a < 1.0:  # eq. (25) divides by cos(alpha)
            raise ArithmeticError(
                f'love: coil length {self.natural_length + elongation:.4g} m at {temperature:g} '
                f'degC reaches the fiber length l_t = {p.fiber.length:g} m (a straight fiber): '
                "Love's inextensible helix has no state there; use cst or rod")
        return love_tension(sin_a, sin_h, self.section(temperature, force), p.coil)

    def free_elongation(self, temperature):
        """Return the unloaded elongation (m) at temperature (degC): l^h - l*."""
        sin_h = love_heated_pitch_sine(self.untwist(temperature), self.params.coil)
        return self.params.fiber.length * sin_h - self.natural_length


class CstModel(KinetostaticModel):
    """Castigliano's second theorem, Eqs. (28)-(29), coefficients at the current alpha.

        F = K_cst(alpha) (y - A_cst(alpha) Delta theta_bar^h)
    """

    name = 'cst'

    def __init__(self, params):
        super().__init__(params)
        self._fused = cst_tension_function(params, self.natural_length)

    def _tension_at(self, elongation, temperature, force):
        # the stepper's hot path: the relations of tension_by_relations, fused
        return self._fused(elongation, temperature, force)

    def tension_by_relations(self, elongation, temperature, force):
        """Return F (N) of Eq. (29) at elongation (m), temperature (degC), moduli at force (N).

        The relations composed one function per equation, as the paper writes them;
        the stepper uses :func:`cst_tension_function`, the same arithmetic fused.
        """
        p = self.params
        alpha = pitch_angle_of_length(self.natural_length + elongation, p.fiber)
        section = self.section(temperature, force)
        radius = fixed_count_radius(alpha, p.coil)
        compliance = cst_compliance(radius, alpha, section, p.fiber)
        a_cst = cst_kinematic_coefficient(radius, alpha, p.fiber)
        return (elongation - a_cst * self.untwist(temperature)) / compliance


def cst_tension_function(params, natural):
    """Return f(y, T, F) -> tension (N) of Eq. (29), Eqs. (2), (4), (8)-(11), (24), (26) fused.

    ``y`` elongation (m), ``T`` temperature (degC), ``F`` the tension (N) at which
    the moduli of eq. (11) are taken. It performs the floating-point operations of
    :meth:`CstModel.tension_by_relations` in the same order (bit-for-bit equal;
    test_kinetostatics.py), with the constants of ``params`` read once: the central-
    difference stepper calls it once or twice per substep, and the calls through the
    readable per-equation functions cost about half of a simulation's time.
    """
    fiber, coil, moduli = params.fiber, params.coil, params.moduli
    length, twist_gain = fiber.length, fiber.untwist_gain * fiber.inserted_twist
    ambient = params.thermal.ambient_temperature
    c2, c1, c0 = fiber.gamma_coefficients
    gamma_ambient = radius_ratio(ambient, fiber)
    top = fiber.expansion_plateau_temperature  # degC, the rubbery plateau of (2)
    gamma_top, slope_top = (c2 * top + c1) * top + c0, 2.0 * c2 * top + c1
    cos_star, r_star, r_fiber = math.cos(coil.pitch_angle), coil.radius, fiber.radius
    constant = moduli.constant
    heated = fiber.heated_radius_in_section and not constant
    e0, g0, ef0 = moduli.youngs_modulus, moduli.shear_modulus, moduli.fiber_modulus
    polar = math.pi * r_fiber ** 4 / 2.0
    tau_scale = moduli.shear_modulus * polar
    tau_max = moduli.max_torsion_strain
    mu2, mu1, mu0 = moduli.load_coefficients
    softening_k, extra = moduli.fiber_softening, params.effects.extra_softening
    floor = moduli.fiber_modulus_floor * ef0

    def tension(elongation, temperature, force):
        alpha = math.asin(min(max((natural + elongation) / length, -1.0), 1.0))  # (26)
        gamma = ((c2 * temperature + c1) * temperature + c0 if temperature <= top
                 else gamma_top + slope_top * (temperature - top))  # (2)
        if constant:
            e, g = e0, g0
        else:  # (11)
            tau = min(max(force * r_fiber * cos_star / tau_scale, 0.0), tau_max)
            lam = (mu2 * tau + mu1) * tau + mu0
            modulus = max(ef0 - (softening_k * lam + extra) * (temperature - ambient), floor)
            ratio = modulus / ef0
            e, g = e0 * ratio, g0 * ratio
        r = r_fiber * gamma / gamma_ambient if heated else r_fiber  # (2)
        area = math.pi * r * r  # (8)
        second_moment = area * r * r / 4.0
        cos_a = math.cos(alpha)
        radius = r_star * cos_a / cos_star  # (24)
        cos2 = cos_a ** 2
        sin2 = 1.0 - cos2
        r2 = radius * radius
        compliance = length * (r2 * cos2 / (g * 2.0 * second_moment)  # (29)
                               + r2 * sin2 / (e * second_moment)
                               + cos2 / (g * area) + sin2 / (e * area))
        a_cst = length * radius * cos_a
        untwist = twist_gain * (gamma_ambient / gamma - 1.0)  # (4)
        return (elongation - a_cst * untwist) / compliance

    return tension


def contact_elongation(params):
    """Return the elongation (m) at which neighbouring coils touch (Sec. V-D1).

    The axial length cannot fall below l_t sin(alpha_min) (a hard stop, the
    reading adopted in docs/decisions.md, D8). With ``coil.contact`` off the measured
    stop is not applied, but the coils still cannot pass through each other: the
    stop is then where the turns touch, l_t sin(alpha_s) (limits.touching_pitch_angle).
    Returns -inf for a conical shape (its coils pass each other).
    """
    c = params.coil
    if c.shape != 'helix':
        return -math.inf
    angle = c.min_pitch_angle if c.contact else touching_pitch_angle(params.fiber, c)
    return params.fiber.length * math.sin(angle) - natural_length(params.fiber, c)


def static_elongation(model, load, temperature):
    """Return the static elongation y (m) under load (N) at temperature (degC).

    ``model`` is a KinetostaticModel; coil contact (Sec. V-D1) bounds y from below.
    Raises ThreadBreakError when the load exceeds the thread's strength.
    """
    y = model.equilibrium_elongation(load, temperature)
    return max(y, contact_elongation(model.params))


def loaded_length(model, load, temperature):
    """Return the static axial length l* + y (m) under load (N) at temperature (degC)."""
    return model.natural_length + static_elongation(model, load, temperature)


def fixed_coil_centreline(params, elongation, n_points):
    """Return the centreline (3, n) (m) of a uniform helix of length l* + elongation.

    Love's kinematics: the coil count N = l_t cos(alpha*) / (2 pi r*) (eq. (24)) and the
    fiber length are kept, sin(alpha) = l / l_t (eq. (26)), r = l_t cos(alpha) / (2 pi N).
    Clamp at the origin, descending along -Z, right-handed (the coiling angle decreases
    about +Z), as the rod model's centreline. A cheap display shape for cst and love.
    """
    fiber, coil = params.fiber, params.coil
    coils = fiber.length * math.cos(coil.pitch_angle) / (2.0 * math.pi * coil.radius)
    length = min(max(natural_length(fiber, coil) + elongation, 0.0), fiber.length)
    radius = math.sqrt(max(fiber.length ** 2 - length ** 2, 0.0)) / (2.0 * math.pi * coils)
    s = np.linspace(0.0, 1.0, int(n_points))
    phase = -2.0 * math.pi * coils * s
    return np.vstack((radius * np.cos(phase), radius * np.sin(phase), -length * s))
