"""What a maker knows of a TCA (MuscleSpec), and the checks that need no derivation.

A MuscleError names the MuscleSpec field, its value and unit and why it is refused,
in one line; the CLI renames the fields to its flags. muscle.py derives the params
file from a checked spec.
"""
from dataclasses import dataclass, field
import math
import re

from tca_ros.model.params_schema import MODELS, ParameterError, SPECS

COIL_TYPES = ('self_coiled', 'mandrel', 'conical')

#: Schema names a thread preset may set: the material, not the muscle.
MATERIAL_PARAMETERS = frozenset((
    'fiber.bias_angle_deg', 'fiber.volume_fraction', 'fiber.density',
    'fiber.specific_heat', 'fiber.gamma_coefficients', 'fiber.expansion_plateau_temperature',
    'thermal.convection_coefficient',
    'thermal.surface_factor', 'moduli.youngs_modulus', 'moduli.shear_modulus',
    'moduli.fiber_modulus', 'moduli.fiber_softening', 'moduli.load_coefficients',
    'moduli.max_torsion_strain', 'moduli.fiber_modulus_floor',
    'electrical.temperature_coefficient', 'electrical.strain_coefficient'))


#: Pa: the paper's twisted thread (d = 0.42 mm) breaks under 240 g (Sec. V-A)
DEFAULT_BREAKING_STRESS = 2.354 / (math.pi * 0.21e-3 ** 2)


@dataclass(frozen=True)
class ThreadPreset:
    """Material of a thread a maker names (config/threads/threads.yaml).

    A preset sets only material parameters of the schema (MATERIAL_PARAMETERS):
    ``params`` maps schema names (``fiber.density``) to values in schema units;
    ``resistance_per_length`` is in ohm/m (None if not conductive) and
    ``twist_diameter_product`` theta* d in rad. muscle.py combines it with the
    maker's geometry; tca_ros.params.thread_presets reads the presets file.
    """

    name: str
    description: str
    conductive: bool
    resistance_per_length: object
    twist_diameter_product: float
    params: dict = field(default_factory=dict)
    breaking_stress: float = DEFAULT_BREAKING_STRESS  # Pa, of the twisted thread's section


@dataclass(frozen=True)
class Derived:
    """One derived quantity: value, unit and how it was obtained."""

    value: float
    unit: str
    note: str


class MuscleError(ParameterError):
    """A described muscle cannot exist or is incompletely described.

    The message is one line, ``field = value unit: reason``; ``field`` names the
    MuscleSpec field (the CLI maps it to its flag).
    """

    def __init__(self, field_name, value, reason, unit=''):
        self.field = field_name
        self.value = value
        self.unit = unit
        self.reason = reason
        super().__init__(self._text(field_name))

    def _text(self, name, names=None):
        reason = self.reason
        for key in _FIELD_TOKEN.findall(reason):
            reason = reason.replace(f'<{key}>', (names or {}).get(key, key))
        if self.value is None:
            return f'{name}: {reason}'
        shown = f'{self.value:g}' if isinstance(self.value, float) else str(self.value)
        unit = f' {self.unit}' if self.unit and self.unit != '-' else ''
        return f'{name} = {shown}{unit}: {reason}'

    def renamed(self, names):
        """Return the message with fields shown by ``names`` ({field: flag}) where given."""
        return self._text(names.get(self.field, self.field), names)


_FIELD_TOKEN = re.compile(r'<([a-z_]+)>')


@dataclass(frozen=True)
class MuscleSpec:
    """What a maker knows of a TCA (SI units; angles in deg, ambient in degC).

    Exactly one of ``pitch_angle_deg`` and ``coils``, and of ``loaded_length`` and
    ``natural_length``. At most one of ``mandrel_diameter``, ``coil_diameter`` (mean,
    2 r*) and ``outer_diameter``. None means not given.
    """

    thread: str
    thread_diameter: float
    coil: str
    mandrel_diameter: float = None
    coil_diameter: float = None
    outer_diameter: float = None
    pitch_angle_deg: float = None
    coils: float = None
    loaded_length: float = None
    natural_length: float = None
    resistance: float = None
    break_force: float = None
    mass: float = 0.0
    ambient_degc: float = 25.0
    model: str = 'rod'
    min_pitch_angle_deg: float = None
    inserted_twist: float = None
    spiral_pitch: float = None
    cone_angle_deg: float = None


def check_spec(spec, presets):
    """Validate what does not depend on the derivation; return the thread preset."""
    if spec.thread not in presets:
        raise MuscleError('thread', spec.thread,
                          f'unknown preset (known: {", ".join(sorted(presets))})')
    if spec.coil is None:
        raise MuscleError('coil', None, f'required: one of {", ".join(COIL_TYPES)}')
    if spec.coil not in COIL_TYPES:
        raise MuscleError('coil', spec.coil, f'must be one of {", ".join(COIL_TYPES)}')
    if spec.model not in MODELS:
        raise MuscleError('model', spec.model, f'must be one of {", ".join(MODELS)}')
    check_positive(spec, 'thread_diameter', 'm')
    high = 2.0 * SPECS['fiber.radius'].high
    if spec.thread_diameter > high:
        raise MuscleError('thread_diameter', spec.thread_diameter,
                          f'above {high:g} m, the largest twisted thread the model takes', 'm')
    for name in ('mandrel_diameter', 'coil_diameter', 'outer_diameter', 'coils',
                 'loaded_length', 'natural_length', 'resistance', 'inserted_twist',
                 'break_force',
                 'spiral_pitch', 'pitch_angle_deg', 'cone_angle_deg'):
        if getattr(spec, name) is not None:
            check_positive(spec, name, SPEC_UNITS[name])
    if not (is_finite(spec.mass) and spec.mass >= 0.0):
        raise MuscleError('mass', spec.mass, 'must be a finite mass >= 0', 'kg')
    low, high = (SPECS['thermal.ambient_temperature_degc'].low,
                 SPECS['thermal.ambient_temperature_degc'].high)
    if not (is_finite(spec.ambient_degc) and low <= spec.ambient_degc <= high):
        raise MuscleError('ambient_degc', spec.ambient_degc,
                          f'must be in [{low:g}, {high:g}]', 'degC')
    if spec.loaded_length is not None and spec.mass == 0.0:
        raise MuscleError('mass', spec.mass, 'a <loaded_length> needs the hanging mass '
                          '(> 0) it was measured under', 'kg')
    if spec.min_pitch_angle_deg is not None and not (
            is_finite(spec.min_pitch_angle_deg) and 0.0 <= spec.min_pitch_angle_deg < 89.0):
        raise MuscleError('min_pitch_angle_deg', spec.min_pitch_angle_deg,
                          'must be in [0, 89)', 'deg')
    preset = presets[spec.thread]
    if spec.resistance is None and not preset.conductive:
        raise MuscleError('resistance', None, f'required: {spec.thread} is not conductive '
                          "(give the heater's resistance at ambient, ohm)")
    return preset


def check_positive(spec, name, unit):
    """Raise MuscleError unless the field ``name`` of ``spec`` is given, finite and > 0."""
    value = getattr(spec, name)
    if value is None:
        raise MuscleError(name, None, 'required')
    if not (is_finite(value) and value > 0.0):
        raise MuscleError(name, value, 'must be a finite value > 0', unit)


def is_finite(value):
    """Return True for a finite int or float (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) \
        and math.isfinite(value)


def check_exactly_one(spec, first, second):
    """Raise MuscleError unless exactly one of the fields ``first``, ``second`` is given."""
    a, b = getattr(spec, first), getattr(spec, second)
    if a is None and b is None:
        raise MuscleError(first, None, f'give exactly one of <{first}> and <{second}>')
    if a is not None and b is not None:
        raise MuscleError(second, b, f'give exactly one of <{first}> and <{second}> '
                          f'(also got <{first}> = {a:g})', SPEC_UNITS[second])


#: unit of each MuscleSpec field, for its messages
SPEC_UNITS = {'thread_diameter': 'm', 'mandrel_diameter': 'm', 'coil_diameter': 'm',
              'outer_diameter': 'm', 'pitch_angle_deg': 'deg', 'coils': '-',
              'loaded_length': 'm', 'natural_length': 'm', 'resistance': 'ohm',
              'break_force': 'N',
              'mass': 'kg', 'ambient_degc': 'degC', 'min_pitch_angle_deg': 'deg',
              'inserted_twist': 'rad/m', 'spiral_pitch': 'm', 'cone_angle_deg': 'deg'}
