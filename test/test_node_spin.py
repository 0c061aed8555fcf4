"""spin_resiliently: an event that fails inside the executor costs that event, not the node;
a stop signal ends the spin with the executor torn down cleanly."""
import gc
import os
import pathlib
import signal
import subprocess
import sys

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from tca_ros.ros.node_spin import spin_resiliently

ROOT = pathlib.Path(__file__).resolve().parents[1]


class FlakyExecutor(SingleThreadedExecutor):
    """Raise rclpy's take_message error on the first events, then stop the context."""

    def __init__(self, context, failures):
        super().__init__(context=context)
        self.failures = failures
        self.calls = 0

    def spin_once(self, timeout_sec=None):
        self.calls += 1
        if self.calls <= self.failures:
            raise RuntimeError("Unable to convert call argument '0' to Python object")
        self.context.try_shutdown()


def test_a_failing_take_is_dropped_and_counted_and_the_spin_goes_on():
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node('spin_probe', context=context)
    try:
        executor = FlakyExecutor(context, failures=3)
        assert spin_resiliently(node, executor) == 3
        assert executor.calls == 4  # three dropped events, then the stop
    finally:
        node.destroy_node()
        context.try_shutdown()


def test_a_stop_while_the_executor_is_built_ends_the_spin_quietly(monkeypatch):
    unraisable = []
    monkeypatch.setattr(sys, 'unraisablehook', unraisable.append)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node('spin_probe_stopped', context=context)
    try:
        context.try_shutdown()  # SIGTERM's handler, arriving just before the spin
        assert spin_resiliently(node) == 0
        gc.collect()
        assert unraisable == []  # no 'Exception ignored in Executor.__del__' traceback
        with pytest.raises(Exception):
            SingleThreadedExecutor(context=context)  # rclpy's own: fails on a stopped context
    finally:
        node.destroy_node()


STOP_MID_REGISTRATION = """
import os, signal, sys
import rclpy
from rclpy.event_handler import EventHandler
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Float64
from tca_ros.ros import node_spin

node_spin.install_stop_handlers()
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
node = rclpy.create_node('spin_stop_probe')
for topic in ('a', 'b', 'c'):
    node.create_publisher(Float64, topic, 10)  # each with QoS event handlers (waitables)
node.create_timer(0.01, lambda: None)
calls = []
register = EventHandler.get_num_entities


def get_num_entities(self):
    calls.append(self)
    if len(calls) == 2:  # the EventsExecutor's first spin registers the event handlers
        os.kill(os.getpid(), getattr(signal, sys.argv[1]))
    return register(self)


EventHandler.get_num_entities = get_num_entities
dropped = node_spin.spin_resiliently(node)
print(f'spin ended: {dropped} dropped, stops {node_spin._STOPS}, ok {rclpy.ok()}', flush=True)
node.destroy_node()
rclpy.try_shutdown()
"""


@pytest.mark.parametrize('signal_name', ['SIGINT', 'SIGTERM'])
def test_a_stop_while_the_events_executor_registers_the_node_ends_the_spin_cleanly(
        signal_name, tmp_path):
    """The signal lands inside the EventsExecutor's registration of the node's entities.

    With rclpy's handlers (context shut down from another thread) or Python's
    KeyboardInterrupt there, the registration stops half way and the process aborts
    ('Destroying callback manager with callbacks remaining') when the executor goes.
    """
    env = dict(os.environ, TCA_EXECUTOR='events', PYTHONPATH=os.pathsep.join(
        [str(ROOT), os.environ.get('PYTHONPATH', '')]))
    script = tmp_path / 'stop_mid_registration.py'
    script.write_text(STOP_MID_REGISTRATION)
    result = subprocess.run([sys.executable, str(script), signal_name], env=env,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stdout + result.stderr
    number = int(getattr(signal, signal_name))
    assert f'spin ended: 0 dropped, stops [{number}], ok True' in result.stdout, result.stdout
    assert 'callback manager' not in result.stdout + result.stderr
