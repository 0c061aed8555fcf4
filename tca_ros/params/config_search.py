"""Where the shipped params files are: the ``config/`` directory and its names.

A params file is named by a path or by the name of a shipped file (``free_stroke``
for ``config/free_stroke.yaml``). The shipped files are found beside the source tree
(a checkout), in the virtual environment's ``share/tca_ros/config`` (pip) or in an
ament prefix's (colcon).
"""
import os

from tca_ros.model.params_schema import ParameterError


def config_dir():
    """Return the directory holding the shipped params files."""
    here = os.path.dirname(os.path.abspath(__file__))
    candidates = [os.path.join(here, '..', '..', 'config')]
    prefix = os.environ.get('VIRTUAL_ENV') or ''
    candidates.append(os.path.join(prefix, 'share', 'tca_ros', 'config'))
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix:
            candidates.append(os.path.join(prefix, 'share', 'tca_ros', 'config'))
    for c in candidates:
        if os.path.isdir(c):
            return os.path.normpath(c)
    return os.path.normpath(candidates[0])


def resolve_config(name_or_path):
    """Return the path of a params file given a path or a shipped name (``free_stroke``).

    A shipped name is a bare name (``free_stroke`` or ``free_stroke.yaml``): a path
    with a directory that does not exist is refused, never read as the shipped file
    of the same name (a mistyped ``mydir/free_stroke.yaml`` would silently run the
    shipped parameters instead of the user's).
    """
    if os.path.isfile(name_or_path):
        return name_or_path
    bare = os.path.basename(name_or_path) == name_or_path and '\\' not in name_or_path
    stem = os.path.splitext(name_or_path)[0]
    path = os.path.join(config_dir(), stem + '.yaml')
    if bare and os.path.isfile(path):
        return path
    raise ParameterError(
        f"config '{name_or_path}': no such file, and not a shipped name "
        f'({", ".join(shipped_configs())})')


def shipped_configs():
    """Return the names of the params files in ``config/``."""
    d = config_dir()
    if not os.path.isdir(d):
        return []
    return sorted(os.path.splitext(f)[0] for f in os.listdir(d) if f.endswith('.yaml'))
