"""ROS 2 node ``tca``: the TCA simulator behind topics, parameters and a reset service.

Inputs (std_msgs/Float64): ``power_cmd`` (W), ``voltage_cmd`` (V, heating V^2 / R),
``load`` (N, tensile). Outputs at ``publish_rate``: ``displacement`` (m, contraction
positive), ``temperature`` (sensor_msgs/Temperature, degC), ``resistance`` (ohm),
``power`` (W, the power actually applied), ``joint_states`` (position = displacement,
velocity = contraction rate, effort = tension), and ``shape`` (visualization_msgs/Marker)
at ``shape_rate``; the muscle's state goes to ``/diagnostics`` (tca_ros.node_diagnostics).
The physics (tca_ros.model.dynamics.TcaSimulator) runs at ``physics_rate``. Time modes,
parameters and examples: docs/node.md.
"""
import math
import sys
import time

from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import Point
import numpy as np
from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rclpy.qos_overriding_options import QoSOverridingOptions
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64
from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker

from tca_ros.model.dynamics import StabilityError
from tca_ros.model.kinetostatics import fixed_coil_centreline
from tca_ros.model.params import from_flat_dict, ParameterError, SCHEMA, SPECS
from tca_ros.model.resistance import power_from_voltage
from tca_ros.model.rigs import start_load
from tca_ros.model.rod_model import centreline as rod_centreline
from tca_ros.node_diagnostics import DiagnosticsPublisher, MuscleState
from tca_ros.node_params import (  # noqa: F401  (re-exported: the node's parameter API)
    build_simulator, check_model_supports, check_ros_arguments, check_unknown_overrides,
    descriptor, GuardedParameterService, init_quietly, INTEGER_NAMES, log_fatal,
    model_for_node, NAMESPACED, namespaced_name, NODE_SCHEMA, NODE_SPECS,
    numbers_as_declared_types, physics_dt, physics_steps_per_tick, READ_ONLY, REBUILD,
    validate_node_values)
from tca_ros.node_rigs import RigTopics
from tca_ros.node_spin import spin_resiliently


STATE_QOS = QoSProfile(depth=10)  # reliable: serves reliable and best-effort readers
COMMAND_QOS = QoSProfile(depth=10)
CLOCK_QOS = QoSProfile(depth=1)  # reliable writer; rclpy's clock reader is best effort
SHAPE_QOS = QoSProfile(depth=1)

MAX_CATCH_UP = 1.0  # s of physics run at most per callback after a stall or a clock jump
MAX_CATCH_UP_WALL = 0.2  # s of wall time a callback may spend stepping (services must answer)
CATCH_UP_CHUNK = 50  # physics steps between checks of that wall-time budget
FAST_BATCH = 0.02  # s of wall time spent ticking per callback at real_time_factor 0
FAST_PERIOD = 1e-3  # s, wall period of the tick timer in publish_clock mode, factor 0
LOCKSTEP_POLL = 0.01  # s, wall period of that timer in lockstep (wake-ups cost ~0.1 ms)
MAX_TEMPERATURE_REARM = 1.0  # K below max_temperature before a new crossing is logged
WARN_PERIOD = 1.0  # s between repeats of a throttled warning

_NS = 1_000_000_000


class TcaSimNode(Node):
    """Step the TCA model at physics_rate and publish its state at publish_rate."""

    def __init__(self, **kwargs):
        kwargs['start_parameter_services'] = False  # ours refuse what rclpy cannot convert
        super().__init__('tca', **kwargs)
        self._parameter_service = GuardedParameterService(self)
        all_specs = [(s, s.name in READ_ONLY) for s in SCHEMA + NODE_SCHEMA]
        for spec, _ in all_specs:
            default = spec.default if spec.name not in NAMESPACED else \
                namespaced_name(self.get_namespace(), spec.default)
            self.declare_parameter(spec.name, default, descriptor(spec, with_range=False))
        check_unknown_overrides(self)  # a misspelt name is refused, as tca_sim does
        tca_values = {s.name: self.get_parameter(s.name).value for s in SCHEMA}
        node_values = {s.name: self.get_parameter(s.name).value for s in NODE_SCHEMA}
        self._params, warning = model_for_node(
            from_flat_dict(tca_values, source='ros parameters'))
        if warning:
            self.get_logger().warning(warning)
            self.set_parameters([Parameter('model', value=self._params.model)])
        self._cfg = validate_node_values(node_values)
        self._sim = build_simulator(self._params, self._cfg)
        # 1000.0 from a params file is stored as the INTEGER it names, 25 for a DOUBLE
        # as 25.0: every parameter keeps its declared type.
        self.set_parameters(numbers_as_declared_types(
            [self.get_parameter(spec.name) for spec, _ in all_specs]))
        # Ranges only now: a bad start-up value gets the schema's one-line message above.
        for spec, read_only in all_specs:
            self.set_descriptor(spec.name, descriptor(spec, read_only))
        self.add_pre_set_parameters_callback(numbers_as_declared_types)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self._rng = np.random.default_rng(int(self._cfg['noise.seed']))
        self._drive = ('power', 0.0)  # last valid command: ('power', W) or ('voltage', V)
        self._last_command_ns = None  # node time of the last valid command
        self._watchdog_tripped = False
        self._load = start_load(self._params)  # N: dead weight, or the spring's F_0
        self._power = 0.0  # W, applied in the last physics step
        self._broken = False
        self._failure = None  # why the physics stopped (None while it runs)
        self._overheated = False
        self._frozen = None  # (displacement, velocity) when the muscle broke
        self._last_good = (0.0, 0.0, self._sim.state.temperature)  # displ., rate, temp.
        self._steps_done = 0
        self._t0_ns = None
        self._sim_ns = 0  # node-owned time with publish_clock
        self._awaiting_command = False
        self._await_deadline = 0.0
        self._started = False
        self._wall_first_tick = None
        self._wall_t0 = None
        self._ticks_done = 0
        self._next_shape_ns = 0
        self._next_shape_wall = 0.0
        self._stepping_paused_until = 0.0  # monotonic s: no catch-up before (overload)

        qos_opts = QoSOverridingOptions.with_default_policies()
        self._disp_pub = self.create_publisher(Float64, 'displacement', STATE_QOS,
                                               qos_overriding_options=qos_opts)
        self._temp_pub = self.create_publisher(Temperature, 'temperature', STATE_QOS,
                                               qos_overriding_options=qos_opts)
        self._res_pub = self.create_publisher(Float64, 'resistance', STATE_QOS,
                                              qos_overriding_options=qos_opts)
        self._power_pub = self.create_publisher(Float64, 'power', STATE_QOS,
                                                qos_overriding_options=qos_opts)
        self._joint_pub = self.create_publisher(JointState, 'joint_states', STATE_QOS,
                                                qos_overriding_options=qos_opts)
        self._shape_pub = self.create_publisher(Marker, 'shape', SHAPE_QOS)
        self._power_sub = self.create_subscription(Float64, 'power_cmd', self._on_power_cmd,
                                                   COMMAND_QOS)
        self._voltage_sub = self.create_subscription(Float64, 'voltage_cmd',
                                                     self._on_voltage_cmd, COMMAND_QOS)
        self.create_subscription(Float64, 'load', self._on_load, COMMAND_QOS)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self._rig = RigTopics(self, self._params.rig.mode, lambda: self._cfg,
                              self._command_time)

        self._owns_time = self._cfg['publish_clock']
        self._wall = Clock(clock_type=ClockType.STEADY_TIME)
        if self._owns_time:
            self._clock_pub = self.create_publisher(ClockMsg, '/clock', CLOCK_QOS)
        self._timer = None
        self._make_timer()
        self._diagnostics = DiagnosticsPublisher(
            self, self._muscle_state, lambda: _time_msg(self._now_ns()), self._wall)
        try:
            self._reset_sim()
        except (ValueError, ArithmeticError) as exc:  # one line at start-up, no traceback
            raise ParameterError(str(exc).splitlines()[0]) from None
        self._warm_up_shape()
        self.get_logger().info(
            f'tca node ready: model {self._params.model}, physics {self._cfg["physics_rate"]:g} '
            f'Hz, publish {self._cfg["publish_rate"]:g} Hz, '
            + (f'own clock x{self._cfg["real_time_factor"]:g}' if self._owns_time
               else 'node clock'))

    # -- time -------------------------------------------------------------------------
    def _make_timer(self):
        """(Re)create the tick timer for the time mode and rates."""
        if self._timer is not None:
            self.destroy_timer(self._timer)
        if self._owns_time:
            rtf = self._cfg['real_time_factor']
            period = FAST_PERIOD if rtf == 0.0 else min(
                FAST_PERIOD * 10, 1.0 / (self._cfg['publish_rate'] * rtf))
            if self._cfg['lockstep']:
                # Commands drive the ticks; the timer only starts them and times out.
                period = max(period, LOCKSTEP_POLL)
            self._timer = self.create_timer(period, self._on_clock_timer, clock=self._wall)
            self._wall_t0, self._ticks_done = None, 0
        else:
            self._timer = self.create_timer(1.0 / self._cfg['publish_rate'], self._on_timer)

    def _now_ns(self):
        """Return the node time (ns): own sim time with publish_clock, else the ROS clock."""
        if self._owns_time:
            return self._sim_ns
        return self.get_clock().now().nanoseconds

    def _catch_up(self):
        """Step the physics up to the node clock (modes without publish_clock)."""
        now = self._now_ns()
        if now == 0:  # use_sim_time and no /clock received yet
            return
        if self._t0_ns is None or now < self._t0_ns:
            if self._t0_ns is not None:
                self.get_logger().warning('clock jumped backwards: physics time rebased')
            self._t0_ns, self._steps_done = now, 0
        target = int((now - self._t0_ns) / (self._sim.dt * _NS))
        n = target - self._steps_done
        limit = int(MAX_CATCH_UP / self._sim.dt)
        if n > limit:
            self.get_logger().warning(
                f'physics {n * self._sim.dt:.3g} s behind the clock: skipped to now',
                throttle_duration_sec=WARN_PERIOD)
            self._steps_done += n - limit
            n = limit
        wall = time.monotonic()
        if wall < self._stepping_paused_until:
            # the last catch-up ran out of its budget: every callback (each command
            # message steps too) would spend another budget and requests would wait
            # behind them, so no stepping until the pause ends (physics skips to now)
            self._steps_done += n
            return
        deadline = wall + MAX_CATCH_UP_WALL
        for start in range(0, n, CATCH_UP_CHUNK):
            if time.monotonic() > deadline:
                # A physics_rate this machine cannot keep up with: drop physics time
                # rather than leave services and commands waiting behind the stepper.
                self.get_logger().warning(
                    f'physics {(n - start) * self._sim.dt:.3g} s behind the clock after '
                    f'{MAX_CATCH_UP_WALL:g} s of stepping: skipped to now (lower '
                    'physics_rate?)', throttle_duration_sec=WARN_PERIOD)
                self._stepping_paused_until = time.monotonic() + MAX_CATCH_UP_WALL
                break
            self._advance(min(CATCH_UP_CHUNK, n - start))
        self._steps_done += n

    def _on_timer(self):
        try:
            self._catch_up()
            self._publish_state(self._now_ns())
        except Exception as exc:  # noqa: B902  a tick must never end the node
            self._fail_unless_stopping(exc)

    def _on_clock_timer(self):
        """Tick the node-owned clock; a failure marks the muscle broken, never raises."""
        try:
            self._clock_tick()
        except Exception as exc:  # noqa: B902  a tick must never end the node
            self._fail_unless_stopping(exc)

    def _fail_unless_stopping(self, exc):
        """Fail the episode on exc, unless a signal shut the context down meanwhile."""
        if self.context.ok():
            self._fail(f'{type(exc).__name__}: {exc}')

    def _clock_tick(self):
        """Tick the node-owned clock at real_time_factor (publish_clock mode)."""
        if not self._started:
            if self._cfg['lockstep'] and not self._peers_matched():
                return
            self._started = True
            self._wall_first_tick = time.monotonic()
            self._publish_tick()
            return
        if self._awaiting_command:
            if time.monotonic() < self._await_deadline:
                return
            if self._last_command_ns is None:
                # The controller's reader may not have matched yet when the first state
                # went out: repeat it (same values) rather than advance without a reply.
                self._publish_clock()
                self._emit_sample()
                self._await_deadline = time.monotonic() + self._cfg['lockstep_timeout']
                return
            self.get_logger().warning(
                f'lockstep: no command within {self._cfg["lockstep_timeout"]:g} s: '
                'advancing with the last one', throttle_duration_sec=WARN_PERIOD)
            self._awaiting_command = False
        self._run_ticks()

    def log_time_summary(self):
        """Log the sim time reached and its ratio to wall time (publish_clock mode)."""
        if self._owns_time and self._wall_first_tick is not None:
            wall = time.monotonic() - self._wall_first_tick
            sim = self._sim_ns / _NS
            # Not the node's logger: at shutdown its /rosout publisher is already gone.
            rclpy.logging.get_logger('tca.time').info(
                f'simulated {sim:.3f} s in {wall:.3f} s of wall time '
                f'({sim / max(wall, 1e-9):.1f}x real time)')

    def _peers_matched(self):
        """Return True when a controller reads the state and writes commands."""
        readers = self._joint_pub.get_subscription_count() \
            + self._disp_pub.get_subscription_count()
        writers = self._power_sub.get_publisher_count() \
            + self._voltage_sub.get_publisher_count()
        return readers > 0 and writers > 0

    def _run_ticks(self):
        """Run the ticks that are due (or a wall-time batch at factor 0)."""
        rtf = self._cfg['real_time_factor']
        tick_s = 1.0 / self._cfg['publish_rate']
        start = time.monotonic()
        if self._wall_t0 is None:
            self._wall_t0, self._ticks_done = start, 0
        while not self._awaiting_command:
            if rtf == 0.0:
                if time.monotonic() - start > FAST_BATCH:
                    break
            else:
                due = int((time.monotonic() - self._wall_t0) * rtf / tick_s)
                if self._ticks_done >= due:
                    break
                if due - self._ticks_done > MAX_CATCH_UP / tick_s:
                    self._wall_t0 = time.monotonic() - self._ticks_done * tick_s / rtf
            self._ticks_done += 1
            self._advance(self._steps_per_tick())
            self._sim_ns += round(tick_s * _NS)
            self._publish_tick()

    def _publish_clock(self):
        self._clock_pub.publish(ClockMsg(clock=_time_msg(self._sim_ns)))

    def _publish_tick(self):
        """Publish /clock and the state; in lockstep, then wait for a command."""
        self._publish_clock()
        self._publish_state(self._sim_ns)
        if self._cfg['lockstep']:
            self._awaiting_command = True
            self._await_deadline = time.monotonic() + self._cfg['lockstep_timeout']

    def _steps_per_tick(self):
        return physics_steps_per_tick(self._cfg)

    # -- physics ----------------------------------------------------------------------
    def _command_power(self, now_ns):
        """Return the power (W) to apply now: watchdog, limits, voltage drive."""
        if self._broken:
            return 0.0
        timeout = self._cfg['command_timeout']
        if self._last_command_ns is not None and timeout > 0.0 and \
                now_ns - self._last_command_ns > timeout * _NS:
            if not self._watchdog_tripped:
                self._watchdog_tripped = True
                # throttled: a command_timeout shorter than the command period trips
                # and clears the watchdog at every message (fuzz_node: 30 lines/s)
                self.get_logger().warning(
                    f'no power or voltage command for {timeout:g} s: power set to 0',
                    throttle_duration_sec=WARN_PERIOD)
            return 0.0
        kind, value = self._drive
        if kind == 'voltage':
            resistance = self._sim.state.resistance
            if not resistance > 0.0:  # R(T, x) law taken outside its range
                self.get_logger().warning(
                    f'resistance {resistance:g} ohm is not positive: voltage drive gives '
                    'power 0 (check electrical.*)', throttle_duration_sec=WARN_PERIOD)
                return 0.0
            power = power_from_voltage(value, resistance)
            if power > self._cfg['max_power']:
                self.get_logger().warning(
                    f'voltage_cmd {value:g} V gives {power:g} W at {resistance:.4g} ohm, above '
                    f'max_power {self._cfg["max_power"]:g} W: clamped',
                    throttle_duration_sec=WARN_PERIOD)
            value = power
        return min(max(value, 0.0), self._cfg['max_power'])

    def _advance(self, n_steps):
        """Run n physics steps with the current command and load.

        A step that raises or leaves a non-finite state ends the episode: the muscle
        is marked broken with its last finite outputs and the physics stops until
        ~/reset or a parameter change (one error line, not one per step).
        """
        now = self._now_ns()
        self._rig.drive(self._sim, now, self._broken)
        for i in range(n_steps):
            if self._failure is not None:
                return
            if i == 0 or self._drive[0] == 'voltage':  # V^2 / R follows R(T, x)
                self._power = self._command_power(now)
            try:
                state = self._sim.step(self._power, self._load)
            except Exception as exc:  # noqa: B902  ZeroDivision, Overflow, StabilityError...
                self._fail(f'{type(exc).__name__}: {exc}')
                return
            bad = _non_finite(state)
            if bad:
                self._fail(f'{bad} = {getattr(state, bad)!r} (non-finite state)')
                return
            temp = self._rig.hottest(self._sim)
            if temp > self._cfg['max_temperature'] and not self._overheated:
                self._overheated = True
                self.get_logger().error(
                    f'temperature {temp:.1f} degC above max_temperature '
                    f'{self._cfg["max_temperature"]:g} degC')
            elif temp < self._cfg['max_temperature'] - MAX_TEMPERATURE_REARM:
                self._overheated = False
            if temp > self._cfg['melt_temperature'] and not self._broken:
                self.get_logger().error(
                    f'temperature {temp:.1f} degC above melt_temperature '
                    f'{self._cfg["melt_temperature"]:g} degC: the muscle broke '
                    '(tension 0, resistance inf) until ~/reset')
                self._break(self._frozen_values(state))

    def _frozen_values(self, state):
        values = (state.measured_displacement, -state.velocity)
        return values if all(map(math.isfinite, values)) else self._last_good[:2]

    def _fail(self, reason):
        """End the episode once: log why, mark the muscle broken, stop the physics."""
        if self._failure is not None:
            return
        self._failure = reason.splitlines()[0] if reason else 'unknown'
        self.get_logger().error(
            f'physics failed at t = {self._sim.state.time:.6g} s (power {self._power:g} W, '
            f'load {self._load:g} N): {self._failure}; the muscle is marked broken (last '
            'finite outputs held) until ~/reset or a parameter change')
        self._break(self._last_good[:2])

    def _break(self, frozen):
        self._broken = True
        self._frozen = frozen
        self._power = 0.0

    def _reset_sim(self, temperature=None):
        """Return to the loaded equilibrium at temperature (degC, default ambient).

        Raises ValueError or ArithmeticError (state unchanged) when the model has no
        finite equilibrium there, e.g. under a load the coil cannot hold.
        """
        self._sim.reset(load=self._load, temperature=temperature)
        bad = _non_finite(self._sim.state)
        if bad:
            raise ValueError(f'{bad} = {getattr(self._sim.state, bad)!r} at the equilibrium')
        s = self._sim.state
        self._last_good = (s.measured_displacement, -s.velocity, s.temperature)
        self._failure = None
        self._broken = False
        self._overheated = False
        self._frozen = None
        self._power = 0.0

    # -- outputs ----------------------------------------------------------------------
    def _muscle_state(self, now_ns=None):
        """Return the MuscleState that /diagnostics reports (model values, no noise)."""
        s, cfg = self._sim.state, self._cfg
        if self._owns_time:
            waiting = '' if self._started else (
                'a controller (lockstep)' if cfg['lockstep'] else 'the first tick')
        else:  # the clock read costs ~10 us: a tick passes its own time
            now = self._now_ns() if now_ns is None else now_ns
            waiting = 'the first /clock message' if now == 0 else ''
        return MuscleState(
            temperature=s.temperature if self._failure is None else self._last_good[2],
            power=self._power, load=self._load,
            displacement=self._frozen[0] if self._broken else s.measured_displacement,
            max_temperature=cfg['max_temperature'], melt_temperature=cfg['melt_temperature'],
            command_timeout=cfg['command_timeout'], overheated=self._overheated,
            broken=self._broken, watchdog_tripped=self._watchdog_tripped,
            failure=self._failure, waiting=waiting)

    def _noise(self, key):
        std = self._cfg['noise.' + key]
        return float(self._rng.normal(0.0, std)) if std > 0.0 else 0.0

    def _publish_state(self, now_ns):
        """Sample the state now (stamps = physics time, ns), publish it and the shape."""
        s = self._sim.state
        if not self._broken and _non_finite(s):  # e.g. a state set by a failed reset
            self._fail(f'{_non_finite(s)} = {getattr(s, _non_finite(s))!r} (non-finite state)')
        if self._broken:
            displacement, rate = self._frozen
            tension, res = 0.0, math.inf  # documented: an open circuit
            temperature = s.temperature if self._failure is None else self._last_good[2]
        else:
            displacement, rate = s.measured_displacement, -s.velocity
            tension, res = s.tension, s.resistance
            temperature = s.temperature
            self._last_good = (displacement, rate, temperature)
        # The noise is drawn whoever listens, so the outputs never depend on the readers.
        displacement += self._noise('displacement')
        res += self._noise('resistance')
        temperature += self._noise('temperature')
        self._sample = (_time_msg(now_ns), displacement, rate, tension, res, temperature,
                        self._power)
        self._rig.sample(self._sim, self._broken)
        self._emit_sample()
        rate = self._cfg['shape_rate']
        if rate > 0.0 and self._failure is None and now_ns >= self._next_shape_ns and \
                time.monotonic() >= self._next_shape_wall and \
                self._shape_pub.get_subscription_count():
            # At most shape_rate per sim second and per wall second: a viewer needs no
            # more, and a 1000-point Marker costs ~5 ms to build in Python.
            self._next_shape_ns = now_ns + round(_NS / rate)
            self._next_shape_wall = time.monotonic() + 1.0 / rate
            self._publish_shape(self._sample[0])
        self._diagnostics.update(self._muscle_state(now_ns))

    def _emit_sample(self):
        """Publish the last sample to the topics that have readers.

        Messages nobody reads are not built: a third of a tick's cost when the node runs
        as fast as possible.
        """
        stamp, displacement, rate, tension, res, temperature, power = self._sample
        if self._joint_pub.get_subscription_count():
            joint = JointState()
            joint.header.stamp = stamp
            joint.name = [self._cfg['joint_name']]
            joint.position, joint.velocity, joint.effort = self._rig.joint(
                displacement, rate, tension)
            self._joint_pub.publish(joint)
        if self._temp_pub.get_subscription_count():
            temp = Temperature()
            temp.header.stamp = stamp
            temp.header.frame_id = self._cfg['frame_id']
            temp.temperature = temperature
            temp.variance = self._cfg['noise.temperature'] ** 2
            self._temp_pub.publish(temp)
        for pub, value in ((self._disp_pub, displacement), (self._res_pub, res),
                           (self._power_pub, power)):
            if pub.get_subscription_count():
                pub.publish(Float64(data=value))
        self._rig.publish(stamp, self._cfg['frame_id'])

    def _rod_shape(self):
        """Return True when the shape comes from the rod solution.

        The rod centreline is the exact one for the rod model and the only one for a
        conical TCA; for cst and love a helix of the current length (fixed coil count)
        shows the same stroke without building the rod table.
        """
        return self._params.model == 'rod' or self._params.coil.shape != 'helix'

    def _warm_up_shape(self):
        """Build the rod centreline's tables now rather than stall the first Marker."""
        if self._cfg['shape_rate'] > 0.0 and self._rod_shape():
            s = self._sim.state
            rod_centreline(self._params, s.elongation, s.temperature, 2)

    def _publish_shape(self, stamp):
        s = self._sim.state
        n = int(self._cfg['shape_points'])
        if self._rod_shape():
            points = rod_centreline(self._params, s.elongation, s.temperature, n)
        else:
            points = fixed_coil_centreline(self._params, s.elongation, n)
        marker = Marker()
        marker.header.stamp = stamp
        marker.header.frame_id = self._cfg['base_frame']
        marker.ns = self.get_fully_qualified_name()  # unique per muscle in one RViz
        marker.type = Marker.LINE_STRIP
        marker.action = Marker.ADD
        marker.pose.orientation.w = 1.0
        marker.scale.x = 2.0 * self._params.fiber.radius  # line width = fiber diameter, m
        hot = min(max((s.temperature - 25.0) / 150.0, 0.0), 1.0)
        marker.color.r, marker.color.g, marker.color.b, marker.color.a = hot, 0.2, 1.0 - hot, 1.0
        marker.points = [_point(x, y, z) for x, y, z in np.asarray(points).T]
        self._shape_pub.publish(marker)

    # -- inputs -----------------------------------------------------------------------
    def _valid(self, topic, value):
        if math.isfinite(value):
            return True
        self.get_logger().warning(f'{topic}: rejected non-finite value {value}; '
                                  'keeping the last valid one',
                                  throttle_duration_sec=WARN_PERIOD)
        return False

    def _command(self, kind, value):
        self._last_command_ns = self._command_time()
        self._drive = (kind, value)
        if self._watchdog_tripped:
            self._watchdog_tripped = False
            self.get_logger().info('commands are back: watchdog cleared',
                                   throttle_duration_sec=WARN_PERIOD)
        if self._awaiting_command:
            self._awaiting_command = False
            self._run_ticks()

    def _command_time(self):
        """Return the node time (ns) of a command, the physics caught up to it."""
        if not self._owns_time:
            self._catch_up()  # the old command holds up to now (zero-order hold)
        return self._now_ns()

    def _on_power_cmd(self, msg):
        if not self._valid('power_cmd', msg.data):
            return
        if msg.data < 0.0 or msg.data > self._cfg['max_power']:
            self.get_logger().warning(
                f'power_cmd {msg.data:g} W outside [0, {self._cfg["max_power"]:g}] W: clamped',
                throttle_duration_sec=WARN_PERIOD)
        self._command('power', msg.data)

    def _on_voltage_cmd(self, msg):
        if self._valid('voltage_cmd', msg.data):
            self._command('voltage', msg.data)

    def _on_load(self, msg):
        if not self._valid('load', msg.data):
            return
        load = min(max(msg.data, 0.0), self._cfg['max_load'])
        if load != msg.data:
            self.get_logger().warning(
                f'load {msg.data:g} N outside [0, {self._cfg["max_load"]:g}] N: clamped',
                throttle_duration_sec=WARN_PERIOD)
        if not self._owns_time:
            self._catch_up()
        self._load = load

    def _on_reset(self, request, response):
        try:
            if not self._owns_time:
                self._catch_up()
            self._reset_sim()
        except Exception as exc:  # noqa: B902  a reset request must never end the node
            response.success = False
            response.message = (f'reset failed: {type(exc).__name__}: {exc}'.splitlines()[0]
                                + f' (load {self._load:g} N); the muscle stays broken')
            self.get_logger().error(response.message, throttle_duration_sec=WARN_PERIOD)
            return response
        self._drive = ('power', 0.0)
        self._last_command_ns = None
        self._watchdog_tripped = False
        response.success = True
        response.message = (f'reset to the loaded equilibrium at '
                            f'{self._sim.state.temperature:g} degC, load {self._load:g} N')
        self.get_logger().info(response.message)
        self._diagnostics.update()
        return response

    # -- parameters -------------------------------------------------------------------
    def _on_set_parameters(self, parameters):
        """Check new values against the schema and cross-parameter rules; apply them.

        Never raises: an unexpected error refuses the request with its reason.
        """
        owned = [p for p in parameters if p.name in SPECS or p.name in NODE_SPECS]
        if not owned:
            return SetParametersResult(successful=True)
        try:
            return self._apply_parameters(owned)
        except Exception as exc:  # noqa: B902  a parameter request must never end the node
            reason = f'{type(exc).__name__}: {exc}'.splitlines()[0]
            self.get_logger().error(f'parameter change refused: {reason}',
                                    throttle_duration_sec=WARN_PERIOD)
            return SetParametersResult(successful=False, reason=reason)

    def _apply_parameters(self, owned):
        """Validate and apply owned parameters; return the SetParametersResult."""
        tca_values = {s.name: self.get_parameter(s.name).value for s in SCHEMA}
        node_values = dict(self._cfg)
        for p in owned:
            (tca_values if p.name in SPECS else node_values)[p.name] = p.value
        if not self._owns_time:
            self._catch_up()  # up to now with the old values
        cfg = self._cfg
        try:
            params = from_flat_dict(tca_values, source='ros parameters')
            check_model_supports(params)
            cfg = validate_node_values(node_values)
            rebuild = params != self._params or any(cfg[k] != self._cfg[k] for k in REBUILD)
            if rebuild and params == self._params:
                # same TCA, new step: keep the whole state (set_dt keeps the old on failure)
                self._sim.set_dt(physics_dt(cfg))
            elif rebuild:
                sim = build_simulator(params, cfg, changed=[p.name for p in owned])
                temperature = self._start_temperature()
                load = self._load if params.rig == self._params.rig else start_load(params)
                try:  # the node's load and temperature, not the file's: refuse if no state
                    sim.reset(load=load, temperature=temperature)
                    if _non_finite(sim.state):
                        raise ValueError(f'{_non_finite(sim.state)} is not finite')
                except (ValueError, ArithmeticError) as exc:
                    raise ParameterError(
                        f'{str(exc).splitlines()[0]} (at the applied load {load:g} N, '
                        f'{temperature if temperature is not None else "ambient"} degC)') \
                        from None
        except StabilityError as exc:
            return SetParametersResult(
                successful=False, reason=f'{exc} (physics_rate = {cfg["physics_rate"]:g} Hz)')
        except ParameterError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        old_cfg, self._cfg = self._cfg, cfg
        if rebuild:
            if params != self._params:
                self._params, self._sim, self._load = params, sim, load
                self._reset_sim(temperature)
                self._warm_up_shape()
            self._t0_ns, self._steps_done = None, 0
        if cfg['noise.seed'] != old_cfg['noise.seed']:
            self._rng = np.random.default_rng(int(cfg['noise.seed']))
        if not cfg['lockstep']:
            self._awaiting_command = False
        if any(cfg[k] != old_cfg[k] for k in ('publish_rate', 'real_time_factor', 'lockstep')):
            self._make_timer()
        return SetParametersResult(successful=True)

    def _start_temperature(self):
        """Return the temperature (degC) a rebuilt simulator starts at (None: ambient)."""
        temp = self._sim.state.temperature
        return temp if self._failure is None and math.isfinite(temp) else None


_CHECKED = ('temperature', 'elongation', 'velocity', 'tension', 'measured_displacement',
            'resistance')


def _non_finite(state):
    """Return the name of the first non-finite field of a TcaState, or ''."""
    for name in _CHECKED:
        if not math.isfinite(getattr(state, name)):
            return name
    return ''


def _time_msg(ns):
    return TimeMsg(sec=ns // _NS, nanosec=ns % _NS)


def _point(x, y, z):
    return Point(x=float(x), y=float(y), z=float(z))


def main(args=None):
    """Run the ``tca`` node; return 2 on an invalid parameter (one-line error).

    Params files and ``-p`` rules are checked before rcl reads them, and rcl's own
    refusals are cut to one line too: a bad start never prints a traceback.
    """
    node = None
    try:
        check_ros_arguments(sys.argv if args is None else args)
        init_quietly(args)
        node = TcaSimNode()
        spin_resiliently(node)
    except ParameterError as exc:
        log_fatal(str(exc))
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RCLError:
        # SIGINT/SIGTERM shut the context down while the executor or a callback was
        # using it ('context is not valid', 'publisher's context is invalid'): a stop.
        if rclpy.ok():
            raise
    finally:
        if node is not None:
            node.log_time_summary()
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
