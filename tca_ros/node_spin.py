"""Spin a node so that nothing a peer sends can end it.

``rclpy.spin`` lets an exception raised while the executor takes a message (inside
rclpy, before any callback of ours runs) escape and end the process: seen once as
"RuntimeError: Unable to convert call argument '0' to Python object" from
``take_message``. Here each event is taken on its own; such a failure costs that one
event, is logged (throttled) and counted, and the node keeps serving.
"""
from rclpy._rclpy_pybind11 import RCLError
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

LOG_PERIOD = 1.0  # s between repeats of the dropped-event error


def spin_resiliently(node, executor=None):
    """Spin ``node`` until shutdown; return the number of executor events dropped.

    KeyboardInterrupt and ExternalShutdownException end the spin as ``rclpy.spin``
    does; an RCLError after the context was shut down (a stop) ends it quietly.
    """
    executor = executor or SingleThreadedExecutor(context=node.context)
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
