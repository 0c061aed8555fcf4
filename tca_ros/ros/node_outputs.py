"""The node's state topics and shape Marker: plain samples turned into messages.

``StateOutputs`` holds the publishers of a ``tca`` node and publishes a
node_episode.Sample to the topics that have readers (messages nobody reads are not
built), and at most shape_rate times per second (sim and wall time) the centreline as a
visualization_msgs/Marker. The QoS of the node's topics are defined here.
"""
import time

from builtin_interfaces.msg import Time as TimeMsg
from geometry_msgs.msg import Point
import numpy as np
from rclpy.qos import QoSProfile
from rclpy.qos_overriding_options import QoSOverridingOptions
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64
from visualization_msgs.msg import Marker

from tca_ros.model.kinetostatic_models import centreline as rod_centreline
from tca_ros.model.kinetostatics import fixed_coil_centreline
from tca_ros.ros.node_clocks import NS

STATE_QOS = QoSProfile(depth=10)  # reliable: serves reliable and best-effort readers
SHAPE_QOS = QoSProfile(depth=1)
COMMAND_QOS = QoSProfile(depth=10)


def time_msg(ns):
    """Return builtin_interfaces/Time for a node time of ``ns`` nanoseconds."""
    return TimeMsg(sec=ns // NS, nanosec=ns % NS)


def ros_point(x, y, z):
    """Return geometry_msgs/Point of x, y, z (m)."""
    return Point(x=float(x), y=float(y), z=float(z))


def rod_shape(params):
    """Return True when the shape comes from the rod solution.

    The rod centreline is the exact one for the rod model and the only one for a
    conical TCA; for cst and love a helix of the current length (fixed coil count)
    shows the same stroke without building the rod table.
    """
    return params.model == 'rod' or params.coil.shape != 'helix'


def warm_up_shape(params, state, cfg):
    """Build the rod centreline's tables now rather than stall the first Marker."""
    if cfg['shape_rate'] > 0.0 and rod_shape(params):
        rod_centreline(params, state.elongation, state.temperature, 2)


class StateOutputs:
    """The state topics (QoS overridable by parameters) and ``shape`` of ``node``."""

    def __init__(self, node):
        self._node = node
        qos_opts = QoSOverridingOptions.with_default_policies()

        def state(msg_type, topic):
            return node.create_publisher(msg_type, topic, STATE_QOS,
                                         qos_overriding_options=qos_opts)
        self.displacement = state(Float64, 'displacement')
        self._temperature = state(Temperature, 'temperature')
        self._resistance = state(Float64, 'resistance')
        self._power = state(Float64, 'power')
        self.joint = state(JointState, 'joint_states')
        self._shape = node.create_publisher(Marker, 'shape', SHAPE_QOS)
        self._next_shape_ns = 0
        self._next_shape_wall = 0.0

    def emit(self, sample, cfg, rig):
        """Publish a Sample to the topics that have readers, and the rig's topics."""
        stamp = time_msg(sample.time_ns)
        if self.joint.get_subscription_count():
            joint = JointState()
            joint.header.stamp = stamp
            joint.name = [cfg['joint_name']]
            joint.position, joint.velocity, joint.effort = rig.joint(
                sample.displacement, sample.rate, sample.tension)
            self.joint.publish(joint)
        if self._temperature.get_subscription_count():
            temp = Temperature()
            temp.header.stamp = stamp
            temp.header.frame_id = cfg['frame_id']
            temp.temperature = sample.temperature
            temp.variance = cfg['noise.temperature'] ** 2
            self._temperature.publish(temp)
        for pub, value in ((self.displacement, sample.displacement),
                           (self._resistance, sample.resistance), (self._power, sample.power)):
            if pub.get_subscription_count():
                pub.publish(Float64(data=value))
        rig.publish(stamp, cfg['frame_id'])

    def shape(self, params, state, cfg, now_ns):
        """Publish the shape Marker if it is due (shape_rate per sim and wall second).

        A viewer needs no more, and a 1000-point Marker costs ~5 ms to build in Python.
        """
        rate = cfg['shape_rate']
        if rate > 0.0 and now_ns >= self._next_shape_ns and \
                time.monotonic() >= self._next_shape_wall and \
                self._shape.get_subscription_count():
            self._next_shape_ns = now_ns + round(NS / rate)
            self._next_shape_wall = time.monotonic() + 1.0 / rate
            self._publish_shape(params, state, cfg, time_msg(now_ns))

    def _publish_shape(self, params, s, cfg, stamp):
        n = int(cfg['shape_points'])
        if rod_shape(params):
            points = rod_centreline(params, s.elongation, s.temperature, n)
        else:
            points = fixed_coil_centreline(params, s.elongation, n)
        marker = Marker()
        marker.header.stamp = stamp
        marker.header.frame_id = cfg['base_frame']
        marker.ns = self._node.get_fully_qualified_name()  # unique per muscle in one RViz
        marker.type = Marker.LINE_STRIP
        marker.action = Marker.ADD
        marker.pose.orientation.w = 1.0
        marker.scale.x = 2.0 * params.fiber.radius  # line width = fiber diameter, m
        hot = min(max((s.temperature - 25.0) / 150.0, 0.0), 1.0)
        marker.color.r, marker.color.g, marker.color.b, marker.color.a = hot, 0.2, 1.0 - hot, 1.0
        marker.points = [ros_point(x, y, z) for x, y, z in np.asarray(points).T]
        self._shape.publish(marker)
