"""State of the ``tca`` node on ``/diagnostics`` (diagnostic_msgs/DiagnosticArray).

``/diagnostics`` is the absolute topic rqt_robot_monitor and diagnostic_aggregator read.
The node publishes one DiagnosticStatus for its muscle about once a second (wall
time) and at the first tick after a change of state:

=====  ================================================================================
level  when
=====  ================================================================================
OK     the muscle runs within its limits
WARN   overheated (above ``max_temperature``, until 1 K below); watchdog tripped (no
       command for ``command_timeout``: power 0)
ERROR  broken above ``melt_temperature`` or by a load above ``fiber.break_force`` (the
       cause in the message and in ``broken_cause``); physics failure (last finite outputs held);
       both until ``~/reset`` (a failure also until a parameter change)
STALE  the physics waits: for the first ``/clock`` message (``use_sim_time``), in
       lockstep for a controller, or for a conical rod table row being built
=====  ================================================================================

``muscle_status`` builds the status from a ``MuscleState`` snapshot and nothing else,
so it is tested without a node; ``DiagnosticsPublisher`` holds the publisher and timer.
"""
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from tca_ros.ros.node_episode import MuscleState  # noqa: F401  (re-exported: the snapshot)

DIAGNOSTICS_TOPIC = '/diagnostics'  # absolute: one topic for every muscle and tool
DIAGNOSTICS_PERIOD = 1.0  # s of wall time between repeats (the diagnostic_updater rate)
DIAGNOSTICS_DEPTH = 10  # messages kept for a late reader (reliable, keep last)
LEVEL_NAMES = {DiagnosticStatus.OK: 'OK', DiagnosticStatus.WARN: 'WARN',
               DiagnosticStatus.ERROR: 'ERROR', DiagnosticStatus.STALE: 'STALE'}


def status_level_and_message(state):
    """Return (level, message) of a MuscleState: the worst condition sets the level.

    Every condition that holds is named in the message, worst first, '; '-separated.
    """
    found = []
    if state.failure is not None:
        found.append((DiagnosticStatus.ERROR,
                      f'physics failed: {state.failure}; outputs held until ~/reset'))
    elif state.broken:
        cause = state.broken_cause or f'above melt_temperature {state.melt_temperature:g} degC'
        found.append((DiagnosticStatus.ERROR,
                      f'broken {cause} (tension 0, open circuit) until ~/reset'))
    if state.waiting:
        found.append((DiagnosticStatus.STALE, f'physics waiting for {state.waiting}'))
    if state.overheated:
        found.append((DiagnosticStatus.WARN,
                      f'overheated: {state.temperature:.1f} degC, max_temperature '
                      f'{state.max_temperature:g} degC'))
    if state.watchdog_tripped:
        found.append((DiagnosticStatus.WARN,
                      f'watchdog: no power or voltage command for {state.command_timeout:g} '
                      's, power 0'))
    if not found:
        return DiagnosticStatus.OK, 'ok'
    level = max(level for level, _ in found)  # OK < WARN < ERROR < STALE (bytes order)
    worst_first = sorted(found, key=lambda item: item[0], reverse=True)
    return level, '; '.join(text for _, text in worst_first)


def muscle_values(state):
    """Return the KeyValue list of a MuscleState (units in the keys)."""
    numbers = (('temperature (degC)', state.temperature), ('power (W)', state.power),
               ('max_temperature (degC)', state.max_temperature),
               ('melt_temperature (degC)', state.melt_temperature),
               ('displacement (m)', state.displacement), ('load (N)', state.load))
    flags = (('overheated', state.overheated), ('broken', state.broken),
             ('watchdog_tripped', state.watchdog_tripped))
    return ([KeyValue(key=k, value=f'{v:.6g}') for k, v in numbers]
            + [KeyValue(key=k, value='true' if v else 'false') for k, v in flags]
            + [KeyValue(key='broken_cause', value=state.broken_cause),
               KeyValue(key='physics_failure', value=state.failure or '')])


def muscle_status(state, name, hardware_id):
    """Return the DiagnosticStatus of one muscle.

    Parameters
    ----------
    state : MuscleState
        The node's snapshot.
    name : str
        Status name, ``'<node fully qualified name>: muscle'`` (``'/finger1/tca: muscle'``).
    hardware_id : str
        The muscle's namespace without slashes, or the node name in the root namespace.
    """
    level, message = status_level_and_message(state)
    return DiagnosticStatus(level=level, name=name, message=message,
                            hardware_id=hardware_id, values=muscle_values(state))


def status_name(fully_qualified_name):
    """Return the status name of the muscle of a node (``'/tca'``: ``'/tca: muscle'``)."""
    return f'{fully_qualified_name}: muscle'


def hardware_id(namespace, node_name):
    """Return the hardware id: the namespace (``'finger1'``), else the node name."""
    return namespace.strip('/') or node_name


class DiagnosticsPublisher:
    """Publish a node's muscle status at DIAGNOSTICS_PERIOD and when its flags change.

    ``snapshot()`` returns the MuscleState, ``stamp()`` the header stamp (a
    builtin_interfaces/Time, the node's time); ``wall_clock`` runs the timer, so the
    status (STALE included) goes out while the node time stands still.
    """

    def __init__(self, node, snapshot, stamp, wall_clock):
        self._node = node
        self._snapshot = snapshot
        self._stamp = stamp
        self._name = status_name(node.get_fully_qualified_name())
        self._hardware_id = hardware_id(node.get_namespace(), node.get_name())
        self._last_flags = None
        self._pub = node.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC,
                                          DIAGNOSTICS_DEPTH)
        node.create_timer(DIAGNOSTICS_PERIOD, self._on_timer, clock=wall_clock)

    def update(self, state=None):
        """Publish now if the flags changed since the last status (one call per tick).

        ``state`` is the MuscleState, by default a new snapshot.
        """
        state = state or self._snapshot()
        if state.flags() != self._last_flags:
            self.publish(state)

    def publish(self, state=None):
        """Publish the status of ``state`` (default: a new snapshot)."""
        state = state or self._snapshot()
        self._last_flags = state.flags()
        self._pub.publish(DiagnosticArray(
            header=Header(stamp=self._stamp()),
            status=[muscle_status(state, self._name, self._hardware_id)]))

    def _on_timer(self):
        try:
            self.publish()
        except Exception as exc:  # noqa: B902  a timer must never end the node
            if self._node.context.ok():  # not a stop signal racing the publish
                self._node.get_logger().error(
                    f'/diagnostics not published: {type(exc).__name__}: {exc}',
                    throttle_duration_sec=DIAGNOSTICS_PERIOD)


def level_name(level):
    """Return 'OK', 'WARN', 'ERROR' or 'STALE' for a DiagnosticStatus level."""
    return LEVEL_NAMES[level]
