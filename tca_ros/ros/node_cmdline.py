"""The ``tca`` node's command line: params files and ``-p`` rules checked before rcl reads them.

rcl answers a bad params file or rule with a multi-line error and a failed init;
``check_ros_arguments`` refuses it first with one line naming the file or rule, the
value and what is allowed, and ``init_quietly`` turns what rcl still refuses into
one ParameterError.
"""
import os
import sys
import tempfile

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.signals import SignalHandlerOptions
import yaml

from tca_ros.model.params_schema import ParameterError


def ros_argument_rules(argv):
    """Return [(flag, value)] of --params-file and -p rules in the --ros-args sections."""
    rules, inside, i = [], False, 0
    while i < len(argv):
        arg = argv[i]
        if arg == '--ros-args':
            inside = True
        elif arg == '--' and inside:
            inside = False
        elif inside and arg in ('--params-file', '-p', '--param') and i + 1 < len(argv):
            rules.append(('--params-file' if arg == '--params-file' else '-p', argv[i + 1]))
            i += 1
        i += 1
    return rules


def check_ros_arguments(argv):
    """Raise ParameterError (one line) for a params file or -p rule rcl would refuse."""
    for flag, value in ros_argument_rules(argv):
        if flag == '--params-file':
            check_params_file(value)
        elif ':=' not in value:
            raise ParameterError(f'-p {value!r}: a parameter rule is name:=value')
        else:
            _check_yaml_value(f'-p {value!r}', value.partition(':=')[2])


def check_params_file(path):
    """Raise ParameterError (one line) unless ``path`` is a ROS 2 params file rcl reads."""
    if not os.path.exists(path):
        raise ParameterError(f'--params-file {path}: no such file')
    if not os.path.isfile(path):
        raise ParameterError(f'--params-file {path}: not a regular file')
    try:
        with open(path, encoding='utf-8') as fh:
            text = fh.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise ParameterError(f'--params-file {path}: unreadable ({exc})') from None
    if '\0' in text:
        raise ParameterError(f'--params-file {path}: binary, not YAML')
    try:
        events = list(yaml.parse(text, Loader=yaml.SafeLoader))
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ParameterError(f'--params-file {path}: invalid YAML ({_yaml_reason(exc)})') \
            from None
    if any(isinstance(e, yaml.AliasEvent) for e in events):
        raise ParameterError(f'--params-file {path}: YAML aliases (*name) are not read by '
                             'ROS 2; write the values out')
    if document is None:
        return  # an empty file sets nothing, as rcl reads it
    if not isinstance(document, dict):
        raise ParameterError(f'--params-file {path}: the top level must be a mapping of '
                             "node names ('/**/tca:')")
    for node_key, body in document.items():
        params = body.get('ros__parameters') if isinstance(body, dict) else None
        if not isinstance(params, dict):
            raise ParameterError(
                f"--params-file {path}: node '{node_key}' needs a 'ros__parameters:' "
                'mapping (ROS 2 params-file layout)')
        _check_tree(path, params, '')


def _yaml_reason(exc):
    mark, problem = getattr(exc, 'problem_mark', None), getattr(exc, 'problem', None)
    if mark is None or problem is None:
        return ' '.join(str(exc).split())
    return f'line {mark.line + 1}, column {mark.column + 1}: {" ".join(problem.split())}'


def _check_tree(path, tree, prefix):
    for key, value in tree.items():
        name = f'{prefix}{key}'
        if isinstance(value, dict):
            _check_tree(path, value, name + '.')
        else:
            _check_leaf(f'--params-file {path}: parameter {name!r}', value)


def _check_yaml_value(where, text):
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        raise ParameterError(f'{where}: the value is not valid YAML') from None
    _check_leaf(where, value)


def _check_leaf(where, value):
    """Refuse what rcl's params parser refuses: null, nested or mixed-type lists."""
    if value is None:
        raise ParameterError(f'{where} = null: a parameter needs a value')
    if isinstance(value, dict):
        raise ParameterError(f'{where} = {value!r}: a mapping is not a parameter value')
    if isinstance(value, list):
        kinds = {_yaml_kind(v) for v in value}
        if None in kinds or len(kinds) > 1:
            raise ParameterError(f'{where} = {value!r}: a list must hold values of one type '
                                 '(all bool, all integer, all float or all string)')


def _yaml_kind(value):
    if isinstance(value, (bool, int, float, str)):
        return type(value)  # rcl refuses [1, 2.5]: write [1.0, 2.5]
    return None


def init_quietly(args):
    """rclpy.init, with rcl's multi-line refusal turned into one ParameterError.

    rcl logs 'Failed to parse global arguments' on stderr before raising; that line is
    held back and dropped when init fails, written through when it succeeds.
    """
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as held:
        os.dup2(held.fileno(), 2)
        try:
            # no rclpy signal handlers: node_spin.install_stop_handlers stops the spin
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        except RCLError as exc:
            reason = str(exc).replace('failed to initialize rcl: ', '').split(', at ')[0]
            raise ParameterError(' '.join(reason.split())) from None
        else:
            held.seek(0)
            os.write(saved, held.read())
        finally:
            os.dup2(saved, 2)
            os.close(saved)


def log_fatal(message):
    """Log one FATAL line (rclpy's format) whether or not rclpy is initialised."""
    try:
        rclpy.logging.get_logger('tca').fatal(message)
    except Exception:  # noqa: B902  logging itself unavailable: plain stderr
        print(f'[FATAL] [tca]: {message}', file=sys.stderr)
