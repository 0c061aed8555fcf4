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

import numpy as np
import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg

from tca_ros.model.limits import ThreadBreakError
from tca_ros.model.params import ParameterError
from tca_ros.model.resistance import power_from_voltage
from tca_ros.model.rigs import start_load
from tca_ros.node_clock import ClockMixin, NS, time_msg, WARN_PERIOD
from tca_ros.node_cmdline import check_ros_arguments, init_quietly, log_fatal
from tca_ros.node_diagnostics import DiagnosticsPublisher
from tca_ros.node_inputs import InputsMixin
from tca_ros.node_outputs import non_finite, OutputsMixin
from tca_ros.node_params import (  # noqa: F401  (re-exported: the node's parameter API)
    build_simulator, check_unknown_overrides,
    descriptor, GuardedParameterService, INTEGER_NAMES,
    NAMESPACED, namespaced_name, NODE_SCHEMA, NODE_SPECS,
    numbers_as_declared_types, physics_dt, physics_steps_per_tick, READ_ONLY, REBUILD,
    validate_node_values)
from tca_ros.node_reconfigure import ParametersMixin
from tca_ros.node_rigs import RigTopics
from tca_ros.node_spin import spin_resiliently
from tca_ros.node_tables import muscle_temperatures, table_rows
from tca_ros.node_task import TaskPlayer


CLOCK_QOS = QoSProfile(depth=1)  # reliable writer; rclpy's clock reader is best effort

MAX_TEMPERATURE_REARM = 1.0  # K below max_temperature before a new crossing is logged


class TcaSimNode(ClockMixin, InputsMixin, OutputsMixin, ParametersMixin, Node):
    """Step the TCA model at physics_rate and publish its state at publish_rate.

    Here: start-up and the physics episode (commands, watchdog, limits, failure, reset);
    the time in node_clock.ClockMixin, the inputs (subscriptions, ~/reset) in
    node_inputs.InputsMixin, the outputs (and their publishers) in
    node_outputs.OutputsMixin, the parameters (declared, then changed) in
    node_reconfigure.ParametersMixin.
    """

    def __init__(self, **kwargs):
        kwargs['start_parameter_services'] = False  # ours refuse what rclpy cannot convert
        super().__init__('tca', **kwargs)
        self._declare_parameters()

        self._rng = np.random.default_rng(int(self._cfg['noise.seed']))
        self._drive = ('power', 0.0)  # last valid command: ('power', W) or ('voltage', V)
        self._last_command_ns = None  # node time of the last valid command
        self._watchdog_tripped = False
        self._load = start_load(self._params)  # N: dead weight, or the spring's F_0
        self._power = 0.0  # W, applied in the last physics step
        self._broken = False
        self._failure = None  # why the physics stopped (None while it runs)
        self._broken_cause = ''  # the physical event that broke the muscle
        self._halted = False  # the thread broke: no physics until ~/reset
        self._table_wait = None  # degC of a table row the physics waits for
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

        self._create_output_publishers()
        self._create_inputs()
        self._rig = RigTopics(self, self._params.rig.mode, lambda: self._cfg,
                              self._command_time)

        self._owns_time = self._cfg['publish_clock']
        self._wall = Clock(clock_type=ClockType.STEADY_TIME)
        if self._owns_time:
            self._clock_pub = self.create_publisher(ClockMsg, '/clock', CLOCK_QOS)
        # scored tasks (tca_sim score --namespace): reference and load per tick
        self._task = TaskPlayer(self, self._start_task, lambda: self._cfg['joint_name'])
        self._timer = None
        self._make_timer()
        self._diagnostics = DiagnosticsPublisher(
            self, self._muscle_state, lambda: time_msg(self._now_ns()), self._wall)
        try:
            self._reset_sim()
        except (ValueError, ArithmeticError) as exc:  # one line at start-up, no traceback
            raise ParameterError(str(exc).splitlines()[0]) from None
        self._rows = table_rows(self._params)
        self._rows.start(muscle_temperatures(self._sim))
        self._warm_up_shape()
        self.get_logger().info(
            f'tca node ready: model {self._params.model}, physics {self._cfg["physics_rate"]:g} '
            f'Hz, publish {self._cfg["publish_rate"]:g} Hz, {self._clock_name()}')

    def _clock_name(self):
        """Return which clock the node runs on, for the ready line."""
        if self._owns_time:
            return f'own clock x{self._cfg["real_time_factor"]:g} (publishes /clock)'
        if self.get_parameter('use_sim_time').value:
            return 'sim clock (use_sim_time: /clock)'
        return 'node clock (system time)'

    # -- physics ----------------------------------------------------------------------
    def _command_power(self, now_ns):
        """Return the power (W) to apply now: watchdog, limits, voltage drive."""
        if self._broken:
            return 0.0
        timeout = self._cfg['command_timeout']
        if self._last_command_ns is not None and timeout > 0.0 and \
                now_ns - self._last_command_ns > timeout * NS:
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
            if self._failure is not None or self._halted:
                return
            if i == 0 or self._drive[0] == 'voltage':  # V^2 / R follows R(T, x)
                self._power = self._command_power(now)
            try:
                state = self._sim.step(self._power, self._load)
            except ThreadBreakError as exc:  # a physical event, not a failure of the physics
                self._break_thread(str(exc))
                return
            except Exception as exc:  # noqa: B902  ZeroDivision, Overflow, StabilityError...
                self._fail(f'{type(exc).__name__}: {exc}')
                return
            bad = non_finite(state)
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
                self._break(self._frozen_values(state),
                            f'above melt_temperature {self._cfg["melt_temperature"]:g} degC')

    def _physics_waits(self):
        """Return True while a table row the next steps read is being built (physics holds).

        Outputs and services go on meanwhile (tca_ros.node_tables).
        """
        if self._failure is not None or self._halted:
            return False
        waiting = self._rows.missing(muscle_temperatures(self._sim))
        if waiting is not None and self._table_wait is None:
            self.get_logger().info(
                f'physics waits for the rod table row at {waiting:g} degC (built off the '
                'executor, 1-2 s a row; cached for the next start)',
                throttle_duration_sec=WARN_PERIOD)
        self._table_wait = waiting
        return waiting is not None

    def _break_thread(self, reason):
        """Break the thread (its load exceeded its strength): the physics stops until reset."""
        reason = reason.splitlines()[0].replace(': the thread breaks', '')
        self._halted = True
        self.get_logger().error(
            f'the thread broke: {reason} (tension 0, resistance inf) until ~/reset')
        self._break(self._last_good[:2], f'by its load: {reason}')

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
        self._break(self._last_good[:2], 'physics failure')

    def _break(self, frozen, cause):
        self._broken = True
        self._broken_cause = cause
        self._frozen = frozen
        self._power = 0.0

    def _reset_sim(self, temperature=None):
        """Return to the loaded equilibrium at temperature (degC, default ambient).

        Raises ValueError or ArithmeticError (state unchanged) when the model has no
        finite equilibrium there, e.g. under a load the coil cannot hold.
        """
        self._sim.reset(load=self._load, temperature=temperature)
        bad = non_finite(self._sim.state)
        if bad:
            raise ValueError(f'{bad} = {getattr(self._sim.state, bad)!r} at the equilibrium')
        s = self._sim.state
        self._last_good = (s.measured_displacement, -s.velocity, s.temperature)
        self._failure = None
        self._broken = False
        self._broken_cause = ''
        self._halted = False
        self._overheated = False
        self._frozen = None
        self._power = 0.0


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
