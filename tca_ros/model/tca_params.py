"""TCA parameters: the typed, validated parameter set of one TCA (TcaParams).

Every parameter has a dotted name (``fiber.radius``), a unit, an allowed range and
a description in the schema (params_schema.py); from_flat_dict checks a
``{dotted_name: value}`` mapping against it, fills gaps with the schema defaults
(the paper's free-stroke TCA) and builds the typed groups below, and
to_flat_dict writes them back. The params files that describe a TCA (``config/``)
are read and written above the model, by tca_ros.params.files; the node declares
its ROS parameters from the same schema.
"""
from dataclasses import dataclass, field, fields, replace
import math

from tca_ros.model.params_checks import check_consistency
from tca_ros.model.params_schema import check_value, ParameterError, SCHEMA, SPECS
from tca_ros.model.reference_state import resolve_reference


@dataclass(frozen=True)
class FiberParams:
    """Twisted fiber (Table II). Lengths in m, angles in rad, SI throughout."""

    length: float
    radius: float
    bias_angle: float
    volume_fraction: float
    inserted_twist: float
    density: float
    specific_heat: float
    gamma_coefficients: tuple
    untwist_gain: float
    heated_radius_in_section: bool
    break_force: float
    expansion_plateau_temperature: float = 260.0  # degC: dGamma/dT held above it (G50)


@dataclass(frozen=True)
class CoilParams:
    """Coil reference state (Table III): radius (m), angles (rad), force scale (N).

    ``radius`` and ``pitch_angle`` are the reference the models use: the as-coiled
    ``coiled_radius`` and ``coiled_pitch_angle`` of the params file, or with
    ``crept_reference`` those crept under dynamics.load (reference_state.py).
    """

    shape: str
    coiled_radius: float
    coiled_pitch_angle: float
    spiral_pitch: float
    cone_angle: float
    contact: bool
    min_pitch_angle: float
    crept_reference: bool
    unloaded_pitch_angle: float
    crept_force_scale: float
    radius: float = math.nan  # set by reference_state.resolve_reference
    pitch_angle: float = math.nan


@dataclass(frozen=True)
class ThermalParams:
    """Thermal model, eq. (1): h (W/(m^2 K)), c_s (-), ambient (degC), P_in / P (-).

    ``initial_temperature_rise`` (K): T(0) - T_inf, the fibre's excess over ambient at
    the start of a simulation (0: at rest).
    """

    convection_coefficient: float
    surface_factor: float
    ambient_temperature: float
    delivered_power_ratio: float = 1.0
    initial_temperature_rise: float = 0.0


@dataclass(frozen=True)
class ModuliParams:
    """Moduli, eqs. (9)-(11): E0, G0, E_f0 (Pa), softening (Pa/K), lambda coefficients."""

    youngs_modulus: float
    shear_modulus: float
    fiber_modulus: float
    fiber_softening: float
    load_coefficients: tuple
    max_torsion_strain: float
    fiber_modulus_floor: float
    constant: bool


@dataclass(frozen=True)
class DynamicsParams:
    """Dynamics, eq. (18): mass (kg), load (N, tensile), damping b_t (N s/m)."""

    mass: float
    load: float
    damping: float


@dataclass(frozen=True)
class ElectricalParams:
    """Resistance R = R0 (1 + beta_T (T - T0) + beta_x x / l0): R0 (ohm), beta_T (1/K)."""

    resistance: float
    temperature_coefficient: float
    strain_coefficient: float


@dataclass(frozen=True)
class EffectParams:
    """Extensions of the nominal model; each is neutral at its default (see effects.py)."""

    creep_compliance: float = 0.0
    creep_time_constant: float = 30.0
    hysteresis_width: float = 0.0
    emissivity: float = 0.0
    convection_exponent: float = 0.0
    convection_reference_dt: float = 50.0
    extra_softening: float = 0.0
    sensor_lag: float = 0.0
    ambient_offset: float = 0.0
    power_loss_fraction: float = 0.0
    dead_time: float = 0.0
    second_thermal_lag: float = 0.0
    friction_force: float = 0.0
    static_friction_ratio: float = 1.0
    friction_start: float = 0.0


@dataclass(frozen=True)
class RigParams:
    """Load rig (docs/rigs.md): k_s (N/m), pretension (N), r_p (m), J (kg m^2), c (N m s/rad)."""

    mode: str = 'dead_weight'
    spring_stiffness: float = 20.0
    pretension: float = 0.05
    pulley_radius: float = 0.01
    joint_inertia: float = 1e-5
    joint_damping: float = 2e-4


@dataclass(frozen=True)
class UncertaintyParams:
    """How well the description knows each calibrated quantity: the calibration's prior.

    Relative uncertainties (-: the prior is x/÷ (1 + u)) except
    ``expansion_zero_temperature``, ``expansion_plateau_temperature`` and
    ``ambient_temperature`` (K) and ``actuation_lag`` (s).
    """

    heat_capacity: float = 0.3
    heat_loss: float = 0.6
    actuation_gain: float = 1.0
    stiffness_scale: float = 0.5
    damping: float = 9.0
    delivered_power_ratio: float = 0.25
    expansion_zero_temperature: float = 20.0
    actuation_lag: float = 5.0
    expansion_plateau_temperature: float = 40.0
    ambient_temperature: float = 2.0


@dataclass(frozen=True)
class TcaParams:
    """All parameters of one TCA, SI units (temperatures in degC)."""

    tca_type: str
    model: str
    fiber: FiberParams
    coil: CoilParams
    thermal: ThermalParams
    moduli: ModuliParams
    dynamics: DynamicsParams
    electrical: ElectricalParams
    effects: EffectParams = field(default_factory=EffectParams)
    source: str = ''
    rig: RigParams = field(default_factory=RigParams)
    uncertainty: UncertaintyParams = field(default_factory=UncertaintyParams)

    def with_values(self, **dotted):
        """Return a copy with dotted-name overrides, e.g. ``{'dynamics.mass': 0.05}``."""
        flat = to_flat_dict(self)
        for key, value in dotted.items():
            flat[key.replace('__', '.')] = value
        return from_flat_dict(flat, source=self.source)


_DEG = {'bias_angle_deg', 'pitch_angle_deg', 'cone_angle_deg', 'min_pitch_angle_deg',
        'unloaded_pitch_angle_deg'}
#: Schema names whose dataclass field is not the name without its unit suffix.
_FIELDS = {'coil.radius': 'coiled_radius', 'coil.pitch_angle_deg': 'coiled_pitch_angle'}
_GROUPS = {'fiber': FiberParams, 'coil': CoilParams, 'thermal': ThermalParams,
           'moduli': ModuliParams, 'dynamics': DynamicsParams,
           'electrical': ElectricalParams, 'effects': EffectParams, 'rig': RigParams,
           'uncertainty': UncertaintyParams}


def _field_name(key):
    if key in _DEG:
        return key[:-4]
    if key.endswith('_degc'):
        return key[:-5]
    return key


def _layout():
    """Return {group: [(dotted name, key, dataclass field)]} of SCHEMA, in schema order."""
    layout = {group: [] for group in _GROUPS}
    for spec in SCHEMA:
        head, _, key = spec.name.partition('.')
        if head in layout:
            layout[head].append((spec.name, key, _FIELDS.get(spec.name) or _field_name(key)))
    return layout


#: The schema's parameters of each group, read once (with_values runs per fit step).
_LAYOUT = _layout()


def muscle_at_rest(params):
    """Return (``params`` starting at rest, a header line saying so or '').

    A calibration or diagnosis fits ``thermal.initial_temperature_rise`` (K) of the
    record it saw; a params file written for the user describes the muscle, which
    the node and the CLI then start at rest.
    """
    rise = params.thermal.initial_temperature_rise
    if rise <= 0.0:
        return params, ''
    return (params.with_values(**{'thermal.initial_temperature_rise': 0.0}),
            f'\nthe record began {rise:.3g} K above ambient (fitted); written as '
            'thermal.initial_temperature_rise 0: the muscle at rest')


def from_flat_dict(values, source=''):
    """Build validated TcaParams from ``{dotted_name: value}``; defaults fill gaps.

    Raises
    ------
    ParameterError
        One line naming the first bad or unknown parameter, its value, what is allowed.
    """
    unknown = sorted(set(values) - set(SPECS))
    if unknown:
        raise ParameterError(
            f"parameter '{unknown[0]}' = {values[unknown[0]]!r}: unknown parameter "
            f'(known: see config/free_stroke.yaml)')
    checked = {s.name: check_value(s, values.get(s.name, s.default)) for s in SCHEMA}
    groups = {}
    for group, cls in _GROUPS.items():
        kwargs = {}
        for name, key, attribute in _LAYOUT[group]:
            value = checked[name]
            if key in _DEG:
                value = math.radians(value)
            if isinstance(value, list):
                value = tuple(value)
            kwargs[attribute] = value
        groups[group] = cls(**kwargs)
    groups['coil'] = resolve_reference(groups['coil'], groups['dynamics'].load)
    params = TcaParams(tca_type=checked['tca_type'], model=checked['model'],
                       source=source, **groups)
    check_consistency(params)
    return params


def to_flat_dict(params):
    """Return ``{dotted_name: value}`` in schema units (degrees, degC) for ``params``."""
    out = {'tca_type': params.tca_type, 'model': params.model}
    for group in _GROUPS:
        obj = getattr(params, group)
        for name, key, attribute in _LAYOUT[group]:
            value = getattr(obj, attribute)
            if key in _DEG:
                value = math.degrees(value)
            if isinstance(value, tuple):
                value = list(value)
            out[name] = value
    return out


def with_effects(params, **effects):
    """Return a copy of ``params`` with effect parameters replaced (SI names)."""
    return replace(params, effects=replace(params.effects, **effects))


def effect_field_names():
    """Return the field names of EffectParams."""
    return [f.name for f in fields(EffectParams)]
