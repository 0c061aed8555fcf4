"""One name per nominal parameter: the calibration's, in calibrate's and diagnose's outputs.

The diagnosis refits some nominal parameters as params-file entries
(candidates.RECALIBRATION); its outputs print them under the names and in the
units `tca_sim calibrate` prints (calibration.py's table), so that the same
quantity reads the same in both:

=============================== =========================== =====================
params-file entry               calibration name            value
=============================== =========================== =====================
fiber.untwist_gain              actuation_gain (-)          the same
thermal.delivered_power_ratio   delivered_power_ratio (-)   the same
dynamics.damping                damping (N s/m)             the same
fiber.specific_heat (J/(kg K))  heat_capacity (J/K)         m_t c_p: x fibre mass
=============================== =========================== =====================

Catalogue effects keep their dotted ``effects.*`` names. The module also says
which catalogue effects a calibrated parameter that left its description can
stand for (issue 25: what calibration absorbs is a finding).
"""
import math

from tca_ros.calibration.calibration import ROOM
from tca_ros.calibration.calibration_report import room_finding_line
from tca_ros.calibration.physical_priors import finding_causes_of, NO_EFFECT_MOVES_IT
from tca_ros.model.thermal import fiber_mass, heat_capacity, thermal_conductance

#: params-file entry -> (calibration name, unit); the value converts by :func:`nominal_value`
NOMINAL_NAMES = {
    'fiber.untwist_gain': ('actuation_gain', '-'),
    'thermal.delivered_power_ratio': ('delivered_power_ratio', '-'),
    'dynamics.damping': ('damping', 'N s/m'),
    'fiber.specific_heat': ('heat_capacity', 'J/K'),
}


def nominal_value(name, value, params):
    """Return (calibration name, value, unit) of a params-file entry, or None for others.

    ``params``: the TcaParams whose fibre gives the mass m_t (kg) that turns a
    specific heat (J/(kg K)) into the heat capacity m_t c_p (J/K).
    """
    if name not in NOMINAL_NAMES:
        return None
    label, unit = NOMINAL_NAMES[name]
    if name == 'fiber.specific_heat':
        value = value * fiber_mass(params.fiber)
    return label, float(value), unit


def format_nominal(name, value, params, sep='='):
    """Return 'actuation_gain=3.25' for a nominal entry, None for an effect's parameter."""
    named = nominal_value(name, value, params)
    if named is None:
        return None
    label, v, unit = named
    return f'{label}{sep}{v:.4g} {unit}'.rstrip(' -')


def calibrated_values(params, reference):
    """Return {calibration name: (value, unit)} of a params file, as calibrate wrote it.

    ``reference``: the description the stiffness scale is relative to (the
    config the calibration started from).
    """
    from tca_ros.calibration.calibration_parameters import expansion_zero
    moduli = reference.moduli.youngs_modulus
    out = {
        'heat_capacity': (heat_capacity(params.fiber), 'J/K'),
        'heat_loss': (thermal_conductance(params.fiber, params.thermal), 'W/K'),
        'actuation_gain': (params.fiber.untwist_gain, '-'),
        'stiffness_scale': (params.moduli.youngs_modulus / moduli if moduli > 0.0 else 1.0,
                            '-'),
        'damping': (params.dynamics.damping, 'N s/m'),
        'delivered_power_ratio': (params.thermal.delivered_power_ratio, '-'),
        'actuation_lag': (params.effects.second_thermal_lag, 's'),
        'expansion_zero_temperature': (expansion_zero(params.fiber), 'degC'),
        'expansion_plateau_temperature': (params.fiber.expansion_plateau_temperature, 'degC'),
    }
    return {k: (float(v), unit) for k, (v, unit) in out.items()}


def plausibility_lines(cal):
    """Return the summary lines of a Calibration's values: value, start, z, flags, findings.

    Names and values as `tca_sim calibrate` prints them; a value beyond
    physical_priors.SHIFT_Z prior spreads is a finding, said with the catalogue
    effects it can stand for (Calibration.findings, physical_priors.stands_for).
    """
    rows = cal.plausibility()
    lines = []
    for row in rows:
        ratio = f', {row.ratio:.2f} x physical' if row.ratio == row.ratio else ''
        flag = ' IMPLAUSIBLE' if row.implausible else ' SHIFTED' if row.shifted else ''
        lines.append(f'  {row.name:<28s}{row.value:>11.4g} {row.unit:<6s}(start '
                     f'{row.prior:.4g}, z {row.z:+.1f}{ratio}){flag}')
    lines += _derived_lines(cal)
    for name, z, effects in cal.findings():
        if name == ROOM:
            lines.append(room_finding_line(cal))
            continue
        row = next(r for r in rows if r.name == name)
        why = (finding_causes_of(cal, name, z, effects) if effects
               else f'a cause outside the catalogue ({NO_EFFECT_MOVES_IT})')
        lines.append(f'finding: {name} moved {z:+.1f} prior spreads from the description '
                     f'({row.prior:.4g} -> {row.value:.4g} {row.unit}): the muscle differs '
                     f'there, or the calibration absorbed an effect: {why}')
    for row in rows:
        if row.implausible:
            lines.append(f'finding: {row.name} is implausible ({row.value:.4g} {row.unit}, '
                         f'{row.ratio:.2f} x the physical reference): the calibration stands '
                         'in for physics the model lacks')
    return lines


def _derived_lines(cal):
    """Return the line of eq. (1)'s time constant and steady rise against the description's.

    A steady rise below the description's at an unchanged time constant is
    what a power loss does: the line says the fraction it would be.
    """
    derived = cal.derived()
    if not derived:
        return []
    tau, rise = derived['thermal_time_constant'], derived['steady_rise']
    t_ratio, r_ratio = tau.value / tau.prior, rise.value / rise.prior
    line = (f'  derived: thermal time constant {tau.value:.3g} s ({t_ratio:.2f} x the '
            f'description), steady rise {rise.value:.3g} K/W ({r_ratio:.2f} x)')
    if r_ratio < 1.0 and abs(math.log(t_ratio)) < 0.5 * abs(math.log(r_ratio)):
        line += (f'; a power loss of {100 * (1.0 - r_ratio):.0f} % (power_loss) would lower '
                 'the rise so and leave the time constant as described')
    elif r_ratio < 1.0 and t_ratio < 1.0:
        line += ('; the time constant fell with the rise: more heat is carried away than '
                 'described, not only less power delivered')
    return [line]
