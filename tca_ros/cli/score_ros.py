"""Score a controller that runs on ROS topics: ``tca_sim score --namespace NS``.

The scorer sends each task to the ``tca`` node in NS (tca_ros.ros.node_task), which plays
it in lockstep against whatever controller answers its states, and gets the run back
on ``task_record``; the metrics are those of the in-process runner
(tca_ros.toolkit.scoring), from the same reference and load. The node must own the
clock in lockstep (``publish_clock``, ``lockstep``) with the dead-weight rig; the
scorer reads the node's parameters (the muscle, rates, limits) from the node itself.
Every wait is bounded by ``timeout`` seconds of wall time without progress.
"""
import os
import random
import subprocess
import sys
import time

from rcl_interfaces.srv import GetParameters
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Float64, Float64MultiArray

from tca_ros.cli.common import InputError, stop_gracefully
from tca_ros.model.params_schema import SCHEMA
from tca_ros.model.tca_params import from_flat_dict
from tca_ros.ros.node_task import parse_record, task_message, TASK_QOS
from tca_ros.ros.service_call import answer_of
from tca_ros.toolkit.scoring import scored_run, task_inputs

NODE_SETTINGS = ('publish_clock', 'lockstep', 'publish_rate', 'max_temperature', 'max_power')
PROGRESS_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)  # not acked
STOP_GRACE = 5.0  # s between SIGINT and SIGKILL of a node the scorer started
SPIN_STEP = 0.01  # s, executor wait per turn


class RosScorer(Node):
    """The scorer's node in the namespace of the ``tca`` node it drives."""

    def __init__(self, namespace, node_name='tca', timeout=10.0):
        super().__init__(f'tca_score_{random.randint(0, 10 ** 9)}', namespace=namespace)
        self.timeout = timeout  # s of wall time without progress before giving up
        self._where = self.get_namespace().rstrip('/')
        self.target = f'{self._where}/{node_name}'
        self._task_pub = self.create_publisher(Float64MultiArray, 'task', TASK_QOS)
        self.create_subscription(Float64MultiArray, 'task_record', self._on_record, TASK_QOS)
        self.create_subscription(Float64, 'displacement_setpoint', self._on_progress,
                                 PROGRESS_QOS)
        self._params_client = self.create_client(GetParameters,
                                                 f'{node_name}/get_parameters')
        self._executor = SingleThreadedExecutor(context=self.context)
        self._executor.add_node(self)
        self._records = {}
        self._ticks = 0  # setpoints seen in the current task
        self._serial0 = random.randint(1, 10 ** 6)

    def _on_record(self, msg):
        record = parse_record(msg.data)
        self._records[record['serial']] = record

    def _on_progress(self, _msg):
        self._ticks += 1
        self._last_progress = time.monotonic()

    def _spin_until(self, predicate, timeout):
        """Serve callbacks until predicate() holds (True) or timeout s pass (False)."""
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > deadline:
                return False
            self._executor.spin_once(timeout_sec=SPIN_STEP)
        return True

    def node_parameters(self, discovery=None):
        """Return {name: value} of the node's muscle and lockstep settings.

        ``discovery``: seconds to wait for the node to be discovered (default: timeout).
        """
        names = [spec.name for spec in SCHEMA] + list(NODE_SETTINGS)
        discovery = self.timeout if discovery is None else discovery
        found = self._spin_until(
            lambda: self._task_pub.get_subscription_count() > 0
            and self._params_client.service_is_ready(), discovery)
        if not found:
            raise InputError(f'no tca node answers in {self._where or "/"} within '
                             f'{discovery:g} s (nothing reads {self._where}/task; start '
                             'one, or use --start-node)')
        client = self._params_client
        response = answer_of(lambda: client.call_async(GetParameters.Request(names=names)),
                             self._spin_until, self.timeout, client.remove_pending_request)
        if response is None:
            raise InputError(f'{self.target}: no answer to get_parameters within '
                             f'{self.timeout:g} s')
        values = dict(zip(names, map(parameter_value_to_python, response.values)))
        for name in ('publish_clock', 'lockstep'):
            if values[name] is not True:
                raise InputError(f'{self.target}: {name} = {values[name]!r}; scoring '
                                 'needs publish_clock and lockstep true (-p publish_clock:='
                                 'true -p lockstep:=true -p real_time_factor:=0.0)')
        if values['rig.mode'] != 'dead_weight':
            raise InputError(f"{self.target}: rig.mode = {values['rig.mode']!r}; the "
                             "tasks need the dead_weight rig (their load is the weight's)")
        return values

    def wait_for_controller(self):
        """Wait until a controller writes power_cmd or voltage_cmd and reads the state.

        Returns True when something reads the stamped ``reference`` (a run that
        repeats exactly), False when the controller can only take the unstamped
        setpoint.
        """
        def present():
            writers = sum(self.count_publishers(f'{self._where}/{topic}')
                          for topic in ('power_cmd', 'voltage_cmd'))
            readers = sum(self.count_subscribers(f'{self._where}/{topic}')
                          for topic in ('joint_states', 'displacement'))
            return writers > 0 and readers > 0
        if not self._spin_until(present, self.timeout):
            raise InputError(f'no controller in {self._where or "/"} within {self.timeout:g} '
                             f's (nothing publishes {self._where}/power_cmd or voltage_cmd and '
                             'reads joint_states or displacement)')
        return self.count_subscribers(f'{self._where}/reference') > 0

    def play(self, task, t, reference, load):
        """Send one task to the node; return its record (tca_ros.ros.node_task layout)."""
        serial = float(self._serial0 + len(self._records))
        self._ticks, self._last_progress = 0, time.monotonic()
        self._task_pub.publish(task_message(serial, reference, load))
        while serial not in self._records:
            self._executor.spin_once(timeout_sec=SPIN_STEP)
            if time.monotonic() - self._last_progress > self.timeout:
                raise InputError(
                    f'no controller answered in {self._where or "/"} within '
                    f'{self.timeout:g} s (task {task.name}: {self._ticks} of {len(t)} ticks '
                    'done)')
        record = self._records[serial]
        if record['missed'] or record['extra']:
            raise InputError(
                f"task {task.name}: the controller missed {record['missed']} ticks "
                f"(no command within the node's lockstep_timeout) and sent "
                f"{record['extra']} unasked commands: not a lockstep run, scores not "
                'repeatable (one command per state, please)')
        return record

    def close(self):
        """Destroy the scorer's node and executor."""
        self._executor.remove_node(self)
        self._executor.shutdown()
        self.destroy_node()


def score_over_ros(tasks, namespace, node_name='tca', timeout=10.0, discovery=None,
                   before_task=None):
    """Run ``tasks`` on the ``tca`` node in ``namespace``; return (runs, node parameters).

    ``discovery`` (s, default ``timeout``) bounds the wait for the node to be found.
    ``before_task(task, params, values)``, when given, is called before each task
    with the node's muscle and settings; what it returns is the run's 'limits'.

    Each run is the dict of tca_ros.toolkit.scoring.scored_run plus 'broken' (the
    muscle broke during the task). Raises InputError (one line) when no node or no
    controller answers within ``timeout`` s of wall time, or the node cannot play tasks.
    """
    owns_rclpy = not rclpy.ok()
    if owns_rclpy:
        rclpy.init()
    scorer = RosScorer(namespace, node_name, timeout)
    try:
        values = scorer.node_parameters(discovery)
        params = from_flat_dict({spec.name: values[spec.name] for spec in SCHEMA},
                                source=f'{scorer.target} parameters')
        values['stamped_reference'] = scorer.wait_for_controller()
        runs = []
        for task in tasks:
            limits = before_task(task, params, values) if before_task else None
            t, reference, load = task_inputs(task, params, params.model,
                                             values['publish_rate'], values['max_temperature'])
            record = scorer.play(task, t, reference, load)
            run = scored_run(task, t, reference, load, record['displacement'],
                             record['temperature'], record['power'],
                             values['max_temperature'])
            run['broken'] = record['broken']
            if limits is not None:
                run['limits'] = limits
            runs.append(run)
        return runs, values
    finally:
        scorer.close()
        if owns_rclpy:
            rclpy.try_shutdown()


def start_node(namespace, config, model, log_path, timeout):
    """Start tca_node in ``namespace`` for scoring (own clock, lockstep, as fast as it can).

    Returns the Popen once the node logs 'ready'; InputError (with the node's last
    log line) if it exits or stays silent for ``timeout`` s.
    """
    command = [sys.executable, '-m', 'tca_ros.ros.node', '--ros-args', '-r',
               f'__ns:={namespace}', '--params-file', config, '-p', 'publish_clock:=true',
               '-p', 'lockstep:=true', '-p', 'real_time_factor:=0.0']
    if model:
        command += ['-p', f'model:={model}']
    log = open(log_path, 'w')
    proc = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL)
    log.close()
    deadline = time.monotonic() + timeout
    while True:
        with open(log_path) as fh:
            text = fh.read()
        if 'tca node ready' in text:
            return proc
        if proc.poll() is not None or time.monotonic() > deadline:
            stop_node(proc)
            last = (text.strip().splitlines() or ['no output'])[-1]
            raise InputError(f'tca_node did not start within {timeout:g} s: {last}')
        time.sleep(0.05)


def stop_node(proc):
    """SIGINT, then SIGKILL after STOP_GRACE s; return the exit code."""
    return stop_gracefully(proc, STOP_GRACE)


def default_log_path(out_dir):
    """Return where a started node logs: DIR/tca_node.log, or a file in /tmp."""
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
        return os.path.join(out_dir, 'tca_node.log')
    return os.path.join('/tmp', f'tca_score_node_{os.getpid()}.log')
