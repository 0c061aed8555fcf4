"""Thread presets: the material of a thread a maker names, read from its file.

config/threads/threads.yaml holds one entry per thread; each becomes a ThreadPreset
(tca_ros.model.muscle_spec): material parameters of the schema only
(MATERIAL_PARAMETERS), plus the thread's resistance per length and its
twist-diameter product. tca_ros.model.muscle.describe_muscle combines a preset with
the maker's geometry.
"""
import os

import yaml

from tca_ros.model.muscle_spec import DEFAULT_BREAKING_STRESS, MATERIAL_PARAMETERS, \
    ThreadPreset
from tca_ros.model.params_schema import ParameterError
from tca_ros.params.config_search import config_dir
from tca_ros.params.files import flatten


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
