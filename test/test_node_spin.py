"""spin_resiliently: an event that fails inside the executor costs that event, not the node."""
import gc
import sys

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from tca_ros.ros.node_spin import spin_resiliently


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
