"""Benchmark of tca_node (printed, not asserted).

1. CPU use of the node at 1 kHz physics / 100 Hz publishing, wall clock (% of one core).
2. Fastest real-time factor with publish_clock (real_time_factor 0): the node alone (its
   own shutdown line), with a client reading /clock, and in lockstep with tca_pid.
3. Command-to-feedback latency: power_cmd published -> the applied ``power`` received.
4. Longest gap between outputs under a 2 W step, per shipped config, with an empty table
   cache (the conical rod table's rows are then built while the node runs).
5. The rclpy loopback round trip on this machine (a Float64 to an echo process and back):
   the limit of a lockstep loop, which needs one round trip per control tick.

Usage: python bench/bench_node.py [--model rod|cst|love] [--seconds 10] [--only-gaps]
"""
import argparse
import math
import os
import pathlib
import random
import re
import statistics
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / 'test'))
os.environ.setdefault('TCA_TEST_DOMAIN', str(random.randint(100, 150)))

from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from test_node_harness import (  # noqa: E402, I100
    CONFIG, module_command, NodeProcess, Probe)

TICKS_PER_SECOND = os.sysconf('SC_CLK_TCK')  # /proc/<pid>/stat time unit
CONFIGS = ('free_stroke', 'self_coiled', 'conical')  # the shipped config/*.yaml
STEP_POWER = 2.0  # W, the step of the output-gap figure
COMMAND_PERIOD = 0.1  # s between its power commands (10 Hz, as a slow controller)


def _cpu_seconds(pid):
    fields = pathlib.Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS_PER_SECOND  # utime + stime


def _start(log_dir, model, *args, name='tca', config=CONFIG, env=None):
    model_args = ['-p', f'model:={model}'] if model else []
    node = NodeProcess(module_command('tca_ros.ros.node', [
        '--params-file', config, *model_args, *args]),
        pathlib.Path(log_dir) / f'{name}.log', env=env)
    node.wait_for_log('tca node ready', timeout=300.0)
    return node


def bench_gap(log_dir, config, seconds, cache):
    """Return (longest gap (s), its start (s from the step), ready time (s), watchdog lines).

    The node starts with its config's model and the table cache ``cache`` (a directory);
    a probe sends STEP_POWER at 10 Hz for ``seconds`` and records when each
    ``displacement`` arrives. The node's publish period is 10 ms (publish_rate 100 Hz).
    """
    env = dict(os.environ, TCA_ROS_CACHE=str(cache))
    start = time.monotonic()
    node = _start(log_dir, None, name=f'gap_{config}', env=env,
                  config=HERE.parent / 'config' / f'{config}.yaml')
    ready = time.monotonic() - start
    probe = Probe()
    rows = probe.record('displacement', Float64)
    try:
        probe.spin_until(lambda: rows, 20.0)
        t0 = time.monotonic()
        next_command = t0
        while time.monotonic() - t0 < seconds:
            if time.monotonic() >= next_command:
                probe.publish('power_cmd', Float64(data=STEP_POWER))
                next_command += COMMAND_PERIOD
            probe.spin_for(0.005)
        times = [t for t, _ in rows if t >= t0]
        gap, at = max((b - a, a - t0) for a, b in zip(times, times[1:]))
        watchdog = node.log().count('watchdog')
    finally:
        probe.close()
        node.stop()
    return gap, at, ready, watchdog


def bench_cpu(log_dir, model, seconds):
    """Return the node's CPU use (fraction of one core) while a client reads it."""
    node = _start(log_dir, model, name='cpu')
    probe = Probe()
    rows = probe.record('power', Float64)
    try:
        probe.spin_until(lambda: rows, 20.0)
        cpu0, t0 = _cpu_seconds(node.proc.pid), time.monotonic()
        while time.monotonic() - t0 < seconds:
            probe.publish('power_cmd', Float64(data=0.5))
            probe.spin_for(0.1)
        cpu = (_cpu_seconds(node.proc.pid) - cpu0) / (time.monotonic() - t0)
        rate = len(rows) / (rows[-1][0] - rows[0][0])
    finally:
        probe.close()
        node.stop()
    return cpu, rate


def bench_fastest(log_dir, model, seconds, lockstep=False, reader=True):
    """Return the real-time factor reached with publish_clock and factor 0.

    With ``reader`` a client reads /clock (as a use_sim_time node does) and the factor is
    measured from it; without, the node runs alone and its shutdown line is read.
    """
    probe = Probe()
    if reader:
        # As rclpy's own /clock reader (TimeSource): best effort, depth 1.
        clocks = probe.record('/clock', Clock, qos=QoSProfile(
            depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
    tag = f'fast{int(lockstep)}{int(reader)}'
    node = _start(log_dir, model, '-p', 'publish_clock:=true', '-p', 'real_time_factor:=0.0',
                  '-p', f'lockstep:={str(lockstep).lower()}', name=tag)
    pid = None
    if lockstep:
        pid = NodeProcess(module_command('tca_ros.ros.pid_node', [
            '-p', 'use_sim_time:=true', '-p', 'setpoint:=0.002']),
            pathlib.Path(log_dir) / 'pid.log')
    try:
        if not reader:
            time.sleep(seconds)
            node.stop()
            line = re.search(r'\(([0-9.]+)x real time\)', node.log())
            return float(line.group(1)) if line else math.nan
        probe.spin_until(lambda: clocks, 60.0)
        probe.spin_for(1.0)
        sim0, t0 = _sim_seconds(clocks[-1][1]), time.monotonic()
        probe.spin_for(seconds)
        factor = (_sim_seconds(clocks[-1][1]) - sim0) / (time.monotonic() - t0)
    finally:
        probe.close()
        if pid is not None:
            pid.stop()
        node.stop()
    return factor


ECHO = """
import rclpy
from rclpy.qos import QoSProfile
from std_msgs.msg import Float64
rclpy.init()
node = rclpy.create_node('tca_bench_echo')
pub = node.create_publisher(Float64, 'bench_pong', QoSProfile(depth=10))
node.create_subscription(Float64, 'bench_ping', pub.publish, QoSProfile(depth=10))
print('echo ready', flush=True)
try:
    rclpy.spin(node)
except BaseException:
    pass
"""


def bench_round_trip(log_dir, samples):
    """Return round-trip times (s): Float64 to an rclpy echo process and back (loopback)."""
    echo = NodeProcess([sys.executable, '-c', ECHO], pathlib.Path(log_dir) / 'echo.log')
    echo.wait_for_log('echo ready')
    probe = Probe()
    rows = probe.record('bench_pong', Float64)
    times = []
    try:
        probe.wait_matched('bench_pong')
        for i in range(samples + 20):  # the first 20 warm up discovery and caches
            value = float(i)
            start = time.monotonic()
            probe.publish('bench_ping', Float64(data=value))
            if probe.spin_until(lambda: rows and rows[-1][1].data == value, 1.0) and i >= 20:
                times.append(rows[-1][0] - start)
    finally:
        probe.close()
        echo.stop()
    return times


def _sim_seconds(msg):
    return msg.clock.sec + 1e-9 * msg.clock.nanosec


def bench_latency(log_dir, model, samples):
    """Return latencies (s) from power_cmd publication to the applied power's receipt."""
    node = _start(log_dir, model, name='latency')
    probe = Probe()
    rows = probe.record('power', Float64)
    latencies = []
    try:
        probe.spin_until(lambda: rows, 20.0)
        for i in range(samples):
            value = 0.5 + 0.001 * (i + 1)  # W, unique per sample
            start = time.monotonic()
            probe.publish('power_cmd', Float64(data=value))
            if probe.spin_until(lambda: rows[-1][1].data == value, 1.0):
                latencies.append(rows[-1][0] - start)
            time.sleep(0.05 * random.random())  # de-phase from the 100 Hz ticks
    finally:
        probe.close()
        node.stop()
    return latencies


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument('--model', default='rod', help='kinetostatic model (rod|cst|love)')
    parser.add_argument('--seconds', type=float, default=10.0, help='wall time per figure, s')
    parser.add_argument('--only-fastest', action='store_true', help='skip CPU and latency')
    parser.add_argument('--only-gaps', action='store_true',
                        help='only the longest output gap per config')
    args = parser.parse_args()
    if args.only_gaps:
        print_gaps(args.seconds)
        return 0
    if args.only_fastest:
        with tempfile.TemporaryDirectory() as log_dir:
            alone = bench_fastest(log_dir, args.model, args.seconds, reader=False)
            fast = bench_fastest(log_dir, args.model, args.seconds)
            lock = bench_fastest(log_dir, args.model, args.seconds, lockstep=True)
            trip = statistics.median(bench_round_trip(log_dir, 500))
        print(f'fastest real-time factor, publish_clock, alone / with a /clock reader / in '
              f'lockstep with tca_pid (x): {alone:.1f} / {fast:.1f} / {lock:.1f}')
        print(f'rclpy loopback round trip, median: {1e3 * trip:.3f} ms, so at most '
              f'{0.01 / trip:.1f}x real time in lockstep at 100 Hz')
        return 0
    with tempfile.TemporaryDirectory() as log_dir:
        cpu, rate = bench_cpu(log_dir, args.model, args.seconds)
        alone = bench_fastest(log_dir, args.model, args.seconds / 2, reader=False)
        fast = bench_fastest(log_dir, args.model, args.seconds / 2)
        lock = bench_fastest(log_dir, args.model, args.seconds / 2, lockstep=True)
        lat = sorted(bench_latency(log_dir, args.model, 100))
        trip = statistics.median(bench_round_trip(log_dir, 500))
    load1, load5, _ = os.getloadavg()
    print(f'tca_node benchmark, model {args.model}, {os.cpu_count()} cores, '
          f'load average {load1:.1f} / {load5:.1f} (1 / 5 min: other work shares the cores)')
    print(f'{"figure":58s} {"value":>10s}  target')
    print(f'{"CPU at 1 kHz physics / 100 Hz publishing (% of a core)":58s} '
          f'{100 * cpu:10.1f}  < 25')
    print(f'{"  publish rate seen by a client (Hz)":58s} {rate:10.1f}')
    print(f'{"fastest real-time factor, publish_clock, node alone (x)":58s} {alone:10.1f}  >= 50')
    print(f'{"  the same with a client reading /clock (x)":58s} {fast:10.1f}')
    print(f'{"real-time factor, lockstep with tca_pid (x)":58s} {lock:10.1f}  >= 30')
    print(f'{"rclpy loopback round trip, median (ms)":58s} {1e3 * trip:10.3f}')
    print(f'{"  lockstep limit at 100 Hz, one round trip a tick (x)":58s} '
          f'{0.01 / trip:10.1f}')
    if lat:
        print(f'{"power_cmd -> power latency, median (ms)":58s} '
              f'{1e3 * statistics.median(lat):10.2f}')
        print(f'{"power_cmd -> power latency, 95th percentile (ms)":58s} '
              f'{1e3 * lat[int(0.95 * (len(lat) - 1))]:10.2f}')
        print(f'{"power_cmd -> power latency, max (ms)":58s} {1e3 * lat[-1]:10.2f}')
    print_gaps(args.seconds)
    return 0


def print_gaps(seconds):
    """Print the longest output gap under a 2 W step for each shipped config.

    Each config first with an empty table cache (the conical rows are then built while
    the node runs), then the conical one again with the rows its first run cached.
    """
    load1, _, _ = os.getloadavg()
    print(f'longest gap between displacement messages, {STEP_POWER:g} W step, commands at '
          f'10 Hz for {seconds:g} s (publish period 10 ms, target < 3 periods; load average '
          f'{load1:.1f} on {os.cpu_count()} cores)')
    print(f'{"config":28s} {"ready (s)":>10s} {"gap (ms)":>10s} {"periods":>8s} '
          f'{"at (s)":>7s} {"watchdog lines":>15s}')
    with tempfile.TemporaryDirectory() as log_dir:
        runs = [(config, 'empty cache', config) for config in CONFIGS]
        runs.append(('conical', 'rows cached', 'conical'))
        for config, cache_state, cache in runs:
            gap, at, ready, watchdog = bench_gap(log_dir, config, seconds,
                                                 pathlib.Path(log_dir) / f'cache_{cache}')
            print(f'{config + ", " + cache_state:28s} {ready:10.1f} {1e3 * gap:10.1f} '
                  f'{gap / 0.01:8.1f} {at:7.2f} {watchdog:15d}')


if __name__ == '__main__':
    sys.exit(main())
