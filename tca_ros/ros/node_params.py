"""Parameters of the ``tca`` node over rclpy: descriptors, types, guarded services.

The schema, the cross-parameter rules and ``build_simulator`` are plain Python in
tca_ros.ros.node_schema (re-exported here). Everything here turns bad input into one line
naming the field, the value and what is allowed:

- ``GuardedParameterService``: rclpy's parameter services, except that a request
  rclpy cannot convert (a type code outside ParameterType, NOT_SET) is refused with a
  reason instead of raising out of ``rclpy.spin``;
- the command line's params files and ``-p`` rules are checked in ros/node_cmdline.py.
"""
import math

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.parameter import Parameter
from rclpy.parameter_service import ParameterService

from tca_ros.model.params_schema import check_value, ParameterError, SCHEMA, SPECS
from tca_ros.model.tca_params import from_flat_dict
from tca_ros.ros.node_schema import (  # noqa: F401  (re-exported: the node's parameter API)
    build_simulator, NAMESPACED, namespaced_name, NODE_SCHEMA, NODE_SPECS, physics_dt,
    physics_steps_per_tick, READ_ONLY, REBUILD, validate_node_values)

#: Prefixes of parameters rclpy declares itself (QoS overrides of the publishers).
RCLPY_PREFIXES = ('qos_overrides.',)
_TYPE_NAMES = {getattr(ParameterType, n): n[len('PARAMETER_'):] for n in dir(ParameterType)
               if n.startswith('PARAMETER_')}


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


def declare_node_parameters(node):
    """Declare the schema's and the node's parameters; return (params, cfg, simulator).

    Each parameter is declared with its default (a namespaced default under the
    node's namespace), start-up overrides that name no parameter are refused, and
    every value is stored in its declared type before the descriptors get their
    ranges. A bad start-up value raises ParameterError with the schema's one-line
    message. Units: the schema's (SI, temperatures in degC).
    """
    all_specs = [(s, s.name in READ_ONLY) for s in SCHEMA + NODE_SCHEMA]
    for spec, _ in all_specs:
        default = spec.default if spec.name not in NAMESPACED else \
            namespaced_name(node.get_namespace(), spec.default)
        node.declare_parameter(spec.name, default, descriptor(spec, with_range=False))
    check_unknown_overrides(node)  # a misspelt name is refused, as tca_sim does
    params = from_flat_dict({s.name: node.get_parameter(s.name).value for s in SCHEMA},
                            source='ros parameters')
    cfg = validate_node_values(
        {s.name: node.get_parameter(s.name).value for s in NODE_SCHEMA})
    sim = build_simulator(params, cfg)
    # 1000.0 from a params file is stored as the INTEGER it names, 25 for a DOUBLE
    # as 25.0: every parameter keeps its declared type.
    node.set_parameters(numbers_as_declared_types(
        [node.get_parameter(spec.name) for spec, _ in all_specs]))
    # Ranges only now: a bad start-up value gets the schema's one-line message above.
    for spec, read_only in all_specs:
        node.set_descriptor(spec.name, descriptor(spec, read_only))
    return params, cfg, sim


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
