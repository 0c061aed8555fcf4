"""Spin a node so that nothing a peer sends can end it, and a stop signal ends it cleanly.

``rclpy.spin`` lets an exception raised while the executor takes a message (inside
rclpy, before any callback of ours runs) escape and end the process: seen once as
"RuntimeError: Unable to convert call argument '0' to Python object" from
``take_message``. Here each event is taken on its own; such a failure costs that one
event, is logged (throttled) and counted, and the node keeps serving.

Stop signals (SIGINT, SIGTERM) are ours, not rclpy's (``install_stop_handlers``, rclpy
initialised with ``SignalHandlerOptions.NO``): while a spin runs, a signal only asks it
to stop; the spin ends between two executor events, the executor unregisters every
callback while the node and the context are intact, and only then does the caller shut
rclpy down. rclpy's own handlers shut the context down from another thread at any
moment, and Python's raises KeyboardInterrupt at any bytecode: when either lands while
rclpy's EventsExecutor registers the node's subscriptions, timers and QoS event
handlers with rcl (its first spin, just after ``ready``), the registration stops half
way, the executor's C++ keeps callbacks it never recorded, and destroying it aborts the
process ("Destroying callback manager with callbacks remaining"; docs/decisions.md).
"""
import os
import signal

from rclpy._rclpy_pybind11 import RCLError
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor

LOG_PERIOD = 1.0  # s between repeats of the dropped-event error
SPIN_TIMEOUT = 0.1  # s, longest wait for an event: a stop is seen at most this late
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: default of TCA_EXECUTOR: 'events' (rclpy's EventsExecutor) or 'single'
EXECUTOR = 'events'
_SPINNING = []  # the nodes spin_resiliently spins now
_STOPS = []  # stop signals received while spinning


def install_stop_handlers():
    """Handle SIGINT and SIGTERM: stop a running spin, else raise KeyboardInterrupt.

    Call in the main thread, with rclpy initialised (or to be) with
    ``signal_handler_options=SignalHandlerOptions.NO``. Before and after a spin (start-up,
    table builds) a signal raises KeyboardInterrupt as Python's default SIGINT handler does.
    """
    for number in STOP_SIGNALS:
        signal.signal(number, _on_stop_signal)


def _on_stop_signal(signum, frame):
    if not _SPINNING:
        raise KeyboardInterrupt
    _STOPS.append(signum)  # the spin loop ends at its next turn


class StopSafeExecutor(SingleThreadedExecutor):
    """rclpy's single-threaded executor whose finaliser accepts a half-built object."""

    def __del__(self):
        if getattr(self, '_sigint_gc', None) is not None:
            super().__del__()


def new_executor(context):
    """Return the executor of ``context``, or None if the context was shut down meanwhile.

    rclpy's EventsExecutor (C++ event queue; lockstep with tca_pid runs several times
    faster, bench/bench_node.py), or with TCA_EXECUTOR=single the StopSafeExecutor.
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
    """Spin ``node`` until a stop signal or shutdown; return the executor events dropped.

    A stop signal (install_stop_handlers) ends the spin at the next turn of the loop;
    KeyboardInterrupt and ExternalShutdownException end it as ``rclpy.spin`` does; an
    RCLError after the context was shut down ends it quietly. An executor made here is
    shut down before returning (all its callbacks unregistered).
    """
    _SPINNING.append(node)
    try:
        return _spin(node, executor)
    finally:
        _SPINNING.remove(node)


def _spin(node, executor):
    owned = executor is None
    executor = executor or new_executor(node.context)
    if executor is None:
        return 0  # stopped before the spin began
    executor.add_node(node)
    dropped = 0
    try:
        while node.context.ok() and not _STOPS:
            try:
                executor.spin_once(timeout_sec=SPIN_TIMEOUT)
            except (KeyboardInterrupt, ExternalShutdownException):
                raise
            except Exception as exc:  # noqa: B902  (any event: the node outlives it)
                if isinstance(exc, RCLError) and not node.context.ok():
                    break  # the context was shut down mid-event: a stop
                dropped += 1
                node.get_logger().error(
                    f'dropped one executor event ({type(exc).__name__}: '
                    f'{str(exc)[:200]}); {dropped} so far', throttle_duration_sec=LOG_PERIOD)
    finally:
        executor.remove_node(node)
        if owned:
            executor.shutdown()  # unregister every callback while the node is intact
    return dropped
