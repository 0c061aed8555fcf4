"""The ``tca`` node's own parameters: schema, cross-parameter rules, the simulator they build.

Plain Python (no rclpy): the node's parameters (NODE_SCHEMA) sit beside the TCA schema
of tca_ros.model.params_schema and are checked by the same ``check_value``; everything here
turns bad input into one line naming the field, the value and what is allowed.
tca_ros.ros.node_params adds what rclpy needs (descriptors, guarded parameter services).
"""
from tca_ros.model.dynamics import StabilityError
from tca_ros.model.params_schema import check_value, ParameterError, ParamSpec, SPECS
from tca_ros.model.rigs import make_rig
from tca_ros.model.tca_params import to_flat_dict

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
#: TCA parameters that shape the rod table (a table failure is blamed on one of them).
_MECHANICAL = ('fiber.', 'coil.', 'moduli.', 'thermal.ambient_temperature_degc',
               'effects.extra_softening')


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
