"""Parameters of the ``tca`` node: schema, validation, guarded services, start-up checks.

The node's own parameters (NODE_SCHEMA) sit beside the TCA schema of
tca_ros.model.params and are checked by the same ``check_value``. Everything here
turns bad input into one line naming the field, the value and what is allowed:

- ``validate_node_values`` and ``build_simulator``: cross-parameter rules and the
  model's own refusals (stability limit, a rod table the model cannot build);
- ``GuardedParameterService``: rclpy's parameter services, except that a request
  rclpy cannot convert (a type code outside ParameterType, NOT_SET) is refused with a
  reason instead of raising out of ``rclpy.spin``;
- the command line's params files and ``-p`` rules are checked in node_cmdline.py.
"""
import math

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.parameter import Parameter
from rclpy.parameter_service import ParameterService

from tca_ros.model.dynamics import StabilityError
from tca_ros.model.params import (check_value, ParameterError, ParamSpec, SCHEMA, SPECS,
                                  to_flat_dict)
from tca_ros.model.rigs import make_rig

#: Node parameters (beside the TCA SCHEMA); validated with the same check_value.
NODE_SCHEMA = (
    ParamSpec('physics_rate', 1000, 'Hz', 'Rate of the physics steps (dynamics (18), eq. (1)).',
              1, 100000),
    ParamSpec('publish_rate', 100.0, 'Hz', 'Rate of the state outputs (and of /clock ticks).',
              0.1, 10000.0),
    ParamSpec('shape_rate', 2.0, 'Hz', 'Rate of the shape Marker; 0 turns it off.', 0.0, 100.0),
    ParamSpec('shape_points', 1000, '-', 'Number of points of the shape Marker.', 2, 100000),
    ParamSpec('publish_clock', False, '-',
              'Own the time: step at real_time_factor and publish /clock.'),
    ParamSpec('real_time_factor', 1.0, '-',
              'Sim seconds per wall second with publish_clock; 0 = as fast as possible.',
              0.0, 1e6),
    ParamSpec('lockstep', False, '-',
              'With publish_clock: after each tick wait for one power or voltage command.'),
    ParamSpec('lockstep_timeout', 1.0, 's', 'Wall time a lockstep tick waits for a command.',
              1e-3, 3600.0),
    ParamSpec('command_timeout', 0.5, 's',
              'Power 0 after this long without a power or voltage command; 0 = never.',
              0.0, 1e6),
    ParamSpec('max_power', 5.0, 'W', 'Power limit of the driver; larger commands are clamped.',
              0.0, 1e4),
    ParamSpec('max_load', 10.0, 'N', 'Largest accepted external load; larger ones are clamped.',
              0.0, 1e4),
    ParamSpec('max_temperature', 180.0, 'degC', 'Overheat limit: an error log at each crossing.',
              -50.0, 2000.0),
    ParamSpec('melt_temperature', 250.0, 'degC',
              'Above this the muscle breaks (tension 0, resistance inf) until reset.',
              -50.0, 2000.0),
    ParamSpec('frame_id', 'tca', '-',
              'Frame of the temperature sensor; default prefixed by the namespace.'),
    ParamSpec('base_frame', 'tca_base', '-',
              'Frame of the clamp, for the shape Marker; default prefixed by the namespace.'),
    ParamSpec('joint_name', 'tca_joint', '-',
              'Joint name in joint_states; default prefixed by the namespace.'),
    ParamSpec('noise.displacement', 0.0, 'm', 'Std of the displacement noise.', 0.0, 1.0),
    ParamSpec('noise.temperature', 0.0, 'K', 'Std of the temperature noise.', 0.0, 100.0),
    ParamSpec('noise.resistance', 0.0, 'ohm', 'Std of the resistance noise.', 0.0, 1e6),
    ParamSpec('noise.seed', 0, '-', 'Seed of the measurement noise.', 0, 2 ** 31 - 1),
)
NODE_SPECS = {s.name: s for s in NODE_SCHEMA}
#: Names whose default is prefixed by the node's namespace (/finger1: finger1/tca_joint).
NAMESPACED = frozenset({'frame_id', 'base_frame', 'joint_name'})
# the time source and the rig (its topics) cannot change while running
READ_ONLY = frozenset({'publish_clock', 'rig.mode'})
#: Node parameters that require a new simulator when changed.
REBUILD = frozenset({'physics_rate', 'publish_rate'})
#: Prefixes of parameters rclpy declares itself (QoS overrides of the publishers).
RCLPY_PREFIXES = ('qos_overrides.',)
#: TCA parameters that shape the rod table (a table failure is blamed on one of them).
_MECHANICAL = ('fiber.', 'coil.', 'moduli.', 'thermal.ambient_temperature_degc',
               'effects.extra_softening')
_TYPE_NAMES = {getattr(ParameterType, n): n[len('PARAMETER_'):] for n in dir(ParameterType)
               if n.startswith('PARAMETER_')}


def namespaced_name(namespace, name):
    """Return ``name`` prefixed by a node namespace, tf2 style (no leading slash).

    ``namespaced_name('/finger1', 'tca_joint')`` is ``'finger1/tca_joint'``; in the
    root namespace the name is unchanged. Several muscles then publish distinct joint
    and frame names into a merged ``joint_states`` or one RViz.
    """
    prefix = namespace.strip('/')
    return f'{prefix}/{name}' if prefix else name


def validate_node_values(values):
    """Return the node parameters coerced, or raise ParameterError (one line).

    ``values`` maps NODE_SCHEMA names to values; cross-parameter rules included.
    """
    out = {name: check_value(NODE_SPECS[name], value) for name, value in values.items()}
    if out['publish_rate'] > out['physics_rate']:
        raise ParameterError(
            f"parameter 'publish_rate' = {out['publish_rate']:g}: must not exceed "
            f"physics_rate ({out['physics_rate']:g} Hz)")
    if out['shape_rate'] > out['publish_rate']:
        raise ParameterError(
            f"parameter 'shape_rate' = {out['shape_rate']:g}: must not exceed "
            f"publish_rate ({out['publish_rate']:g} Hz)")
    for name in sorted(NAMESPACED & set(out)):
        if not out[name].strip():
            raise ParameterError(f"parameter '{name}' = {out[name]!r}: must be a non-empty "
                                 'name (a frame or joint name that tf2 and RViz can use)')
    if out['melt_temperature'] <= out['max_temperature']:
        raise ParameterError(
            f"parameter 'melt_temperature' = {out['melt_temperature']:g}: must be above "
            f"max_temperature ({out['max_temperature']:g} degC)")
    return out


def physics_steps_per_tick(node_values):
    """Return the physics steps per publish period (physics_rate / publish_rate, >= 1)."""
    return max(1, round(node_values['physics_rate'] / node_values['publish_rate']))


def physics_dt(node_values):
    """Return the physics step (s): 1/physics_rate rounded to fill a publish period."""
    return 1.0 / (node_values['publish_rate'] * physics_steps_per_tick(node_values))


def build_simulator(params, node_values, kinetostatics=None, changed=()):
    """Return the simulator of params.rig.mode (make_rig), or raise ParameterError.

    Model failures and the explicit stability limit become one-line ParameterErrors
    naming the parameter: the one in ``changed`` (names just set) that shapes the
    model, else the first that differs from its default.
    """
    try:
        return make_rig(params, dt=physics_dt(node_values), kinetostatics=kinetostatics)
    except StabilityError as exc:
        raise ParameterError(f'{exc} (physics_rate = {node_values["physics_rate"]:g} Hz)') \
            from None
    except RuntimeError as exc:  # a rod table the exact helices cannot fill
        name, value = _blamed_parameter(params, changed)
        raise ParameterError(
            f"parameter '{name}' = {value!r}: {str(exc).splitlines()[0]}; the {params.model} "
            'model does not support this TCA (another value, or model cst or love)') from None
    except (ValueError, ArithmeticError) as exc:  # model range errors, a start state
        raise ParameterError(str(exc).splitlines()[0]) from None


def _blamed_parameter(params, changed):
    """Return (name, value) of the parameter a model failure is blamed on."""
    flat = to_flat_dict(params)
    mechanical = [n for n in flat if n.startswith(_MECHANICAL)]
    for name in changed:
        if name in mechanical:
            return name, flat[name]
    for name in mechanical:
        if flat[name] != SPECS[name].default:
            return name, flat[name]
    return 'model', params.model


def descriptor(spec, read_only=False, with_range=True):
    """Return the ParameterDescriptor of a schema entry (unit and range in the text)."""
    text = f'{spec.description} Unit: {spec.unit}.'
    finite = math.isfinite(spec.low) and math.isfinite(spec.high)
    if finite and _is_integer_spec(spec):
        text += f' Range: [{int(spec.low)}, {int(spec.high)}].'
    elif finite:
        text += f' Range: [{spec.low:g}, {spec.high:g}].'
    if spec.choices:
        text += f' One of: {", ".join(spec.choices)}.'
    # Dynamic typing lets a params file write 25 for 25.0; check_value does the typing.
    d = ParameterDescriptor(description=text, dynamic_typing=True, read_only=read_only)
    if with_range and finite and isinstance(spec.default, float):
        d.floating_point_range = [FloatingPointRange(from_value=float(spec.low),
                                                     to_value=float(spec.high))]
    if with_range and _is_integer_spec(spec):
        # Statically INTEGER once started (a double would retype it); the parameter
        # services refuse a fraction in one line before rclpy's type check.
        d.dynamic_typing, d.type = False, ParameterType.PARAMETER_INTEGER
        d.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high),
                                        step=1)]
    return d


def _is_integer_spec(spec):
    return isinstance(spec.default, int) and not isinstance(spec.default, bool)


#: Names of the INTEGER parameters (node and TCA schemas).
INTEGER_NAMES = frozenset(s.name for s in NODE_SCHEMA + SCHEMA if _is_integer_spec(s))
#: Names of the DOUBLE and DOUBLE_ARRAY parameters (node and TCA schemas).
DOUBLE_NAMES = frozenset(s.name for s in NODE_SCHEMA + SCHEMA if isinstance(s.default, float))
DOUBLE_ARRAY_NAMES = frozenset(s.name for s in NODE_SCHEMA + SCHEMA
                               if isinstance(s.default, list))


def numbers_as_declared_types(parameters):
    """Return the parameters with numbers in their parameter's declared type.

    A pre-set callback, so that no ``ros2 param set`` or params file retypes a
    parameter: an integral double of an INTEGER parameter becomes the integer
    (``physics_rate 2000.0``: 2000), an integer of a DOUBLE parameter the double
    (``max_load 8``: 8.0) and an integer array of a DOUBLE_ARRAY parameter a double
    array. Any other value passes unchanged, for the on-set callback to refuse in one
    line.
    """
    out = []
    for p in parameters:
        if p.name in INTEGER_NAMES and p.type_ == Parameter.Type.DOUBLE and \
                math.isfinite(p.value) and float(p.value).is_integer():
            p = Parameter(p.name, Parameter.Type.INTEGER, int(p.value))
        elif p.name in DOUBLE_NAMES and p.type_ == Parameter.Type.INTEGER:
            p = Parameter(p.name, Parameter.Type.DOUBLE, float(p.value))
        elif p.name in DOUBLE_ARRAY_NAMES and p.type_ == Parameter.Type.INTEGER_ARRAY:
            p = Parameter(p.name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in p.value])
        out.append(p)
    return out


def unknown_overrides(node):
    """Return the sorted (name, value) of overrides no declared parameter takes."""
    return sorted((name, p.value) for name, p in node._parameter_overrides.items()
                  if not node.has_parameter(name) and not name.startswith(RCLPY_PREFIXES))


def check_unknown_overrides(node):
    """Raise ParameterError (one line) when the start-up parameters name no parameter."""
    unknown = unknown_overrides(node)
    if unknown:
        name, value = unknown[0]
        raise ParameterError(
            f"parameter '{name}' = {value!r}: unknown parameter (known: see "
            'config/free_stroke.yaml and docs/node.md)')


# -- parameter services -------------------------------------------------------------
def parameter_from_msg(msg):
    """Return (Parameter, '') for a rcl_interfaces/Parameter message, or (None, reason).

    rclpy raises ValueError out of the executor on a type code outside ParameterType;
    NOT_SET would undeclare the parameter, which this node never allows.
    """
    code = msg.value.type
    if code not in _TYPE_NAMES:
        return None, (f"parameter '{msg.name}': type code {code} is not a ParameterType "
                      f'(allowed: {min(_TYPE_NAMES) + 1}-{max(_TYPE_NAMES)})')
    if code == ParameterType.PARAMETER_NOT_SET:
        return None, (f"parameter '{msg.name}': type NOT_SET would undeclare it; the tca "
                      'node keeps all its parameters')
    try:
        return Parameter.from_parameter_msg(msg), ''
    except (TypeError, ValueError) as exc:
        return None, f"parameter '{msg.name}': {exc}"


class GuardedParameterService(ParameterService):
    """rclpy's parameter services; a request they cannot convert is refused, not raised.

    Any exception left in a set request (a bug, not bad input) is logged and
    returned as the reason, so that no request can end ``rclpy.spin``.
    """

    def _set_parameters_callback(self, request, response):
        node = self._get_node()
        for msg in request.parameters:
            param, reason = parameter_from_msg(msg)
            response.results.append(
                _set_atomically(node, [param]) if param is not None
                else SetParametersResult(successful=False, reason=reason))
        return response

    def _set_parameters_atomically_callback(self, request, response):
        node = self._get_node()
        parsed = [parameter_from_msg(msg) for msg in request.parameters]
        reasons = [reason for param, reason in parsed if param is None]
        response.result = (SetParametersResult(successful=False, reason=reasons[0])
                           if reasons else _set_atomically(node, [p for p, _ in parsed]))
        return response

    def _get_parameters_callback(self, request, response):
        return _answer(super()._get_parameters_callback, request, response)

    def _describe_parameters_callback(self, request, response):
        return _answer(super()._describe_parameters_callback, request, response)

    def _get_parameter_types_callback(self, request, response):
        return _answer(super()._get_parameter_types_callback, request, response)

    def _list_parameters_callback(self, request, response):
        return _answer(super()._list_parameters_callback, request, response)


def _set_atomically(node, params):
    for p in numbers_as_declared_types(params):
        if p.name in INTEGER_NAMES and p.type_ != Parameter.Type.INTEGER:
            try:  # the schema's one line, not rclpy's 'Wrong parameter type'
                check_value(NODE_SPECS.get(p.name) or SPECS[p.name], p.value)
            except ParameterError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
    try:
        return node.set_parameters_atomically(params)
    except ParameterNotDeclaredException:
        unknown = [p.name for p in params if not node.has_parameter(p.name)]
        return SetParametersResult(successful=False, reason=(
            f'parameter {", ".join(map(repr, unknown))}: unknown parameter (the tca node '
            'declares its parameters at start-up; ros2 param list shows them)'))
    except Exception as exc:  # noqa: B902  a parameter request must never end the node
        reason = f'{type(exc).__name__}: {exc}'.splitlines()[0]
        node.get_logger().error(f'set_parameters refused after an internal error: {reason}',
                                throttle_duration_sec=1.0)
        return SetParametersResult(successful=False, reason=f'internal error: {reason}')


def _answer(callback, request, response):
    try:
        return callback(request, response)
    except Exception:  # noqa: B902  a malformed query gets an empty answer, not a crash
        return type(response)()
