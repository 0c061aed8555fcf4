"""Spin a node so that nothing a peer sends can end it.

``rclpy.spin`` lets an exception raised while the executor takes a message (inside
rclpy, before any callback of ours runs) escape and end the process: seen once as
"RuntimeError: Unable to convert call argument '0' to Python object" from
``take_message``. Here each event is taken on its own; such a failure costs that one
event, is logged (throttled) and counted, and the node keeps serving.

A stop signal can also land while the executor is being built (just after the node
logs that it is ready): rclpy's constructor then fails on the shut-down context and
its ``__del__`` prints an AttributeError traceback for the half-built object. That
case is a stop too, and ends quietly.
"""
import os

from rclpy._rclpy_pybind11 import RCLError
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor

LOG_PERIOD = 1.0  # s between repeats of the dropped-event error
#: default of TCA_EXECUTOR: 'single' or 'events'. rclpy's EventsExecutor (experimental in
#: Jazzy) aborted a tca_node process on stop once in four clean-clone test runs ('Destroying
#: callback manager with callbacks remaining'), so it is opt-in
EXECUTOR = 'single'


class StopSafeExecutor(SingleThreadedExecutor):
    """rclpy's single-threaded executor whose finaliser accepts a half-built object."""

    def __del__(self):
        if getattr(self, '_sigint_gc', None) is not None:
            super().__del__()


def new_executor(context):
    """Return the executor of ``context``, or None if a stop shut the context meanwhile.

    The StopSafeExecutor, or with TCA_EXECUTOR=events rclpy's EventsExecutor (C++ event
    queue; lockstep with tca_pid runs ~7x faster, bench/bench_node.py, but it can abort
    the process on stop: EXECUTOR).
    """
    try:
        if os.environ.get('TCA_EXECUTOR', EXECUTOR) == 'events':
            return EventsExecutor(context=context)
        return StopSafeExecutor(context=context)
    except Exception:  # noqa: B902  rclpy fails with TypeError or RCLError here
        if context.ok():
            raise
        return None


def spin_resiliently(node, executor=None):
    """Spin ``node`` until shutdown; return the number of executor events dropped.

    KeyboardInterrupt and ExternalShutdownException end the spin as ``rclpy.spin``
    does; an RCLError after the context was shut down (a stop) ends it quietly.
    """
    executor = executor or new_executor(node.context)
    if executor is None:
        return 0  # stopped before the spin began
    executor.add_node(node)
    dropped = 0
    try:
        while node.context.ok():
            try:
                executor.spin_once(timeout_sec=0.5)
            except (KeyboardInterrupt, ExternalShutdownException):
                raise
            except Exception as exc:  # noqa: B902  (any event: the node outlives it)
                if isinstance(exc, RCLError) and not node.context.ok():
                    break  # SIGINT/SIGTERM shut the context down mid-event: a stop
                dropped += 1
                node.get_logger().error(
                    f'dropped one executor event ({type(exc).__name__}: '
                    f'{str(exc)[:200]}); {dropped} so far', throttle_duration_sec=LOG_PERIOD)
    finally:
        executor.remove_node(node)
    return dropped
