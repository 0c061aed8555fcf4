"""The node's outputs: the sampled state on its topics, the shape Marker, /diagnostics.

A mixin of tca_ros.node.TcaSimNode: each tick samples the simulator's state (with the
configured sensor noise, drawn whoever listens), publishes it to the topics that have
readers, and at most shape_rate times per second the centreline as a Marker. Uses the
node's _cfg, _sim, _params, _rig, _diagnostics and the publishers made in __init__.
"""
import math
import time

from geometry_msgs.msg import Point
import numpy as np
from rclpy.qos import QoSProfile
from rclpy.qos_overriding_options import QoSOverridingOptions
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64
from visualization_msgs.msg import Marker

from tca_ros.model.kinetostatic_models import centreline as rod_centreline
from tca_ros.model.kinetostatics import fixed_coil_centreline
from tca_ros.node_clock import NS, time_msg
from tca_ros.node_diagnostics import MuscleState

_CHECKED = ('temperature', 'elongation', 'velocity', 'tension', 'measured_displacement',
            'resistance')


def non_finite(state):
    """Return the name of the first non-finite field of a TcaState, or ''."""
    for name in _CHECKED:
        if not math.isfinite(getattr(state, name)):
            return name
    return ''


def ros_point(x, y, z):
    """Return geometry_msgs/Point of x, y, z (m)."""
    return Point(x=float(x), y=float(y), z=float(z))


STATE_QOS = QoSProfile(depth=10)  # reliable: serves reliable and best-effort readers
SHAPE_QOS = QoSProfile(depth=1)


class OutputsMixin:
    """State topics, shape Marker and /diagnostics of TcaSimNode."""

    def _create_output_publishers(self):
        """Create the state topics (QoS overridable by parameters) and ``shape``."""
        qos_opts = QoSOverridingOptions.with_default_policies()

        def state(msg_type, topic):
            return self.create_publisher(msg_type, topic, STATE_QOS,
                                         qos_overriding_options=qos_opts)
        self._disp_pub = state(Float64, 'displacement')
        self._temp_pub = state(Temperature, 'temperature')
        self._res_pub = state(Float64, 'resistance')
        self._power_pub = state(Float64, 'power')
        self._joint_pub = state(JointState, 'joint_states')
        self._shape_pub = self.create_publisher(Marker, 'shape', SHAPE_QOS)

    def _muscle_state(self, now_ns=None):
        """Return the MuscleState that /diagnostics reports (model values, no noise)."""
        s, cfg = self._sim.state, self._cfg
        if self._owns_time:
            waiting = '' if self._started else (
                'a controller (lockstep)' if cfg['lockstep'] else 'the first tick')
        else:  # the clock read costs ~10 us: a tick passes its own time
            now = self._now_ns() if now_ns is None else now_ns
            waiting = 'the first /clock message' if now == 0 else ''
        if self._table_wait is not None and not waiting:
            waiting = f'the rod table row at {self._table_wait:g} degC'
        return MuscleState(
            temperature=s.temperature if self._failure is None else self._last_good[2],
            power=self._power, load=self._load,
            displacement=self._frozen[0] if self._broken else s.measured_displacement,
            max_temperature=cfg['max_temperature'], melt_temperature=cfg['melt_temperature'],
            command_timeout=cfg['command_timeout'], overheated=self._overheated,
            broken=self._broken, broken_cause=self._broken_cause,
            watchdog_tripped=self._watchdog_tripped,
            failure=self._failure, waiting=waiting)

    def _noise(self, key):
        std = self._cfg['noise.' + key]
        return float(self._rng.normal(0.0, std)) if std > 0.0 else 0.0

    def _publish_state(self, now_ns):
        """Sample the state now (stamps = physics time, ns), publish it and the shape."""
        s = self._sim.state
        if not self._broken and non_finite(s):  # e.g. a state set by a failed reset
            self._fail(f'{non_finite(s)} = {getattr(s, non_finite(s))!r} (non-finite state)')
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
        self._sample = (time_msg(now_ns), displacement, rate, tension, res, temperature,
                        self._power)
        self._rig.sample(self._sim, self._broken)
        self._emit_sample()
        rate = self._cfg['shape_rate']
        if rate > 0.0 and self._failure is None and now_ns >= self._next_shape_ns and \
                time.monotonic() >= self._next_shape_wall and \
                self._shape_pub.get_subscription_count():
            # At most shape_rate per sim second and per wall second: a viewer needs no
            # more, and a 1000-point Marker costs ~5 ms to build in Python.
            self._next_shape_ns = now_ns + round(NS / rate)
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
        marker.points = [ros_point(x, y, z) for x, y, z in np.asarray(points).T]
        self._shape_pub.publish(marker)
