"""The calibration parameters: their priors and bounds, and where each acts in a params file.

What calibration.py fits (its module docstring has the table of names and
units), as engine.Parameters around a start TcaParams, and ``apply_calibration``,
which writes fitted values into a TcaParams. Used by the calibration, the
diagnosis and the realistic record generator alike.
"""
import math

import numpy as np

from tca_ros.calibration import engine
from tca_ros.calibration.physical_priors import ACTUATION_LAG_PRIOR, prior_spreads
from tca_ros.model.effects import CATALOGUE
from tca_ros.model.end_motion import critical_damping
from tca_ros.model.kinetostatics import static_elongation
from tca_ros.model.limits import MELT_TEMPERATURE_DEGC
from tca_ros.model.static_maps import make_statics
from tca_ros.model.thermal import fiber_mass, heat_capacity, surface_area, \
    thermal_conductance

DEFAULT_FIT = ('heat_capacity', 'heat_loss', 'actuation_gain', 'stiffness_scale',
               'damping', 'delivered_power_ratio', 'resistance',
               'resistance_temperature_coef', 'resistance_strain_coef')
#: physics a calibration adds when named in ``fit`` (or by ``--physics``): the curvature of
#: the stroke-temperature characteristic and an actuation lag (docs/calibration.md)
PHYSICS_FIT = ('expansion_zero_temperature', 'actuation_lag')
MIN_CURVATURE_LEVELS = 2  # power levels needed to fit the characteristic's curvature
#: prior standard deviation (K) of a record's initial temperature rise: nearly flat
#: over the 0-60 K a muscle keeps a minute or so after a heating
INITIAL_RISE_SPREAD = 30.0
INITIAL_RISE_MAX = 300.0  # K, the schema's bound of thermal.initial_temperature_rise
#: fitted when named in ``fit``: friction (a diagnosis effect else); the initial rise also
#: by default on one record whose logged temperature shows it beginning warm (starts_warm)
#: and the top of the characteristic's curvature, T_p (no held-out gain on the shared muscles:
#: their records leave it at its prior, docs/decisions.md G50)
OPTIONAL_FIT = ('friction_force', 'initial_temperature_rise',
                'expansion_plateau_temperature') + PHYSICS_FIT
#: catalogue effect parameters a calibration fits when named in ``fit`` (dotted names)
EFFECT_PARAMETERS = tuple(n for names in CATALOGUE.values() for n in names
                          if n.startswith('effects.'))
EFFECT_PRIOR_SPREAD = 10.0  # effect priors' standard deviation, x the parameter's range
#: calibrated damping at most this many times the critical damping of the hanging mass
#: (or 10x the start's, for a muscle known to be heavily damped): beyond it the fit
#: uses b_t / k as a lag of seconds, a thermal-like lag that is not viscous
#: (docs/calibration.md, "Damping")
MAX_DAMPING_RATIO = 10.0


def damping_bound(params, model=None):
    """Return the largest damping b_t (N s/m) a calibration may fit.

    MAX_DAMPING_RATIO times the critical damping of the hanging mass on the
    coil's stiffness at ambient under the start's load, or ten times the
    start's damping if that is larger; at least 1 N s/m.
    """
    crit = critical_damping(coil_stiffness(params, model), params.dynamics.mass)
    return max(MAX_DAMPING_RATIO * crit, 10.0 * params.dynamics.damping, 1.0)


def coil_stiffness(params, model=None):
    """Return the coil's axial stiffness k (N/m) at ambient under ``params``' load.

    A central difference of the static elongation; 0 where the statics fail.
    """
    statics = make_statics(params, model)
    load, ambient = params.dynamics.load, params.thermal.ambient_temperature
    step = max(1e-3 * abs(load), 1e-4)
    try:
        y0 = static_elongation(statics, max(load - step, 0.0), ambient)
        y1 = static_elongation(statics, load + step, ambient)
    except (ValueError, ArithmeticError):
        return 0.0
    return (load + step - max(load - step, 0.0)) / (y1 - y0) if y1 > y0 else 0.0


def calibration_priors(params, nominal_power, has_resistance, r0_measured=None,
                       supply='power', max_damping=1e3):
    """Return {name: engine.Parameter} around the start ``params``.

    The resistance law is fitted when the records carry resistance, and its
    coefficients also when a constant-voltage supply makes the power follow it.
    ``max_damping`` (N s/m): the damping's upper bound (:func:`damping_bound`).
    """
    conductance = thermal_conductance(params.fiber, params.thermal)
    capacity = heat_capacity(params.fiber)
    spread = prior_spreads(params)
    e = params.electrical
    out = [
        engine.Parameter('heat_capacity', 'J/K', capacity, capacity / 20.0, capacity * 20.0,
                         spread['heat_capacity'], description='m_t c_p, eq. (1)'),
        engine.Parameter('heat_loss', 'W/K', conductance, conductance / 20.0,
                         conductance * 20.0, spread['heat_loss'],
                         description='h c_s A_0, eq. (1)'),
        engine.Parameter('expansion_zero_temperature', 'degC', expansion_zero(params.fiber),
                         -200.0, params.thermal.ambient_temperature - 1.0,
                         spread['expansion_zero_temperature'], log=False,
                         description='where dGamma/dT of eq. (2) vanishes: the curvature '
                                     'of the stroke-temperature characteristic'),
        engine.Parameter('expansion_plateau_temperature', 'degC',
                         params.fiber.expansion_plateau_temperature,
                         params.thermal.ambient_temperature + 10.0, MELT_TEMPERATURE_DEGC,
                         spread['expansion_plateau_temperature'], log=False,
                         description='above it dGamma/dT of eq. (2) holds: the top of the '
                                     "thread's glass transition (G50)"),
        engine.Parameter('actuation_lag', 's',
                         max(params.effects.second_thermal_lag, ACTUATION_LAG_PRIOR), 0.0,
                         120.0, spread['actuation_lag'], log=False,
                         description='first-order lag of the actuating temperature'),
        engine.Parameter('actuation_gain', '-', params.fiber.untwist_gain, 0.02, 20.0,
                         spread['actuation_gain'], description='untwist gain on eq. (4)'),
        engine.Parameter('stiffness_scale', '-', 1.0, 0.05, 20.0, spread['stiffness_scale'],
                         description='E and G relative to the start config'),
        engine.Parameter('damping', 'N s/m',
                         min(max(params.dynamics.damping, 1e-3), max_damping), 1e-3,
                         max_damping, spread['damping'], description='b_t of eq. (18)'),
    ]
    out.append(engine.Parameter(
        'initial_temperature_rise', 'K', params.thermal.initial_temperature_rise, 0.0,
        INITIAL_RISE_MAX, INITIAL_RISE_SPREAD, log=False,
        description='T(0) - T_inf: a record that begins warm (0: at rest)'))
    if nominal_power:
        out.append(engine.Parameter(
            'delivered_power_ratio', '-', params.thermal.delivered_power_ratio, 0.2, 5.0,
            spread['delivered_power_ratio'],
            description='power heating the thread / logged power'))
    if has_resistance:
        r0 = r0_measured or e.resistance
        out.append(engine.Parameter('resistance', 'ohm', r0, r0 / 10.0, r0 * 10.0,
                                    math.log(1.5),
                                    description='R0 at ambient and loaded length'))
    # optional (--fit ...,friction_force): Coulomb friction of the load path (a pulley)
    out.append(engine.Parameter('friction_force', 'N',
                                max(params.effects.friction_force, 1e-3), 1e-5, 1.0,
                                math.log(10.0), description='effects.friction_force'))
    if has_resistance or supply == 'voltage':
        out += [
            engine.Parameter('resistance_temperature_coef', '1/K', e.temperature_coefficient,
                             -0.05, 0.05, 5e-3, log=False, description='beta_T'),
            engine.Parameter('resistance_strain_coef', '-', e.strain_coefficient, -10.0,
                             10.0, 1.0, log=False, description='beta_x'),
        ]
    return {p.name: p for p in out}


def effect_priors(names, params):
    """Return {dotted name: engine.Parameter} of the catalogue effect parameters in ``names``.

    Bounds and scale (linear or log) are the diagnosis's search space of each
    (candidates.effect_space); the prior is centred on the start ``params``' value
    (the middle screening start where that is the effect's neutral value, which a
    fit started at a bound could not leave) and EFFECT_PRIOR_SPREAD times the range
    wide: nearly flat, so the records decide.
    """
    from tca_ros.calibration.candidates import effect_space
    out = {}
    for name in names:
        if name not in EFFECT_PARAMETERS:
            continue
        space, starts = effect_space(name)
        section, field_name = name.split('.')
        value = float(getattr(getattr(params, section), field_name))
        if not space.low < value < space.high:
            value = starts[len(starts) // 2]
        spread = EFFECT_PRIOR_SPREAD * (math.log(space.high / space.low) if space.log
                                        else space.high - space.low)
        out[name] = engine.Parameter(name, space.unit, value, space.low, space.high, spread,
                                     log=space.log, description=f'catalogue effect {name}')
    return out


def apply_calibration(params, values):
    """Return ``params`` with calibration ``values`` ({name: value}) written in.

    The names are those of the module docstring; absent ones keep ``params``.
    """
    flat = {}
    fiber, thermal = params.fiber, params.thermal
    capacity, conductance = _heat(values, fiber, thermal)
    if capacity is not None:
        area = thermal.surface_factor * surface_area(fiber)
        flat['thermal.convection_coefficient'] = conductance / area
        flat['fiber.specific_heat'] = capacity / fiber_mass(fiber)
    if 'expansion_zero_temperature' in values:
        c2, _, c0 = fiber.gamma_coefficients
        flat['fiber.gamma_coefficients'] = [
            c2, -2.0 * c2 * values['expansion_zero_temperature'], c0]
    if 'actuation_lag' in values:
        flat['effects.second_thermal_lag'] = values['actuation_lag']
    if 'expansion_plateau_temperature' in values:
        flat['fiber.expansion_plateau_temperature'] = values['expansion_plateau_temperature']
    simple = {'actuation_gain': 'fiber.untwist_gain', 'damping': 'dynamics.damping',
              'friction_force': 'effects.friction_force',
              'delivered_power_ratio': 'thermal.delivered_power_ratio',
              'resistance': 'electrical.resistance',
              'resistance_temperature_coef': 'electrical.temperature_coefficient',
              'resistance_strain_coef': 'electrical.strain_coefficient',
              'initial_temperature_rise': 'thermal.initial_temperature_rise'}
    for name, dotted in simple.items():
        if name in values:
            flat[dotted] = values[name]
    flat.update({k: v for k, v in values.items() if k in EFFECT_PARAMETERS})
    if 'stiffness_scale' in values:
        s = values['stiffness_scale']
        flat['moduli.youngs_modulus'] = params.moduli.youngs_modulus * s
        flat['moduli.shear_modulus'] = params.moduli.shear_modulus * s
    return params.with_values(**flat) if flat else params


def _heat(values, fiber, thermal):
    """Return (m_t c_p J/K, h c_s A_0 W/K) of ``values``, or (None, None) if none is given.

    Either pair names them: heat_capacity and heat_loss, or (as realistic.py draws
    its truths) thermal_time_constant (s) and steady_rise (K/W).
    """
    names = ('heat_capacity', 'heat_loss', 'thermal_time_constant', 'steady_rise')
    if not any(n in values for n in names):
        return None, None
    conductance = thermal_conductance(fiber, thermal)
    capacity = heat_capacity(fiber)
    if 'steady_rise' in values:
        conductance = 1.0 / values['steady_rise']
    conductance = values.get('heat_loss', conductance)
    if 'thermal_time_constant' in values:
        capacity = values['thermal_time_constant'] * conductance
    capacity = values.get('heat_capacity', capacity)
    return capacity, conductance


def expansion_zero(fiber):
    """Return T_z (degC) where dGamma/dT = 2 c2 T + c1 of eq. (2) vanishes: -c1 / (2 c2).

    The radial expansion rate grows linearly from zero at T_z; the paper's fit puts
    T_z at 9.47 degC. A lower T_z is a less convex stroke-temperature characteristic.
    """
    c2, c1, _ = fiber.gamma_coefficients
    return -c1 / (2.0 * c2) if c2 > 0.0 else -200.0


def plateau_start(params, records):
    """Return where a fit of T_p (expansion_plateau_temperature, degC) starts.

    Halfway from ambient to the start's steady temperature at the records' largest
    power, or the description's T_p if lower. Above every temperature the records
    reach, T_p changes no prediction (G50): a fit started there could not leave it.
    """
    top = max(float(np.max(r.power)) for r in records)  # W
    rise = top * params.thermal.delivered_power_ratio / thermal_conductance(
        params.fiber, params.thermal)  # K
    return min(params.thermal.ambient_temperature + 0.5 * rise,
               params.fiber.expansion_plateau_temperature)


def physics_names(physics):
    """Return the PHYSICS_FIT names ``physics`` selects: True all, False none, or a collection."""
    if physics is True or physics is False:
        return PHYSICS_FIT if physics else ()
    unknown = [n for n in physics if n not in PHYSICS_FIT]
    if unknown:
        raise ValueError(f'physics {unknown[0]!r}: unknown; allowed: {", ".join(PHYSICS_FIT)}')
    return tuple(physics)


def default_fit(records, physics=True):
    """Return the names a calibration fits by default on ``records``.

    DEFAULT_FIT, and with ``physics`` (physics_names) the actuation lag and, when
    the records hold at least MIN_CURVATURE_LEVELS power levels, the curvature of
    the stroke-temperature characteristic (expansion_zero_temperature): one level
    shows the characteristic's shape only through a transient, and fitted there
    the curvature predicted other powers worse (docs/calibration.md, "Physics").
    """
    names = list(DEFAULT_FIT)
    chosen = physics_names(physics)
    if 'actuation_lag' in chosen:
        names.append('actuation_lag')
    levels = {round(float(np.max(r.power)), 2) for r in records}
    if 'expansion_zero_temperature' in chosen and len(levels) >= MIN_CURVATURE_LEVELS:
        names.append('expansion_zero_temperature')
    return names
