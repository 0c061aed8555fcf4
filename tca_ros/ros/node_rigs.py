"""The rig's own topics on the ``tca`` node (rig.mode; docs/rigs.md, docs/node.md).

- spring, isometric: ``force`` (std_msgs/Float64, N), the TCA tension a gauge in
  series reads (isometric: the force the clamp holds), also the effort of
  ``joint_states``;
- antagonistic: ``antagonist/power_cmd`` in (W, clamped to [0, max_power], zero
  after ``command_timeout`` as ``power_cmd``); out ``force`` and
  ``antagonist/force`` (N), ``antagonist/temperature`` (degC), and
  ``joint_states`` of the joint (position theta rad, velocity rad/s, effort the
  muscles' net torque N m) instead of the muscle's.

The dead weight (the default) adds nothing. The node builds one RigTopics and
calls ``drive`` before stepping, ``sample`` when it samples the state and
``publish`` when it publishes.
"""
import math

from rclpy.qos_overriding_options import QoSOverridingOptions
from sensor_msgs.msg import Temperature
from std_msgs.msg import Float64

from tca_ros.model.rigs import ANTAGONISTIC, ISOMETRIC, SPRING
from tca_ros.ros.node_clocks import NS
from tca_ros.ros.node_episode import WARN_PERIOD
from tca_ros.ros.node_outputs import COMMAND_QOS, STATE_QOS  # as the node's own topics


class RigTopics:
    """Publishers and the antagonist's command of one rig on ``node``."""

    def __init__(self, node, mode, settings, command_time):
        self._node = node
        self.mode = mode
        self._settings = settings  # () -> the node's validated parameters (dict)
        self._command_time = command_time  # () -> node time (ns), physics caught up
        self._pubs = {}
        self._power_2 = 0.0  # W, last valid antagonist command
        self._command_ns = None  # node time of that command
        self._timed_out = False
        self._values = {}
        opts = QoSOverridingOptions.with_default_policies()
        if mode in (SPRING, ISOMETRIC, ANTAGONISTIC):
            self._pubs['force'] = node.create_publisher(Float64, 'force', STATE_QOS,
                                                        qos_overriding_options=opts)
        if mode == ANTAGONISTIC:
            self._pubs['force_2'] = node.create_publisher(
                Float64, 'antagonist/force', STATE_QOS, qos_overriding_options=opts)
            self._pubs['temperature_2'] = node.create_publisher(
                Temperature, 'antagonist/temperature', STATE_QOS, qos_overriding_options=opts)
            node.create_subscription(Float64, 'antagonist/power_cmd', self._on_power_2,
                                     COMMAND_QOS)

    # -- input ----------------------------------------------------------------------
    def _on_power_2(self, msg):
        log = self._node.get_logger()
        if not math.isfinite(msg.data):
            log.warning(
                f'antagonist/power_cmd: rejected non-finite value {msg.data}; keeping the '
                'last valid one', throttle_duration_sec=WARN_PERIOD)
            return
        limit = self._settings()['max_power']
        if not 0.0 <= msg.data <= limit:
            log.warning(
                f'antagonist/power_cmd {msg.data:g} W outside [0, {limit:g}] W: clamped',
                throttle_duration_sec=WARN_PERIOD)
        # the old command holds up to now (zero-order hold)
        self._command_ns = self._command_time()
        self._power_2 = min(max(msg.data, 0.0), limit)
        self._timed_out = False

    def drive(self, sim, now_ns, broken):
        """Set the antagonist's power (W) of an antagonistic sim for the coming steps."""
        if self.mode != ANTAGONISTIC:
            return
        settings = self._settings()
        timeout = settings['command_timeout']
        stale = self._command_ns is not None and timeout > 0.0 and \
            now_ns - self._command_ns > timeout * NS
        if stale and not self._timed_out:
            self._timed_out = True
            self._node.get_logger().warning(
                f'no antagonist/power_cmd for {timeout:g} s: antagonist power set to 0',
                throttle_duration_sec=WARN_PERIOD)
        sim.power_2 = 0.0 if broken or stale else min(self._power_2, settings['max_power'])

    def hottest(self, sim):
        """Return the highest muscle temperature (degC) of the rig, for the limits."""
        if self.mode == ANTAGONISTIC:
            return max(sim.state.temperature, sim.antagonist.state.temperature)
        return sim.state.temperature

    # -- outputs --------------------------------------------------------------------
    def sample(self, sim, broken):
        """Take the rig's outputs now; a broken rig pulls with no force."""
        if self.mode not in (SPRING, ISOMETRIC, ANTAGONISTIC):
            return
        values = dict(sim.outputs())
        if broken:
            values.update(force=0.0, force_2=0.0, torque=0.0, angular_velocity=0.0,
                          angle=self._values.get('angle', values.get('angle')))
        self._values = values

    def joint(self, displacement, rate, tension):
        """Return (position, velocity, effort) of joint_states: the joint's for the pair.

        On the spring rig the effort is the TCA tension, not the spring-and-TCA force
        the stepper carries.
        """
        v = self._values
        if self.mode == ANTAGONISTIC:
            return [v['angle']], [v['angular_velocity']], [v['torque']]
        if self.mode == SPRING:
            return [displacement], [rate], [v['force']]
        return [displacement], [rate], [tension]

    def publish(self, stamp, frame_id):
        """Publish the last sample to the rig topics that have readers.

        The antagonist's temperature is stamped in frame ``<frame_id>_antagonist``.
        """
        for name in ('force', 'force_2'):
            pub = self._pubs.get(name)
            if pub is not None and pub.get_subscription_count():
                pub.publish(Float64(data=float(self._values[name])))
        pub = self._pubs.get('temperature_2')
        if pub is not None and pub.get_subscription_count():
            msg = Temperature()
            msg.header.stamp = stamp
            msg.header.frame_id = frame_id + '_antagonist'
            msg.temperature = float(self._values['temperature_2'])
            pub.publish(msg)
