"""Thread presets: the material of a thread a maker names (config/threads/threads.yaml).

A preset sets only material parameters of the schema (MATERIAL_PARAMETERS), plus
the thread's resistance per length and its twist-diameter product; muscle.py
combines it with the maker's geometry.
"""
from dataclasses import dataclass, field
import math
import os

import yaml

from tca_ros.model.params import config_dir, flatten, ParameterError

#: Schema names a thread preset may set: the material, not the muscle.
MATERIAL_PARAMETERS = frozenset((
    'fiber.bias_angle_deg', 'fiber.volume_fraction', 'fiber.density',
    'fiber.specific_heat', 'fiber.gamma_coefficients', 'thermal.convection_coefficient',
    'thermal.surface_factor', 'moduli.youngs_modulus', 'moduli.shear_modulus',
    'moduli.fiber_modulus', 'moduli.fiber_softening', 'moduli.load_coefficients',
    'moduli.max_torsion_strain', 'moduli.fiber_modulus_floor',
    'electrical.temperature_coefficient', 'electrical.strain_coefficient'))


#: Pa: the paper's twisted thread (d = 0.42 mm) breaks under 240 g (Sec. V-A)
DEFAULT_BREAKING_STRESS = 2.354 / (math.pi * 0.21e-3 ** 2)


@dataclass(frozen=True)
class ThreadPreset:
    """Material of a thread preset (config/threads/threads.yaml).

    ``params`` maps schema names (``fiber.density``) to values in schema units;
    ``resistance_per_length`` is in ohm/m (None if not conductive) and
    ``twist_diameter_product`` theta* d in rad.
    """

    name: str
    description: str
    conductive: bool
    resistance_per_length: object
    twist_diameter_product: float
    params: dict = field(default_factory=dict)
    breaking_stress: float = DEFAULT_BREAKING_STRESS  # Pa, of the twisted thread's section


def thread_presets_path():
    """Return the path of the thread presets file (config/threads/threads.yaml)."""
    return os.path.join(config_dir(), 'threads', 'threads.yaml')


def load_thread_presets(path=None):
    """Return ``{name: ThreadPreset}`` read from the presets file (YAML).

    Raises ParameterError (one line) if the file is unreadable or an entry sets a
    name that is not a material parameter of the schema.
    """
    path = path or thread_presets_path()
    try:
        with open(path, encoding='utf-8') as fh:
            document = yaml.safe_load(fh)
    except OSError as exc:
        raise ParameterError(f'{path}: cannot read thread presets ({exc.strerror})') from None
    except yaml.YAMLError as exc:
        raise ParameterError(f'{path}: invalid YAML ({str(exc).splitlines()[0]})') from None
    if not isinstance(document, dict):
        raise ParameterError(f'{path}: thread presets must be a mapping of names')
    presets = {}
    for name, entry in document.items():
        values = flatten((entry or {}).get('params') or {})
        bad = sorted(set(values) - MATERIAL_PARAMETERS)
        if bad:
            raise ParameterError(f"{path}: preset '{name}': '{bad[0]}' is not a material "
                                 'parameter of the schema')
        presets[name] = ThreadPreset(
            name=str(name), description=' '.join(str(entry.get('description', '')).split()),
            conductive=bool(entry.get('conductive', False)),
            resistance_per_length=entry.get('resistance_per_length'),
            twist_diameter_product=float(entry['twist_diameter_product']), params=values,
            breaking_stress=float(entry.get('breaking_stress', DEFAULT_BREAKING_STRESS)))
    return presets
