"""One end of a Float64 ping-pong between two rclpy processes (bench_node.py's round trip).

    python bench/ros_ping_pong.py echo|ping events|single TRIPS

``echo`` answers each message; ``ping`` sends the next one when the last came back
(one message in flight, as in a lockstep loop) and prints the median and mean round
trip (s) of the last nine tenths of TRIPS.
"""
import statistics
import sys
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.qos import QoSProfile
from std_msgs.msg import Float64

TIMEOUT_S = 120.0  # the ping gives up after this long
ECHO_IDLE_S = 2.0  # the echo stops this long after its last message
RESTART_S = 0.5  # the ping (re)sends when nothing came back for this long


def main(role, kind, trips):
    """Run one end; return the exit status."""
    rclpy.init()
    node = rclpy.create_node('tca_bench_' + role)
    executor = (EventsExecutor if kind == 'events' else SingleThreadedExecutor)(
        context=node.context)
    out, into = ('bench_pong', 'bench_ping') if role == 'echo' else ('bench_ping', 'bench_pong')
    pub = node.create_publisher(Float64, out, QoSProfile(depth=10))
    state = {'sent': 0.0, 'times': [], 'last': None}

    def on_message(msg):
        if role == 'echo':
            state['last'] = time.monotonic()
            pub.publish(msg)
        elif msg.data == len(state['times']):
            state['times'].append(time.perf_counter() - state['sent'])
            state['sent'] = time.perf_counter()
            pub.publish(Float64(data=float(len(state['times']))))

    node.create_subscription(Float64, into, on_message, QoSProfile(depth=10))
    executor.add_node(node)
    print(role, 'ready', flush=True)
    deadline = time.monotonic() + TIMEOUT_S
    while rclpy.ok() and time.monotonic() < deadline and len(state['times']) < trips:
        executor.spin_once(timeout_sec=0.05)
        if state['last'] is not None and time.monotonic() - state['last'] > ECHO_IDLE_S:
            break  # the echo's pinger is done
        if role == 'ping' and time.perf_counter() - state['sent'] > RESTART_S:
            if pub.get_subscription_count() and node.count_publishers(into):
                state['sent'] = time.perf_counter()
                pub.publish(Float64(data=float(len(state['times']))))
    if role == 'ping' and state['times']:
        times = state['times'][trips // 10:]  # the first tenth warms up
        print(f'round trip {statistics.median(times)} {statistics.mean(times)}', flush=True)
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1], sys.argv[2], int(sys.argv[3])))
