"""A service call that survives a dropped response.

On a loaded machine Fast DDS (the middleware of the Jazzy wheels) can drop the
response to a client its server has not discovered yet (ros2/rmw_fastrtps#842: rclpy
logs ``failed to send response (timeout)`` and the caller waits). An idempotent
request is therefore sent again every RESEND_AFTER s until it is answered or the
caller's timeout passes. Used by ``tca_sim score --namespace`` and the node tests.
"""
import time

RESEND_AFTER = 2.0  # s an idempotent request waits for its response before it is resent


def answer_of(send, spin_until, timeout, forget=None, resend_after=RESEND_AFTER):
    """Return the result of the future ``send()`` returns, or None after ``timeout`` s.

    ``send()`` makes the request and returns its rclpy Future; ``spin_until(predicate,
    seconds)`` serves callbacks until predicate() holds (True) or the seconds pass;
    ``forget(future)`` drops an unanswered request before it is sent again
    (``Client.remove_pending_request``). A response of None counts as none.
    """
    deadline = time.monotonic() + timeout
    while True:
        future = send()
        wait = max(min(resend_after, deadline - time.monotonic()), 0.0)
        if spin_until(future.done, wait) and future.result() is not None:
            return future.result()
        if forget is not None:
            forget(future)
        if time.monotonic() >= deadline:
            return None
