"""The TCA parameter schema: every parameter's dotted name, default, unit and range.

One ParamSpec per parameter, in the order the node declares them (SCHEMA, by name
in SPECS), and the check of one value against its spec (check_value), whose
one-line error names the parameter, the value and what is allowed, with a hint
where YAML 1.1 (PyYAML, ``ros2 param set``) read a number as a string, told by
YAML 1.1's typing rules without reading YAML. tca_params.py builds the typed
parameter sets from it; tca_ros.params reads and writes the params files.
"""
import array
from dataclasses import dataclass
import math
import numbers
import re

import numpy as np

GRAVITY = 9.81  # m/s^2, g_r of Sec. III-C [1]

#: Node name the params files are keyed by (any namespace, ``/**/tca``).
NODE_NAME = 'tca'

TCA_TYPES = ('self_coiled', 'free_stroke', 'conical')
MODELS = ('rod', 'cst', 'love')
SHAPES = ('helix', 'conical')
#: Load modes of the free end (tca_ros.model.rigs, docs/rigs.md).
RIG_MODES = ('dead_weight', 'spring', 'isometric', 'antagonistic')


class ParameterError(ValueError):
    """A parameter value is outside its allowed set or range."""


@dataclass(frozen=True)
class ParamSpec:
    """Schema entry of one parameter (name, default, unit, range, meaning)."""

    name: str
    default: object
    unit: str
    description: str
    low: float = -math.inf
    high: float = math.inf
    choices: tuple = ()
    length: int = 0  # > 0 for a fixed-length float list


def _p(name, default, unit, description, low=-math.inf, high=math.inf, choices=(), length=0):
    return ParamSpec(name, default, unit, description, low, high, tuple(choices), length)


#: The parameter schema, in the order the node declares them.
SCHEMA = (
    _p('tca_type', 'free_stroke', '-', 'TCA kind (Table III).', choices=TCA_TYPES),
    _p('model', 'rod', '-', 'Coil kinetostatic model: Cosserat rod, CST or Love.',
       choices=MODELS),
    # Twisted fiber (Table II)
    _p('fiber.length', 0.175, 'm', 'Twisted fiber length l_t.', 1e-3, 10.0),
    _p('fiber.radius', 0.21e-3, 'm', 'Twisted fiber radius r_t* at T0.', 1e-6, 5e-3),
    _p('fiber.bias_angle_deg', 40.0, 'deg', 'Twisted fiber bias (pitch) angle alpha_t.',
       1.0, 89.0),
    _p('fiber.volume_fraction', 0.35, '-', 'Volume fraction V_f of eq. (9).', 0.01, 1.0),
    _p('fiber.inserted_twist', 4710.0, 'rad/m', 'Inserted twist per length theta*/l_t.',
       0.0, 1e5),
    _p('fiber.density', 1300.0, 'kg/m^3', 'Fiber density rho.', 100.0, 20000.0),
    _p('fiber.specific_heat', 1267.0, 'J/(kg K)', 'Specific heat c_p.', 10.0, 1e4),
    _p('fiber.gamma_coefficients', [3.54e-6, -6.705e-5, 1.0017], '1/degC^2, 1/degC, -',
       'Radius ratio Gamma(T) = c2 T^2 + c1 T + c0 (T in degC), [c2, c1, c0].', length=3),
    _p('fiber.expansion_plateau_temperature', 260.0, 'degC',
       'T_p: above it dGamma/dT of eq. (2) holds its value (Gamma linear in T); 260 (the '
       "melt): the paper's quadratic throughout; the thread presets: 160, its oven's top.",
       -60.0, 260.0),
    _p('fiber.untwist_gain', 1.0, '-',
       "Actuation gain: multiplies the untwist of eq. (4) (1 = the paper's law; "
       "calibrated for a user's muscle).", 0.01, 20.0),
    _p('fiber.heated_radius_in_section', True, '-',
       'Use the heated radius r_t Gamma(T)/Gamma(T0) in A, I and J (as the authors do).'),
    _p('fiber.break_force', 2.354, 'N',
       'Thread strength: a tension above it breaks the thread (Sec. V-A: heavier than '
       '240 g, i.e. 2.354 N, may break the thread).', 1e-4, 1e4),
    # Coil reference state (Table III)
    _p('coil.shape', 'helix', '-', 'Reference centreline: helix (12) or conical spiral (36).',
       choices=SHAPES),
    _p('coil.radius', 0.408e-3, 'm', 'Coil radius r* of the helix.', 1e-5, 0.1),
    # Steeper coils are nearly straight fibers, not TCAs: the rod model's y(F) is flat
    # to round-off at 89 deg, and at 80 deg the helix inverts on heating by 60 degC.
    _p('coil.pitch_angle_deg', 22.42, 'deg', 'Coil pitch angle alpha* of the helix.',
       0.5, 60.0),
    _p('coil.spiral_pitch', 10.6e-3, 'm', 'Conical spiral pitch p_c (a = 2 pi / p_c).',
       1e-4, 1.0),
    _p('coil.cone_angle_deg', 12.0, 'deg', 'Conical spiral cone angle (b = tan(angle/2)).',
       0.1, 170.0),
    _p('coil.contact', True, '-', 'Stop contraction when neighbouring coils touch.'),
    _p('coil.min_pitch_angle_deg', 12.0, 'deg',
       'Pitch angle alpha_min at which coils touch (Sec. V-D1).', 0.0, 89.0),
    _p('coil.crept_reference', False, '-',
       'Reference crept under dynamics.load (Sec. V-D1): alpha*, r* follow the law of '
       "reference_state.py; false: Table III's alpha*, r* for every load."),
    _p('coil.unloaded_pitch_angle_deg', 15.0, 'deg',
       "Crept reference: rest pitch angle a_0 crept without load (authors' code: 15 deg).",
       0.5, 60.0),
    _p('coil.crept_force_scale', 0.24, 'N',
       'Crept reference: load scale F_c of sin a* = sin a_c - (sin a_c - sin a_0) '
       "exp(-F/F_c) (0.24 N fits the authors' 15/16/20/22 deg at 0/2/30/60 g to 0.43 deg).",
       1e-4, 100.0),
    # Thermal model, eq. (1)
    _p('thermal.convection_coefficient', 23.0, 'W/(m^2 K)', 'Natural convection h.',
       0.0, 1e4),
    _p('thermal.surface_factor', 2.5, '-', 'Surface roughness factor c_s.', 0.1, 100.0),
    _p('thermal.ambient_temperature_degc', 25.0, 'degC', 'Ambient T_inf = T0.',
       -50.0, 100.0),
    _p('thermal.delivered_power_ratio', 1.0, '-',
       'P_in of eq. (1) over the logged or commanded power (1 = as logged; calibrated '
       'when a record gives nominal power).', 0.05, 5.0),
    _p('thermal.initial_temperature_rise', 0.0, 'K',
       'Fibre temperature above ambient at the start (t = 0 of a simulation, a node '
       'reset): 0 starts at rest; a record that begins before the muscle has cooled '
       'has it above 0 (the diagnosis fits it per record).', 0.0, 300.0),
    # Moduli, eqs. (9)-(11)
    _p('moduli.youngs_modulus', 1.2e9, 'Pa', 'Measured E at T0, no load (scales eq. (9)).',
       1e6, 1e12),
    _p('moduli.shear_modulus', 0.22e9, 'Pa', 'Measured G at T0, no load (scales eq. (10)).',
       1e6, 1e12),
    _p('moduli.fiber_modulus', 3.9e9, 'Pa', 'Monofilament modulus E_f0 at T0.', 1e6, 1e12),
    _p('moduli.fiber_softening', 1.1e6, 'Pa/K', 'Fall of E_f per kelvin (eq. (11)).',
       0.0, 1e9),
    _p('moduli.load_coefficients', [3.24e-4, -0.027, 1.0], '-',
       'lambda(tau) = mu2 tau^2 + mu1 tau + mu0 of eq. (11), [mu2, mu1, mu0].', length=3),
    _p('moduli.max_torsion_strain', 171.0, '1/m', 'Calibrated range of tau in eq. (11).',
       0.0, 1e5),
    _p('moduli.fiber_modulus_floor', 0.1, '-', 'Lower bound of E_f / E_f0.', 1e-3, 1.0),
    _p('moduli.constant', False, '-', 'Use constant E and G (no T or load dependence).'),
    # Dynamics, eq. (18)
    _p('dynamics.mass', 0.03, 'kg', 'Moving mass m at the free end.', 0.0, 1e3),
    _p('dynamics.load', 0.2943, 'N', 'External tensile force on the free end at start.',
       0.0, 1e3),
    _p('dynamics.damping', 0.5, 'N s/m', 'Damping coefficient b_t.', 0.0, 1e4),
    # Electrical self-sensing
    _p('electrical.resistance', 25.0, 'ohm', 'Resistance R0 at T0 and loaded length.',
       1e-3, 1e6),
    _p('electrical.temperature_coefficient', -1.0e-3, '1/K', 'beta_T of R(T, x).',
       -0.1, 0.1),
    _p('electrical.strain_coefficient', -0.2, '-', 'beta_x of R(T, x) (x / l0).', -10.0, 10.0),
    # Model extensions (all neutral by default); see tca_ros.model.effects
    _p('effects.creep_compliance', 0.0, 'm/N', 'Creep: Kelvin-Voigt compliance.', 0.0, 10.0),
    _p('effects.creep_time_constant', 30.0, 's', 'Creep: retardation time.', 1e-2, 1e6),
    _p('effects.hysteresis_width', 0.0, 'K', 'Hysteresis: play width on temperature.',
       0.0, 100.0),
    _p('effects.emissivity', 0.0, '-', 'Radiation: emissivity of the fiber surface.',
       0.0, 1.0),
    _p('effects.convection_exponent', 0.0, '-',
       'Nonlinear convection: h (|T - T_inf| / dT_ref)^n.', 0.0, 1.0),
    _p('effects.convection_reference_dt', 50.0, 'K', 'Nonlinear convection: dT_ref.',
       1.0, 1000.0),
    _p('effects.extra_softening', 0.0, 'Pa/K', 'Modulus softening: added fall of E_f.',
       0.0, 1e8),
    _p('effects.sensor_lag', 0.0, 's', 'Sensor lag: displacement sensor time constant.',
       0.0, 100.0),
    _p('effects.ambient_offset', 0.0, 'K', 'Ambient offset: true minus nominal ambient.',
       -50.0, 50.0),
    _p('effects.power_loss_fraction', 0.0, '-', 'Power loss: fraction not heating the fiber.',
       0.0, 0.99),
    _p('effects.dead_time', 0.0, 's', 'Dead time: delay of the drive before power heats.',
       0.0, 30.0),
    _p('effects.second_thermal_lag', 0.0, 's',
       'Second thermal lag: time constant between the heated and the actuating fiber.',
       0.0, 300.0),
    _p('effects.friction_force', 0.0, 'N',
       'Friction: Coulomb (kinetic) force opposing the motion of the free end.', 0.0, 100.0),
    _p('effects.static_friction_ratio', 1.0, '-',
       'Friction: static over kinetic force (> 1: stick-slip jumps).', 1.0, 10.0),
    _p('effects.friction_start', 0.0, '-',
       'Friction: where in its static band the free end starts (-1: its shortened edge, '
       'held by F_s against contraction; 0: at its equilibrium; 1: its stretched edge).',
       -1.0, 1.0),
    # Load rig of the free end (tca_ros.model.rigs, docs/rigs.md)
    _p('rig.mode', 'dead_weight', '-',
       'Load on the free end: dead_weight (eq. (18) as printed), spring (in series), '
       'isometric (held at its length), antagonistic (two muscles on a pulley joint).',
       choices=RIG_MODES),
    _p('rig.spring_stiffness', 20.0, 'N/m', 'Spring rig: stiffness k_s of the series spring.',
       0.0, 1e6),
    _p('rig.pretension', 0.05, 'N',
       'Spring, isometric and antagonistic rigs: tension at the reference state (ambient).',
       0.0, 1e3),
    _p('rig.pulley_radius', 0.01, 'm', 'Antagonistic rig: pulley radius r_p of the joint.',
       1e-4, 1.0),
    _p('rig.joint_inertia', 1e-5, 'kg m^2', 'Antagonistic rig: moment of inertia J of the joint.',
       1e-9, 1e3),
    _p('rig.joint_damping', 2e-4, 'N m s/rad', 'Antagonistic rig: viscous damping c of the joint.',
       0.0, 1e3),
    # How well the description knows each calibrated quantity (docs/calibration.md): the
    # prior of a calibration. Relative (x/÷ 1 + u) unless a unit is given; measured about
    # 0.05, estimated 0.3, guessed 1. A calibrated value beyond 2 of these is a finding.
    _p('uncertainty.heat_capacity', 0.3, '-',
       'Relative uncertainty of m_t c_p (thread mass and c_p known to about 15 % each).',
       1e-3, 100.0),
    _p('uncertainty.heat_loss', 0.6, '-',
       'Relative uncertainty of h c_s A_0 (a still-air correlation).', 1e-3, 100.0),
    _p('uncertainty.actuation_gain', 1.0, '-',
       "Relative uncertainty of the untwist gain (the paper's law on another thread).",
       1e-3, 100.0),
    _p('uncertainty.stiffness_scale', 0.5, '-',
       "Relative uncertainty of the moduli E, G (the preset's).", 1e-3, 100.0),
    _p('uncertainty.damping', 9.0, '-', 'Relative uncertainty of b_t (not known).',
       1e-3, 1000.0),
    _p('uncertainty.delivered_power_ratio', 0.25, '-',
       'Relative uncertainty of the power heating the thread per logged watt.', 1e-3, 100.0),
    _p('uncertainty.expansion_zero_temperature', 20.0, 'K',
       'Uncertainty of T_z, where dGamma/dT of eq. (2) vanishes (the curvature).',
       1e-3, 200.0),
    _p('uncertainty.actuation_lag', 5.0, 's',
       'Uncertainty of the lag of the actuating temperature.', 1e-3, 600.0),
    _p('uncertainty.expansion_plateau_temperature', 40.0, 'K',
       'Uncertainty of T_p, above which dGamma/dT of eq. (2) holds (the rubbery plateau).',
       1e-3, 400.0),
    _p('uncertainty.ambient_temperature', 2.0, 'K',
       "Uncertainty of the room's temperature T_inf (a wall thermostat's); an ambient "
       'offset within 2 of these is the description, not an effect.', 1e-3, 100.0),
)

SPECS = {s.name: s for s in SCHEMA}


def check_value(spec, value):
    """Return ``value`` coerced to the spec's type, or raise ParameterError.

    The message is one line naming the parameter, the value and what is allowed.
    """
    default = spec.default
    if isinstance(default, bool):
        if isinstance(value, bool):
            return value
        raise ParameterError(f"parameter '{spec.name}' = {value!r}: must be true or false")
    if isinstance(default, str):
        if isinstance(value, str) and (not spec.choices or value in spec.choices):
            return value
        raise ParameterError(
            f"parameter '{spec.name}' = {value!r}: must be one of {', '.join(spec.choices)}")
    if isinstance(default, list):
        # A ROS double array arrives as array.array('d'), a numpy array from Python callers.
        items = list(value) if _is_sequence(value) else None
        ok = (items is not None and len(items) == spec.length
              and all(_is_real(v) and math.isfinite(v) for v in items))
        if not ok:
            shown = items if items is not None else (
                value.tolist() if isinstance(value, np.ndarray) else value)
            raise ParameterError(
                f"parameter '{spec.name}' = {shown!r}{_string_given(value, 'a list')}: "
                f'must be a list of {spec.length} finite numbers ({spec.unit})'
                f'{_yaml11_hint(value)}')
        return [float(v) for v in items]
    if isinstance(default, int):
        # An integral double (1000.0 in a params file) is taken as the integer it names.
        if _is_real(value) and math.isfinite(value) and float(value).is_integer() and \
                spec.low <= value <= spec.high:
            return int(value)
        unit = '' if spec.unit == '-' else f' {spec.unit}'
        raise ParameterError(
            f"parameter '{spec.name}' = {value!r}{_string_given(value)}: must be an "
            f'integer in [{int(spec.low)}, {int(spec.high)}]{unit}{_yaml11_hint(value)}')
    if not _is_real(value) or not math.isfinite(value) or not (
            spec.low <= value <= spec.high):
        raise ParameterError(
            f"parameter '{spec.name}' = {value!r}{_string_given(value)}: must be a "
            f'finite number in [{spec.low:g}, {spec.high:g}] {spec.unit}{_yaml11_hint(value)}')
    return float(value)


#: A number written with an exponent but without a decimal point or exponent sign.
_EXPONENT_NUMBER = re.compile(r'[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)[eE][-+]?[0-9]+')


def _string_given(value, wanted='a number'):
    """Return ' (a string, not <wanted>)' for a str value, else ''."""
    return f' (a string, not {wanted})' if isinstance(value, str) else ''


def _yaml11_hint(value):
    """Return how to write a number YAML 1.1 read as a string (or '').

    YAML 1.1 (PyYAML: ``ros2 param set``, ``ros2 param load`` and tca_sim's config
    reader) takes a float only with a decimal point and a signed exponent: ``1e-9``
    and ``1.0e9`` are strings, ``1.0e-9`` and ``1.0e+9`` numbers.
    """
    if not isinstance(value, str):
        return ''
    for token in _EXPONENT_NUMBER.findall(value):
        if yaml11_number_type(token) is None:
            mantissa, exponent = re.split('[eE]', token)
            mantissa += '' if '.' in mantissa else '.0'
            exponent = exponent if exponent[0] in '+-' else '+' + exponent
            return (f' (YAML 1.1, as ros2 param set reads it, takes {token} for a string: '
                    f'write {mantissa}e{exponent})')
    flow = _FLOW_SEQUENCE.fullmatch(value)
    items = [item.strip() for item in flow.group(1).split(',')] if flow else []
    if items and not items[-1] and len(items) > 1:
        items.pop()  # a trailing comma ends a flow sequence
    kinds = {yaml11_number_type(item) for item in items}
    if kinds == {int, float}:  # ros2 param set sends a mixed list as one string
        return (' (ros2 param set sends a list mixing integers and floats as a string: '
                'write the integers as floats, 1 as 1.0)')
    return ''


#: Plain scalars YAML 1.1 types as int: decimal, octal, hexadecimal, binary, base 60.
_YAML11_INT = re.compile(r'[-+]?(?:0b[01_]+|0x[0-9a-fA-F_]+|0[0-7_]+|0'
                         r'|[1-9][0-9_]*(?::[0-5]?[0-9])*)')
#: Plain scalars YAML 1.1 types as float: a point is needed, and an exponent its sign
#: (a leading point takes no sign); base 60; infinities and NaN.
_YAML11_FLOAT = re.compile(r'[-+]?[0-9][0-9_]*\.[0-9_]*(?:[eE][-+][0-9]+)?'
                           r'|\.[0-9][0-9_]*(?:[eE][-+][0-9]+)?'
                           r'|[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+\.[0-9_]*'
                           r'|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)')
#: A one-level flow sequence of plain scalars, ``[a, b, c]``, with an optional comment.
_FLOW_SEQUENCE = re.compile(r'\s*\[([^\[\]{}\'"]*)\]\s*(?:#.*)?', re.S)


def yaml11_number_type(text):
    """Return int or float as YAML 1.1 types the plain scalar ``text``, else None.

    The typing rules of YAML 1.1, the version PyYAML and ``ros2 param set`` read,
    so that the schema explains a value read as a string without reading YAML.
    """
    if _YAML11_FLOAT.fullmatch(text):
        return float
    if _YAML11_INT.fullmatch(text):
        return int
    return None


def _is_real(value):
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _is_sequence(value):
    """Return True for a list-like value: list, tuple, array.array, 1-D ndarray."""
    if isinstance(value, np.ndarray):
        return value.ndim == 1
    return isinstance(value, (list, tuple, array.array))
