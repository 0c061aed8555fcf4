"""Cross-parameter rules of a TcaParams that no single range can express.

params.from_flat_dict checks each value against its schema range (params_schema),
builds the typed sets and then calls :func:`check_consistency`: each rule raises
a ParameterError of one line naming the parameter, its value and what is allowed.
"""
import math

from tca_ros.model.effects import true_ambient
from tca_ros.model.heat_transfer import radiation_coefficient
from tca_ros.model.limits import parameter_limit_violation
from tca_ros.model.params_schema import ParameterError
from tca_ros.model.thermal import heat_capacity, surface_area, thermal_conductance


def check_consistency(p):
    """Cross-parameter rules that a single range cannot express.

    Each rule keeps the model finite: the fiber loses heat (eq. (1) has a finite time
    constant), a conical coil runs the rod model, the coil is wider than its fiber,
    creep stays within the coil's stretch; and physical
    (limits.parameter_limit_violation): coils that do not overlap, a load within the
    thread's strength, an untwist defined up to the melt.
    """
    _check_thermal(p)
    if p.coil.shape != 'helix' and p.model != 'rod':
        raise ParameterError(
            f"parameter 'model' = {p.model!r}: a {p.coil.shape} TCA needs the rod model "
            '(cst and love assume a uniform helix); set model to rod')
    if p.coil.shape == 'helix' and p.coil.radius < p.fiber.radius:
        raise ParameterError(
            f"parameter 'coil.radius' = {p.coil.radius:g}: must be at least fiber.radius "
            f'({p.fiber.radius:g} m); a coil narrower than its fiber crosses its own axis')
    stretch = p.fiber.length * (1.0 - math.sin(p.coil.pitch_angle))  # l_t - l*, eq. (26)
    creep = p.effects.creep_compliance * p.dynamics.load
    if creep >= stretch:
        raise ParameterError(
            f"parameter 'effects.creep_compliance' = {p.effects.creep_compliance:g}: creep "
            f'C F = {creep:.3g} m under dynamics.load {p.dynamics.load:g} N must stay below '
            f'the stretch of the coil l_t - l* = {stretch:.3g} m')
    if p.coil.contact and p.coil.shape == 'helix' and p.coil.min_pitch_angle >= p.coil.pitch_angle:
        raise ParameterError(
            f"parameter 'coil.min_pitch_angle_deg' = {math.degrees(p.coil.min_pitch_angle):g}: "
            f'must be below coil.pitch_angle_deg ({math.degrees(p.coil.pitch_angle):g})')
    c2, c1, c0 = p.fiber.gamma_coefficients
    t0 = p.thermal.ambient_temperature
    if c2 * t0 * t0 + c1 * t0 + c0 <= 0.0:
        raise ParameterError(
            f"parameter 'fiber.gamma_coefficients' = {list(p.fiber.gamma_coefficients)}: "
            f'Gamma(T0) must be positive')
    c = p.coil
    if c.crept_reference and c.unloaded_pitch_angle > c.coiled_pitch_angle:
        raise ParameterError(
            f"parameter 'coil.unloaded_pitch_angle_deg' = {math.degrees(c.unloaded_pitch_angle):g}"
            f': the crept reference needs it at most coil.pitch_angle_deg '
            f'({math.degrees(c.coiled_pitch_angle):g}): a load stretches the crept coil')
    violation = parameter_limit_violation(p)  # strength, melt range, overlapping coils
    if violation:
        raise ParameterError(violation)


def _check_thermal(p):
    """Refuse a fiber that cannot lose heat: h c_s A_0 > 0 (or radiation), tau finite."""
    fiber, thermal = p.fiber, p.thermal
    conductance = thermal_conductance(fiber, thermal)  # h c_s A_0 of eq. (1)
    capacity = heat_capacity(fiber)
    # Radiation linearised at ambient also cools: h = 0 with emissivity > 0 is a fiber in vacuum.
    conductance += radiation_coefficient(p.effects.emissivity, 0.0, true_ambient(
        thermal, p.effects)) * surface_area(fiber)
    if not (conductance > 0.0 and math.isfinite(capacity / conductance)):
        raise ParameterError(
            f"parameter 'thermal.convection_coefficient' = {thermal.convection_coefficient!r}: "
            f'h c_s A_0 = {conductance:.3g} W/K must be positive so that eq. (1) has a finite '
            'time constant (or effects.emissivity > 0)')
