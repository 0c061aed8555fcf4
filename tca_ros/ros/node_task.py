"""Scored tasks played by the ``tca`` node in lockstep (``tca_sim score --namespace``).

A scorer sends a task on ``task`` (std_msgs/Float64MultiArray, layout below): the
reference (m) and the external load (N) at each control tick. If a state awaits its
command, the node lets that command come (or lockstep_timeout pass) and drops it:
an answer to a state from before the task must not count as the answer to its first
one. Then it restarts from the loaded equilibrium at ambient under load[0], its
clock TASK_GAP on (a new episode: no stamp of the task can be one from before, and a
controller sees a gap no tick has, on which it starts afresh: tca_pid restarts on
gaps over 1 s) and, at each tick k, before the state of tick k goes out:

1. sets the load to load[k] (held over [t_k, t_k+1), as the in-process runner does);
2. publishes r_k on ``reference`` (sensor_msgs/JointState: the joint's name,
   position r_k in m, stamped t_k like the state) and on ``displacement_setpoint``
   (std_msgs/Float64, m; unstamped, for controllers that take only a setpoint).

Then it publishes the state of tick k and waits for the controller's command
(lockstep). A controller that answers each state with the reference of the same
stamp (tca_pid -p stamped_reference:=true) answers tick k with r_k whatever the
scheduling: same controller, same scores. Through the unstamped setpoint a state
can overtake its setpoint (two topics, two DDS paths, an executor serving ready
subscriptions in creation order): docs/toolkit.md, section 4.

When the command answering the last state arrives, the node publishes the run on
``task_record`` and holds its clock until the next task (or ``~/reset``).

Layouts (flat float64 arrays, N = ticks + 1 samples):

- task:   [serial, N, reference (N), load (N)]
- record: [serial, missed, extra, broken, N, displacement (N), temperature (N),
  power (N)]; ``missed``: ticks the node advanced after ``lockstep_timeout``
  without a command; ``extra``: commands that came while no tick waited (both
  make a run unrepeatable); ``broken``: 1 if the muscle broke (melted or the
  physics failed); power[k] (W) is the power applied over [t_k, t_k+1), the last
  one the clamped answer to the final state.
"""
import math

from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray

from tca_ros.ros.node_core import TASK_GAP  # noqa: F401  (documented above; the core applies it)
from tca_ros.ros.node_outputs import time_msg

TASK_HEADER = 2  # serial, N
RECORD_HEADER = 5  # serial, missed, extra, broken, N
MAX_TASK_SAMPLES = 1_000_000  # 10^4 s at 100 Hz: a bound on memory, not a physical one
SETPOINT_QOS = QoSProfile(depth=10)
TASK_QOS = QoSProfile(depth=1)
WARN_PERIOD = 1.0  # s between repeats of a throttled warning


def parse_task(data):
    """Return (serial, reference (m), load (N)) of a task array; ValueError if malformed."""
    data = list(data)
    if len(data) < TASK_HEADER or not all(map(math.isfinite, data)):
        raise ValueError('task: needs [serial, N, reference (N), load (N)], all finite')
    samples = data[1]
    if samples != int(samples) or not 2 <= samples <= MAX_TASK_SAMPLES or \
            len(data) != TASK_HEADER + 2 * int(samples):
        raise ValueError(f'task: N = {samples:g} with {len(data)} values; allowed 2 to '
                         f'{MAX_TASK_SAMPLES} and 2 + 2 N values')
    n = int(samples)
    load = data[TASK_HEADER + n:]
    if min(load) < 0.0:
        raise ValueError(f'task: load {min(load):g} N; allowed >= 0 (tensile)')
    return data[0], data[TASK_HEADER:TASK_HEADER + n], load


def task_message(serial, reference, load):
    """Return the Float64MultiArray of a task (reference in m, load in N per tick)."""
    return Float64MultiArray(data=[float(serial), float(len(reference))]
                             + [float(x) for x in reference] + [float(x) for x in load])


def parse_record(data):
    """Return the record as a dict: serial, missed, extra, broken, and the columns."""
    n = int(data[4])
    columns = [list(data[RECORD_HEADER + i * n:RECORD_HEADER + (i + 1) * n])
               for i in range(3)]
    return {'serial': data[0], 'missed': int(data[1]), 'extra': int(data[2]),
            'broken': bool(data[3]), 'displacement': columns[0],
            'temperature': columns[1], 'power': columns[2]}


class TaskPlayer:
    """The node's side of a scored task: reference, load and the record of one run."""

    def __init__(self, node, restart, joint_name):
        """Subscribe to ``task`` on ``node``; ``restart(load)`` starts a run at t = 0.

        ``joint_name()`` returns the joint's name (the node's joint_name).
        """
        self._node = node
        self._restart = restart
        self._joint_name = joint_name
        self._reference_pub = node.create_publisher(JointState, 'reference', SETPOINT_QOS)
        self._setpoint_pub = node.create_publisher(Float64, 'displacement_setpoint',
                                                   SETPOINT_QOS)
        self._record_pub = node.create_publisher(Float64MultiArray, 'task_record', TASK_QOS)
        node.create_subscription(Float64MultiArray, 'task', self._on_task, TASK_QOS)
        self._serial = None
        self.queued = None  # a task received while a state awaited its command
        self._reference = self._load = ()
        self._rows = []  # [displacement (m), temperature (degC), power (W)] per tick
        self.missed = self.extra = 0
        self.holding = False  # a run ended: the clock stays until the next task

    @property
    def active(self):
        """Return True while a task runs."""
        return self._serial is not None

    def _on_task(self, msg):
        try:
            self.queued = parse_task(msg.data)
        except ValueError as exc:
            self._node.get_logger().error(f'{exc}: task ignored',
                                          throttle_duration_sec=WARN_PERIOD)

    def start(self):
        """Start the queued task: the node restarts, TASK_GAP s on, under load[0]."""
        (serial, reference, load), self.queued = self.queued, None
        try:
            self._restart(load[0])
        except Exception as exc:  # noqa: B902  a task must never end the node
            self._node.get_logger().error(f'{exc}'.splitlines()[0] + ': task ignored',
                                          throttle_duration_sec=WARN_PERIOD)
            return
        self._serial, self._reference, self._load = serial, reference, load
        self._rows = []
        self.missed = self.extra = 0
        self.holding = False
        self._node.get_logger().info(f'task {serial:g}: {len(reference)} ticks')

    def before_state(self, now_ns):
        """Publish r_k stamped ``now_ns`` (node time, ns); return load_k (N)."""
        k = len(self._rows)
        reference = float(self._reference[k])
        msg = JointState(name=[self._joint_name()], position=[reference])
        msg.header.stamp = time_msg(now_ns)
        self._reference_pub.publish(msg)
        self._setpoint_pub.publish(Float64(data=reference))
        return float(self._load[k])

    def after_state(self, displacement, temperature, power):
        """Record tick k's published state and the power (W) applied over the last tick."""
        if self._rows:
            self._rows[-1][2] = power
        self._rows.append([displacement, temperature, 0.0])

    def at_end(self):
        """Return True when every state of the task has gone out."""
        return self.active and len(self._rows) == len(self._reference)

    def finish(self, power, broken):
        """Record the answer (W) to the last state, publish the record, hold the clock."""
        self._rows[-1][2] = power
        columns = [float(row[i]) for i in range(3) for row in self._rows]
        self._record_pub.publish(Float64MultiArray(data=[
            float(self._serial), float(self.missed), float(self.extra), float(broken),
            float(len(self._rows))] + columns))
        self._node.get_logger().info(f'task {self._serial:g} done: {self.missed} missed, '
                                     f'{self.extra} extra commands')
        self._serial = None
        self.holding = True
