"""ROS 2 node ``tca_pid``: an example PID controller of the TCA's displacement.

Reads ``displacement_setpoint`` (std_msgs/Float64, m) and the feedback ``joint_states``
(position = displacement, m, stamped; best effort) of ``tca_node``; publishes ``power_cmd``
(std_msgs/Float64, W) once per feedback message. The sample time is taken from the
feedback stamps, so the loop is the same under wall time, ``use_sim_time`` and the
simulator's lockstep ``/clock``, and two runs with the same inputs give the same output.

    u = kp e + ki integral(e) - kd d(y_f)/dt + u_ff,   0 <= u <= max_power

with e = setpoint - y, the derivative on the filtered measurement y_f (no kick on a
setpoint step), and conditional integration for anti-windup: the integral is not
advanced while the output is saturated in the direction the error pushes it.
"""
import math

from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, SetParametersResult
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from tca_ros.ros.node_params import namespaced_name
from tca_ros.ros.node_spin import install_stop_handlers, spin_resiliently

COMMAND_QOS = QoSProfile(depth=10)
# Best effort: the node's reliable writer then sends no heartbeats to be acknowledged,
# which cost each process a wake-up of its DDS event thread per state (lockstep:
# docs/node_figures.md); one state is in flight at a time, on the same host.
FEEDBACK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
SETPOINT_QOS = QoSProfile(depth=10)

MAX_SAMPLE_TIME = 1.0  # s; a longer gap between feedback stamps restarts the integrator
REFERENCE_KEEP = 1000  # stamped references kept for states still to come
MATCH_WAIT = 2.0  # s of wall time the first command waits for the simulator to be matched

#: (name, default, unit, description, low, high); gains tuned on the free-stroke TCA.
PARAMETERS = (
    ('kp', 1500.0, 'W/m', 'Proportional gain.', 0.0, 1e6),
    ('ki', 1000.0, 'W/(m s)', 'Integral gain.', 0.0, 1e6),
    ('kd', 0.0, 'W s/m', 'Derivative gain (on the measurement).', 0.0, 1e6),
    ('derivative_filter', 0.05, 's', 'Time constant of the measurement filter for kd.',
     0.0, 10.0),
    ('feedforward', 0.0, 'W', 'Constant power added to the PID output.', 0.0, 1e4),
    ('max_power', 2.0, 'W', 'Upper output limit.', 0.0, 1e4),
    ('min_power', 0.0, 'W', 'Lower output limit.', 0.0, 1e4),
    ('setpoint', 0.0, 'm', 'Displacement setpoint until one arrives on the topic.',
     -1.0, 1.0),
)


_SPECS = {spec[0]: spec for spec in PARAMETERS}


class PidController:
    """Discrete PID with output limits and conditional-integration anti-windup."""

    def __init__(self, kp, ki, kd, derivative_filter, feedforward, min_power, max_power):
        self.kp, self.ki, self.kd = kp, ki, kd
        self.derivative_filter = derivative_filter
        self.feedforward = feedforward
        self.min_power, self.max_power = min_power, max_power
        self.integral = 0.0  # m s
        self._filtered = None  # m, filtered measurement
        self._rate = 0.0  # m/s, its derivative

    def settings(self):
        """Return the gains and limits (the constructor's arguments) as a dict."""
        return {name: getattr(self, name) for name in (
            'kp', 'ki', 'kd', 'derivative_filter', 'feedforward', 'min_power', 'max_power')}

    def update(self, setpoint, measurement, dt):
        """Return the power (W) for setpoint and measurement (m) after dt (s)."""
        error = setpoint - measurement
        if self._filtered is None or not 0.0 < dt <= MAX_SAMPLE_TIME:
            self._filtered, self._rate = measurement, 0.0
            dt = 0.0
        else:
            alpha = dt / (self.derivative_filter + dt)
            filtered = self._filtered + alpha * (measurement - self._filtered)
            self._rate = (filtered - self._filtered) / dt
            self._filtered = filtered
        unsat = self.kp * error + self.ki * self.integral - self.kd * self._rate \
            + self.feedforward
        high, low = unsat >= self.max_power, unsat <= self.min_power
        if not ((high and error > 0.0) or (low and error < 0.0)):
            self.integral += error * dt
        out = self.kp * error + self.ki * self.integral - self.kd * self._rate \
            + self.feedforward
        return min(max(out, self.min_power), self.max_power)


class TcaPidNode(Node):
    """Track displacement_setpoint by commanding power_cmd."""

    def __init__(self):
        super().__init__('tca_pid')
        values = {}
        for name, default, unit, text, low, high in PARAMETERS:
            descriptor = ParameterDescriptor(
                description=f'{text} Unit: {unit}. Range: [{low:g}, {high:g}].',
                dynamic_typing=True)  # a params file may write 2 for 2.0
            values[name] = checked_value(name, self.declare_parameter(
                name, default, descriptor).value)
            # The range goes in only now, so a bad start-up value gets checked_value's line.
            descriptor.floating_point_range = [FloatingPointRange(from_value=low,
                                                                  to_value=high)]
            self.set_descriptor(name, descriptor)
        _check_limits(values['min_power'], values['max_power'])
        self._setpoint = values.pop('setpoint')
        # Until a setpoint arrives, send no command: a lockstep simulator then holds its
        # clock at 0 until the whole loop (and whoever sends setpoints) is connected.
        self._have_setpoint = not self.declare_parameter(
            'wait_for_setpoint', False, ParameterDescriptor(
                description='Send no power_cmd until a displacement_setpoint arrives.',
                read_only=True)).value
        self._pid = PidController(**values)
        # tca_node's default joint_name in the same namespace (/finger1: finger1/tca_joint)
        self._joint = self.declare_parameter('joint_name', namespaced_name(
            self.get_namespace(), 'tca_joint'), ParameterDescriptor(
            description='Joint of joint_states to control (joint_name of tca_node).',
            read_only=True)).value
        if not self._joint.strip():
            raise ValueError(f"parameter 'joint_name' = {self._joint!r}: must be a non-empty "
                             'name (the joint_name of tca_node)')
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._last_stamp_ns = None
        self._waited_for_match = False
        self._power_pub = self.create_publisher(Float64, 'power_cmd', COMMAND_QOS)
        self._command = Float64()  # refilled per state: publish serialises it at once
        # The setpoint first: when both are pending, the executor serves subscriptions in
        # creation order, so a pending setpoint is taken before a pending state.
        self.create_subscription(Float64, 'displacement_setpoint', self._on_setpoint,
                                 SETPOINT_QOS)
        self._stamped = self.declare_parameter('stamped_reference', False, ParameterDescriptor(
            description='Answer each joint_states message with the reference (topic '
                        'reference, JointState) of the same stamp, waiting for it: '
                        'deterministic scored runs (tca_sim score --namespace).',
            read_only=True)).value
        self._references = {}  # stamp (ns) -> reference (m), the latest REFERENCE_KEEP
        self._pending = None  # a state waiting for its reference
        if self._stamped:
            self.create_subscription(JointState, 'reference', self._on_reference,
                                     SETPOINT_QOS)
        self.create_subscription(JointState, 'joint_states', self._on_feedback, FEEDBACK_QOS)
        self.get_logger().info(f'tca_pid ready: setpoint {self._setpoint:g} m')

    def _on_setpoint(self, msg):
        if math.isfinite(msg.data):
            self._setpoint = msg.data
            self._have_setpoint = True
        else:
            self.get_logger().warning('displacement_setpoint: non-finite value rejected',
                                      throttle_duration_sec=1.0)

    def _on_reference(self, msg):
        index = msg.name.index(self._joint) if self._joint in msg.name else 0
        if len(msg.position) <= index or not math.isfinite(msg.position[index]):
            self.get_logger().warning('reference: no finite position: ignored',
                                      throttle_duration_sec=1.0)
            return
        stamp = _stamp_ns(msg)
        if self._references and stamp < max(self._references):
            self._references.clear()  # time went back: a new episode's references
        self._references[stamp] = msg.position[index]
        while len(self._references) > REFERENCE_KEEP:
            del self._references[min(self._references)]
        if self._pending is not None and _stamp_ns(self._pending) == stamp:
            pending, self._pending = self._pending, None
            self._on_feedback(pending)

    def _on_feedback(self, msg):
        if self._stamped and _stamp_ns(msg) != self._last_stamp_ns:  # (a repeat: as before)
            stamp = _stamp_ns(msg)
            if stamp not in self._references:
                self._pending = msg  # answered when its reference comes
                return
            self._setpoint, self._have_setpoint = self._references[stamp], True
            for old in [s for s in self._references if s <= stamp]:
                del self._references[old]  # only references of states to come stay
        # the muscle's joint by name (a merged joint_states has several); unnamed: first
        index = msg.name.index(self._joint) if self._joint in msg.name else 0
        if len(msg.position) <= index or not math.isfinite(msg.position[index]) or (
                msg.name and self._joint not in msg.name):
            # Answer every state (lockstep counts on it), with the safe command.
            self.get_logger().warning('joint_states: no finite position of joint '
                                      f'{self._joint!r}: power 0',
                                      throttle_duration_sec=1.0)
            self._power_pub.publish(Float64(data=0.0))
            return
        if not self._have_setpoint:
            return
        stamp = _stamp_ns(msg)
        if self._last_stamp_ns is not None and not 0 <= stamp - self._last_stamp_ns <= \
                MAX_SAMPLE_TIME * 1e9:
            # Time went back or jumped: a new episode (a scored task starts after a gap).
            self._pid = PidController(**self._pid.settings())
            self._last_stamp_ns = None
        dt = 0.0 if self._last_stamp_ns is None else (stamp - self._last_stamp_ns) * 1e-9
        self._last_stamp_ns = stamp
        power = self._pid.update(self._setpoint, msg.position[index], dt)
        if not self._waited_for_match:
            self._wait_for_match()
        self._command.data = power
        self._power_pub.publish(self._command)

    def _wait_for_match(self):
        """Hold the first command until the simulator's subscription is matched.

        A reliable writer drops what it publishes before matching; in lockstep the
        simulator would then wait out its timeout and the run would not be repeatable.
        """
        self._waited_for_match = True
        clock = Clock(clock_type=ClockType.STEADY_TIME)
        deadline = clock.now().nanoseconds + MATCH_WAIT * 1e9
        while self._power_pub.get_subscription_count() == 0 and \
                clock.now().nanoseconds < deadline:
            clock.sleep_for(Duration(seconds=0.01))

    def _on_set_parameters(self, parameters):
        pid = self._pid
        merged = {'min_power': pid.min_power, 'max_power': pid.max_power}
        try:
            updates = {p.name: checked_value(p.name, p.value) for p in parameters
                       if p.name in _SPECS}
            merged.update({k: v for k, v in updates.items() if k in merged})
            _check_limits(merged['min_power'], merged['max_power'])
        except ValueError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        for name, value in updates.items():
            if name == 'setpoint':
                self._setpoint = value
            else:
                setattr(pid, name, value)
        return SetParametersResult(successful=True)


def _stamp_ns(msg):
    """Return a stamped message's header stamp in ns."""
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def checked_value(name, value):
    """Return a tca_pid parameter as float, or raise ValueError (one line)."""
    _, _, unit, _, low, high = _SPECS[name]
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not low <= value <= high:
        raise ValueError(f"parameter '{name}' = {value!r}: must be a number in "
                         f'[{low:g}, {high:g}] {unit}')
    return float(value)


def _check_limits(min_power, max_power):
    if min_power > max_power:
        raise ValueError(f"parameter 'min_power' = {min_power:g}: must not exceed "
                         f'max_power ({max_power:g} W)')


def main(args=None):
    """Run the ``tca_pid`` node."""
    install_stop_handlers()  # SIGINT and SIGTERM stop the spin, not rclpy
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    try:
        node = TcaPidNode()
        spin_resiliently(node)
    except ValueError as exc:  # a bad parameter: one line, no traceback
        rclpy.logging.get_logger('tca_pid').fatal(str(exc))
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
