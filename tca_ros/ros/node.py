"""ROS 2 node ``tca``: the TCA simulator behind topics, parameters and a reset service.

Inputs (std_msgs/Float64): ``power_cmd`` (W), ``voltage_cmd`` (V, heating V^2 / R),
``load`` (N, tensile). Outputs at ``publish_rate``: ``displacement`` (m, contraction
positive), ``temperature`` (sensor_msgs/Temperature, degC), ``resistance`` (ohm),
``power`` (W, the power actually applied), ``joint_states`` (position = displacement,
velocity = contraction rate, effort = tension), and ``shape`` (visualization_msgs/Marker)
at ``shape_rate``; the muscle's state goes to ``/diagnostics`` (tca_ros.ros.node_diagnostics).

``TcaSimNode`` is a thin shell: what the node decides (commands, clamps, watchdog,
limits, the clock, lockstep, parameter changes) is tca_ros.ros.node_core.NodeCore, plain
Python tested without ROS; here messages and parameters are turned into its calls and
its plain outputs into messages. Time modes, parameters and examples: docs/node.md.
"""
import gc
import sys

from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.clock import Clock, ClockType
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock as ClockMsg
from std_srvs.srv import Trigger

from tca_ros.model.params_schema import ParameterError, SCHEMA, SPECS
from tca_ros.params.row_cache import install_disk_cache
from tca_ros.ros.node_clocks import Settled
from tca_ros.ros.node_cmdline import check_ros_arguments, init_quietly, log_fatal
from tca_ros.ros.node_core import NodeCore
from tca_ros.ros.node_diagnostics import DiagnosticsPublisher
from tca_ros.ros.node_episode import Log, WARN_PERIOD
from tca_ros.ros.node_outputs import (
    command_subscription, StateOutputs, time_msg, warm_up_shape)
from tca_ros.ros.node_params import (  # noqa: F401  (re-exported: the node's parameter API)
    build_simulator, check_unknown_overrides, declare_node_parameters,
    descriptor, GuardedParameterService, INTEGER_NAMES,
    NAMESPACED, namespaced_name, NODE_SCHEMA, NODE_SPECS,
    numbers_as_declared_types, physics_dt, physics_steps_per_tick, READ_ONLY, REBUILD,
    validate_node_values)
from tca_ros.ros.node_rigs import RigTopics
from tca_ros.ros.node_spin import install_stop_handlers, spin_resiliently
from tca_ros.ros.node_task import TaskPlayer

CLOCK_QOS = QoSProfile(depth=1)  # reliable writer; rclpy's clock reader is best effort
FAST_PERIOD = 1e-3  # s, wall period of the tick timer in publish_clock mode, factor 0
LOCKSTEP_POLL = 0.01  # s, wall period of that timer in lockstep (wake-ups cost ~0.1 ms)
# s of wall time a controller stays matched before the first lockstep tick: the node's
# writer matched tca_pid's reader 55-70 ms before that reader matched the writer, and the
# first state, sent in between, was lost (repeated only after lockstep_timeout, 1 s)
MATCH_SETTLE = 0.25


class TcaSimNode(Node):
    """The ``tca`` node: topics, services, parameters and timers around a NodeCore."""

    def __init__(self, **kwargs):
        kwargs['start_parameter_services'] = False  # ours refuse what rclpy cannot convert
        super().__init__('tca', **kwargs)
        self._parameter_service = GuardedParameterService(self)
        params, cfg, sim = declare_node_parameters(self)
        self._owns_time = cfg['publish_clock']
        self._wall = Clock(clock_type=ClockType.STEADY_TIME)
        self._outputs = StateOutputs(self)
        self._power_sub = command_subscription(
            self, 'power_cmd', lambda m: self.core.power_command(m.data))
        self._voltage_sub = command_subscription(
            self, 'voltage_cmd', lambda m: self.core.voltage_command(m.data))
        command_subscription(self, 'load', lambda m: self.core.load_command(m.data))
        self.create_service(Trigger, '~/reset', self._on_reset)
        self._rig = RigTopics(self, params.rig.mode, lambda: self.core.cfg,
                              lambda: self.core.command_time())
        if self._owns_time:
            self._clock_pub = self.create_publisher(ClockMsg, '/clock', CLOCK_QOS)
        # scored tasks (tca_sim score --namespace): reference and load per tick
        task = TaskPlayer(self, lambda load: self.core.start_task(load),
                          lambda: self.core.cfg['joint_name'])
        self.core = NodeCore(
            params, cfg, sim, owns_time=self._owns_time,
            clock_ns=lambda: self.get_clock().now().nanoseconds,
            publish_tick=self._publish_tick, republish=self._republish,
            log=Log(self._log_line),
            rig=self._rig, task=task)
        self.add_pre_set_parameters_callback(numbers_as_declared_types)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._timer = None
        self._settled = Settled(MATCH_SETTLE)  # a controller matched for MATCH_SETTLE s
        self._make_timer()
        self._diagnostics = DiagnosticsPublisher(
            self, self.core.muscle_state, lambda: time_msg(self.core.now_ns()), self._wall)
        try:
            self.core.episode.start()
        except (ValueError, ArithmeticError) as exc:  # one line at start-up, no traceback
            raise ParameterError(str(exc).splitlines()[0]) from None
        warm_up_shape(params, sim.state, cfg)
        self.get_logger().info(
            f'tca node ready: model {params.model}, physics {cfg["physics_rate"]:g} Hz, '
            f'publish {cfg["publish_rate"]:g} Hz, {self._clock_name()}')

    def _log_line(self, level, text):
        """Write a line of the core's log ('info', 'warning' or 'error')."""
        logger = self.get_logger()  # rclpy ties one severity to each call site
        if level == 'error':
            logger.error(text)
        elif level == 'warning':
            logger.warning(text)
        else:
            logger.info(text)

    def _clock_name(self):
        """Return which clock the node runs on, for the ready line."""
        if self._owns_time:
            return f'own clock x{self.core.cfg["real_time_factor"]:g} (publishes /clock)'
        if self.get_parameter('use_sim_time').value:
            return 'sim clock (use_sim_time: /clock)'
        return 'node clock (system time)'

    # -- time ---------------------------------------------------------------------------
    def _make_timer(self):
        """(Re)create the tick timer for the time mode and rates."""
        if self._timer is not None:
            self.destroy_timer(self._timer)
        cfg = self.core.cfg
        if self._owns_time:
            rtf = cfg['real_time_factor']
            period = FAST_PERIOD if rtf == 0.0 else min(
                FAST_PERIOD * 10, 1.0 / (cfg['publish_rate'] * rtf))
            if cfg['lockstep']:
                # Commands drive the ticks; the timer only starts them and times out.
                period = max(period, LOCKSTEP_POLL)
            self._timer = self.create_timer(period, self._on_clock_timer, clock=self._wall)
            self.core.retimed()
        else:
            self._timer = self.create_timer(1.0 / cfg['publish_rate'], self._on_timer)

    def _on_timer(self):
        """Catch the physics up to the ROS clock and publish; a failure never raises."""
        try:
            self.core.catch_up()
            self._publish_state(self.core.now_ns())
        except Exception as exc:  # noqa: B902  a tick must never end the node
            self._fail_unless_stopping(exc)

    def _on_clock_timer(self):
        """Tick the node-owned clock; a failure marks the muscle broken, never raises."""
        try:
            self.core.clock_tick(self._peers_matched)
        except Exception as exc:  # noqa: B902  a tick must never end the node
            self._fail_unless_stopping(exc)

    def _fail_unless_stopping(self, exc):
        """Fail the episode on exc, unless a signal shut the context down meanwhile."""
        if self.context.ok():
            self.core.episode.fail(f'{type(exc).__name__}: {exc}')

    def _peers_matched(self):
        """Return True when a controller reads the state and writes commands.

        ... and has done so for MATCH_SETTLE s (node_clocks.Settled).
        """
        readers = self._outputs.joint.get_subscription_count() \
            + self._outputs.displacement.get_subscription_count()
        writers = self._power_sub.get_publisher_count() \
            + self._voltage_sub.get_publisher_count()
        return self._settled(readers > 0 and writers > 0)

    def log_time_summary(self):
        """Log the sim time reached and its ratio to wall time (publish_clock mode)."""
        summary = self.core.time_summary()
        if summary is not None:
            sim, wall = summary
            # Not the node's logger: at shutdown its /rosout publisher is already gone.
            rclpy.logging.get_logger('tca.time').info(
                f'simulated {sim:.3f} s in {wall:.3f} s of wall time '
                f'({sim / max(wall, 1e-9):.1f}x real time)')

    # -- outputs ------------------------------------------------------------------------
    def _publish_tick(self, now_ns):
        """Publish /clock and the state of a tick of the own clock."""
        self._publish_clock(now_ns)
        self._publish_state(now_ns)

    def _republish(self):
        """Publish the last tick again (same values): lockstep before the first command."""
        self._publish_clock(self.core.own_clock.sim_ns)
        self._outputs.emit(self.core.episode.sample, self.core.cfg, self._rig)

    def _publish_clock(self, now_ns):
        """Publish /clock if anyone reads it (a use_sim_time node, ros2 topic echo, a bag).

        Unread, it is not sent: a publish costs tens of us, a lockstep tick about 300 us.
        """
        if self._clock_pub.get_subscription_count():
            self._clock_pub.publish(ClockMsg(clock=time_msg(now_ns)))

    def _publish_state(self, now_ns):
        """Sample the state now (stamps = node time, ns), publish it and the shape."""
        ep = self.core.episode
        self._outputs.emit(ep.take_sample(now_ns), ep.cfg, self._rig)
        if ep.failure is None:
            self._outputs.shape(ep.params, ep.sim.state, ep.cfg, now_ns)
        self._diagnostics.update(self.core.muscle_state(now_ns))

    # -- services and parameters ------------------------------------------------------
    def _on_reset(self, request, response):
        try:
            self.core.reset()
        except Exception as exc:  # noqa: B902  a reset request must never end the node
            response.success = False
            response.message = (f'reset failed: {type(exc).__name__}: {exc}'.splitlines()[0]
                                + f' (load {self.core.episode.load:g} N); the muscle stays '
                                'broken')
            self.get_logger().error(response.message, throttle_duration_sec=WARN_PERIOD)
            return response
        response.success = True
        ep = self.core.episode
        response.message = (f'reset to the loaded equilibrium at '
                            f'{ep.sim.state.temperature:g} degC, load {ep.load:g} N')
        self.get_logger().info(response.message)
        self._diagnostics.update()
        return response

    def _on_set_parameters(self, parameters):
        """Check new values against the schema and cross-parameter rules; apply them.

        Never raises: an unexpected error refuses the request with its reason.
        """
        owned = [p for p in parameters if p.name in SPECS or p.name in NODE_SPECS]
        if not owned:
            return SetParametersResult(successful=True)
        try:
            tca_values = {s.name: self.get_parameter(s.name).value for s in SCHEMA}
            node_values = dict(self.core.cfg)
            for p in owned:
                (tca_values if p.name in SPECS else node_values)[p.name] = p.value
            change = self.core.reconfigure(tca_values, node_values, [p.name for p in owned])
            if change.rebuilt:
                ep = self.core.episode
                warm_up_shape(ep.params, ep.sim.state, ep.cfg)
            if change.retime:
                self._make_timer()
            return SetParametersResult(successful=change.successful, reason=change.reason)
        except Exception as exc:  # noqa: B902  a parameter request must never end the node
            reason = f'{type(exc).__name__}: {exc}'.splitlines()[0]
            self.get_logger().error(f'parameter change refused: {reason}',
                                    throttle_duration_sec=WARN_PERIOD)
            return SetParametersResult(successful=False, reason=reason)


def main(args=None):
    """Run the ``tca`` node; return 2 on an invalid parameter (one-line error).

    Params files and ``-p`` rules are checked before rcl reads them, and rcl's own
    refusals are cut to one line too: a bad start never prints a traceback.
    """
    node = None
    try:
        check_ros_arguments(sys.argv if args is None else args)
        install_stop_handlers()  # SIGINT and SIGTERM stop the spin, not rclpy
        init_quietly(args)
        install_disk_cache()  # a conical table's rows solved once, read at the next start
        node = TcaSimNode()
        # The start-up heap (numpy, scipy, rclpy, the model's tables: ~66 000 objects) out
        # of the collector's reach: a full collection of it stops the executor for
        # 0.1-0.3 s on this machine; what the running node allocates is still collected.
        gc.freeze()
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
