"""Harness of the node tests: nodes in subprocesses, a probe node in the test process.

No launch_testing on PyPI: each test session picks a random ROS_DOMAIN_ID and limits
discovery to localhost before rclpy starts, runs ``tca_node`` / ``tca_pid`` with the
venv's own python (output redirected to a file, never a pipe), and stops them with
SIGINT, then SIGKILL after a few seconds. This module holds no tests.
"""
import atexit
import math
import os
import pathlib
import random
import signal
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
CONFIG = ROOT / 'config' / 'free_stroke.yaml'
PYTHON = sys.executable
STOP_GRACE = 5.0  # s between SIGINT and SIGKILL
READY_TIMEOUT = 30.0  # s for a node to log 'ready' (the rod table takes ~2 s on 2 cores)


def _test_domain():
    """Return a ROS_DOMAIN_ID for this test process: random per run, distinct per worker.

    xdist workers run node tests of different files at the same time; they share the
    run's PYTEST_XDIST_TESTRUNUID, so one base drawn from it plus the worker's index
    keeps them apart (two independent draws in 20-99 would collide in 1 run of 80).
    """
    run = os.environ.get('PYTEST_XDIST_TESTRUNUID')
    worker = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
    if run is None:
        return random.randint(20, 99)
    base = 20 + random.Random(run).randrange(0, 70, 10)  # 20, 30, ..., 80
    return base + int(worker.lstrip('gw') or 0) % 10


# One domain per test process, set before rclpy is initialised anywhere.
os.environ.setdefault('TCA_TEST_DOMAIN', str(_test_domain()))
os.environ['ROS_DOMAIN_ID'] = os.environ['TCA_TEST_DOMAIN']
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'

import rclpy  # noqa: E402  (after the domain is chosen)
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import QoSProfile  # noqa: E402

from tca_ros.ros.service_call import answer_of  # noqa: E402


class NodeProcess:
    """A node run in a subprocess, its output in a log file."""

    def __init__(self, command, log_path, env=None, cwd=ROOT):
        self.log_path = pathlib.Path(log_path)
        self._log = open(self.log_path, 'w')
        self.proc = subprocess.Popen(
            [str(c) for c in command], stdout=self._log, stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL, env=env or os.environ.copy(), cwd=cwd)

    def log(self):
        """Return the output so far."""
        return self.log_path.read_text()

    def wait_for_log(self, text, timeout=READY_TIMEOUT):
        """Wait until ``text`` appears in the output; fail if the process exits first."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.log():
                return
            if self.proc.poll() is not None:
                raise AssertionError(f'node exited ({self.proc.returncode}):\n{self.log()}')
            time.sleep(0.05)
        raise AssertionError(f'no {text!r} within {timeout} s:\n{self.log()}')

    def stop(self):
        """SIGINT, then SIGKILL after STOP_GRACE; return the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(STOP_GRACE)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._log.close()
        return self.proc.returncode


def module_command(module, ros_args):
    """Return the command line running ``module`` with the venv's python."""
    return [PYTHON, '-m', module, '--ros-args', *ros_args]


def start_tca(log_dir, *args, name='tca', params_file=CONFIG, wait=True):
    """Start tca_node with the cst model (fast start-up) plus ``args`` (--ros-args)."""
    ros_args = ['--params-file', str(params_file)] if params_file else []
    ros_args += ['-p', 'model:=cst', *args]
    node = NodeProcess(module_command('tca_ros.ros.node', ros_args),
                       pathlib.Path(log_dir) / f'{name}.log')
    if wait:
        try:
            node.wait_for_log('tca node ready')
        except AssertionError:
            node.stop()
            raise
    return node


def ensure_rclpy():
    """Initialise rclpy once per test session."""
    if not rclpy.ok():
        rclpy.init()
        atexit.register(rclpy.try_shutdown)


class Probe(Node):
    """Test-side node: publishes commands, records what the simulator publishes."""

    def __init__(self, namespace=''):
        ensure_rclpy()
        super().__init__(f'probe_{random.randint(0, 10 ** 9)}', namespace=namespace)
        self._exec = SingleThreadedExecutor()
        self._exec.add_node(self)
        self.records = {}
        self._pubs = {}
        self._subs = {}

    def record(self, topic, msg_type, depth=10000, qos=None):
        """Record (receive time s, message) of ``topic``; return the list."""
        rows = self.records.setdefault(topic, [])
        self._subs[topic] = self.create_subscription(
            msg_type, topic, lambda m: rows.append((time.monotonic(), m)),
            qos or QoSProfile(depth=depth))
        return rows

    def wait_matched(self, *topics, timeout=30.0):
        """Wait until each recorded topic has a matched publisher (discovery done)."""
        assert self.spin_until(
            lambda: all(self._subs[t].get_publisher_count() > 0 for t in topics), timeout), \
            f'no publisher matched on {topics} within {timeout} s'

    def publish(self, topic, msg):
        """Publish msg on topic (publisher created on first use, matched before sending)."""
        if topic not in self._pubs:
            pub = self.create_publisher(type(msg), topic, QoSProfile(depth=10))
            self._pubs[topic] = pub
            self.spin_until(lambda: pub.get_subscription_count() > 0, 10.0)
        self._pubs[topic].publish(msg)

    def spin_for(self, seconds):
        """Process callbacks for ``seconds`` of wall time."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self._exec.spin_once(timeout_sec=0.01)

    def spin_until(self, predicate, timeout):
        """Process callbacks until predicate() holds; return whether it did."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if predicate():
                return True
            self._exec.spin_once(timeout_sec=0.01)
        return predicate()

    def call(self, client, request, timeout=10.0):
        """Call a service and return its response (AssertionError after timeout s).

        The request (every one the tests send is idempotent) goes again every 2 s
        (service_call.answer_of), as ``tca_sim score`` sends it: on a loaded machine
        Fast DDS can drop the response to a client its server has not discovered yet.
        """
        assert client.wait_for_service(timeout_sec=timeout), 'service not available'
        response = answer_of(lambda: client.call_async(request), self.spin_until, timeout,
                             client.remove_pending_request)
        assert response is not None, f'no service response in {timeout:g} s'
        return response

    def set_params(self, node_name, **values):
        """Set parameters of a remote node; return the SetParametersResult list."""
        from rcl_interfaces.srv import SetParameters
        client = self.create_client(SetParameters, f'{node_name}/set_parameters')
        request = SetParameters.Request(parameters=[
            Parameter(name.replace('__', '.'), value=v).to_parameter_msg()
            for name, v in values.items()])
        return self.call(client, request).results

    def close(self):
        """Destroy the probe."""
        self._exec.remove_node(self)
        self.destroy_node()


def last_value(rows):
    """Return the data of the last Float64 recorded."""
    return rows[-1][1].data


def stamp_seconds(header):
    """Return a header stamp in seconds."""
    return header.stamp.sec + 1e-9 * header.stamp.nanosec


def finite(x):
    """Return True for a finite float."""
    return math.isfinite(x)
