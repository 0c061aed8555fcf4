"""The inputs of the ``tca`` node: commands, the load and the reset request.

``power_cmd`` (W) and ``voltage_cmd`` (V) set the drive, ``load`` (N) the
tensile load and ``~/reset`` returns to the loaded equilibrium. A non-finite
value is refused with a throttled warning (the last valid one is kept); a value
outside the configured range is clamped with a warning naming it. In node time a
command first brings the physics up to now, so the old one holds until it lands.
"""
import math

from rclpy.qos import QoSProfile
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from tca_ros.node_clock import WARN_PERIOD

COMMAND_QOS = QoSProfile(depth=10)


class InputsMixin:
    """Subscriptions, their callbacks and the reset service of TcaSimNode."""

    def _create_inputs(self):
        """Subscribe to power_cmd, voltage_cmd and load; offer ~/reset."""
        self._power_sub = self.create_subscription(Float64, 'power_cmd', self._on_power_cmd,
                                                   COMMAND_QOS)
        self._voltage_sub = self.create_subscription(Float64, 'voltage_cmd',
                                                     self._on_voltage_cmd, COMMAND_QOS)
        self.create_subscription(Float64, 'load', self._on_load, COMMAND_QOS)
        self.create_service(Trigger, '~/reset', self._on_reset)

    def _valid(self, topic, value):
        if math.isfinite(value):
            return True
        self.get_logger().warning(f'{topic}: rejected non-finite value {value}; '
                                  'keeping the last valid one',
                                  throttle_duration_sec=WARN_PERIOD)
        return False

    def _command(self, kind, value):
        if self._task.queued and self._awaiting_command:
            self._awaiting_command = False  # the answer to the state before the task
            self._task.start()
            return
        self._task.extra += self._task.active and self._started and not self._awaiting_command
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
        self._task.holding = False  # a scored run's hold ends: lockstep goes on
        response.success = True
        response.message = (f'reset to the loaded equilibrium at '
                            f'{self._sim.state.temperature:g} degC, load {self._load:g} N')
        self.get_logger().info(response.message)
        self._diagnostics.update()
        return response
