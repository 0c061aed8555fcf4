"""Benchmark of tca_node (printed, not asserted).

1. CPU use of the node at 1 kHz physics / 100 Hz publishing, wall clock (% of one core).
2. Lockstep speed, side by side per executor (TCA_EXECUTOR: events, single): the fastest
   real-time factor with publish_clock (real_time_factor 0) of the node alone, with a
   client reading /clock, in lockstep with tca_pid at 100 Hz
   reading joint_states only (its time comes from the stamps) and with tca_pid on
   use_sim_time (it reads /clock too), with the CPU time per tick of the node and of
   tca_pid (all threads; less sensitive to the machine's load than the factor), each over
   a window of whole seconds timed by the node's /diagnostics stamps once it ticks, also with
   the node's power_cmd read best effort (a qos_overrides parameter); beside them the
   rclpy round trip between two processes spinning the same executor (a Float64
   ping-pong, one message in flight), the limit of a lockstep loop, which needs one
   round trip per control tick.
3. Command-to-feedback latency: power_cmd published -> the applied ``power`` received.
4. Longest gap between outputs under a 2 W step, per shipped config, with an empty table
   cache (the conical rod table's rows are then built while the node runs): at the
   probe (receipt times) and at the node (the joint_states stamps: when the node
   published), the machine as it is and with ``--busy N`` busy Python processes.

Usage: python bench/bench_node.py [--model rod|cst|love] [--seconds 10]
       [--only-fastest] [--only-gaps] [--busy 0] [--executors events,single] [--rounds 3]
"""
import argparse
import math
import os
import pathlib
import random
import re
import statistics
import subprocess
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / 'test'))
os.environ.setdefault('TCA_TEST_DOMAIN', str(random.randint(100, 150)))

from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from test_node_harness import (  # noqa: E402, I100
    CONFIG, module_command, NodeProcess, Probe)

TICKS_PER_SECOND = os.sysconf('SC_CLK_TCK')  # /proc/<pid>/stat time unit
CONFIGS = ('free_stroke', 'self_coiled', 'conical')  # the shipped config/*.yaml
STEP_POWER = 2.0  # W, the step of the output-gap figure
COMMAND_PERIOD = 0.1  # s between its power commands (10 Hz, as a slow controller)
PUBLISH_PERIOD = 0.01  # s, the shipped configs' publish_rate 100 Hz
#: the node's power_cmd read best effort: no acknowledgements in the lockstep loop
BEST_EFFORT_COMMANDS = ('-p', 'qos_overrides./power_cmd.subscription.reliability:=best_effort')


def _cpu_seconds(pid):
    fields = pathlib.Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS_PER_SECOND  # utime + stime


BUSY = 'while True:\n    sum(i * i for i in range(10000))\n'


def start_busy(count):
    """Start ``count`` Python processes that keep a core busy each; return them."""
    return [subprocess.Popen([sys.executable, '-c', BUSY]) for _ in range(count)]


def stop_busy(procs):
    for proc in procs:
        proc.kill()
        proc.wait()


def _stamp_s(msg):
    return msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec


def _start(log_dir, model, *args, name='tca', config=CONFIG, env=None):
    model_args = ['-p', f'model:={model}'] if model else []
    node = NodeProcess(module_command('tca_ros.ros.node', [
        '--params-file', config, *model_args, *args]),
        pathlib.Path(log_dir) / f'{name}.log', env=env)
    node.wait_for_log('tca node ready', timeout=300.0)
    return node


def bench_gap(log_dir, config, seconds, cache):
    """Return (longest gap (s), its start (s from the step), ready time (s), watchdog lines,
    longest gap between joint_states stamps (s), gaps between stamps of 3 periods or more).

    The node starts with its config's model and the table cache ``cache`` (a directory);
    a probe sends STEP_POWER at 10 Hz for ``seconds`` and records when each
    ``displacement`` arrives, and the stamps of ``joint_states`` (node time when the
    node sampled and published). The node's publish period is 10 ms (publish_rate 100 Hz).
    """
    env = dict(os.environ, TCA_ROS_CACHE=str(cache))
    start = time.monotonic()
    node = _start(log_dir, None, name=f'gap_{config}', env=env,
                  config=HERE.parent / 'config' / f'{config}.yaml')
    ready = time.monotonic() - start
    probe = Probe()
    rows = probe.record('displacement', Float64)
    joints = probe.record('joint_states', JointState)
    try:
        probe.spin_until(lambda: rows and joints, 20.0)
        t0 = time.monotonic()
        next_command = t0
        while time.monotonic() - t0 < seconds:
            if time.monotonic() >= next_command:
                probe.publish('power_cmd', Float64(data=STEP_POWER))
                next_command += COMMAND_PERIOD
            probe.spin_for(0.005)
        times = [t for t, _ in rows if t >= t0]
        gap, at = max((b - a, a - t0) for a, b in zip(times, times[1:]))
        stamps = [_stamp_s(m) for t, m in joints if t >= t0]
        stamp_gaps = [b - a for a, b in zip(stamps, stamps[1:])]
        late = sum(g >= 3 * PUBLISH_PERIOD for g in stamp_gaps)
        watchdog = node.log().count('watchdog')
    finally:
        probe.close()
        node.stop()
    return gap, at, ready, watchdog, max(stamp_gaps), late


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


def bench_fastest(log_dir, model, seconds, lockstep=False, reader=False, pid_sim_time=False,
                  env=None, node_args=(), cpu=None):
    """Return the real-time factor reached with publish_clock and factor 0.

    Without ``reader`` the factor is measured over a window of whole seconds once the
    node ticks (0.5 s after its first tick with a sim time above 0): from the stamps
    (node time) and receipt times of the node's /diagnostics, which it publishes once a
    wall second (no message per tick is added); with ``reader`` a client reads /clock
    (as a use_sim_time node does) and the factor is measured from it. ``lockstep``: with
    tca_pid at the node's 100 Hz, on use_sim_time if ``pid_sim_time`` (it then reads
    /clock too). ``node_args``: more ``-p`` rules of the node. ``cpu`` (a list, without
    ``reader``): the CPU time (s) per tick of the node and of tca_pid (all their threads)
    over the same window is appended to it.
    """
    probe = Probe()
    if reader:
        # As rclpy's own /clock reader (TimeSource): best effort, depth 1.
        clocks = probe.record('/clock', Clock, qos=QoSProfile(
            depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
    else:
        diagnostics = probe.record('/diagnostics', DiagnosticArray)
    tag = f'fast{int(lockstep)}{int(reader)}{int(pid_sim_time)}'
    node = _start(log_dir, model, '-p', 'publish_clock:=true', '-p', 'real_time_factor:=0.0',
                  '-p', f'lockstep:={str(lockstep).lower()}', *node_args, name=tag, env=env)
    pid = None
    if lockstep:
        pid = NodeProcess(module_command('tca_ros.ros.pid_node', [
            '-p', f'use_sim_time:={str(pid_sim_time).lower()}', '-p', 'setpoint:=0.002']),
            pathlib.Path(log_dir) / f'pid{tag}.log', env=env)
    try:
        if not reader:
            procs = [node.proc.pid] + ([pid.proc.pid] if pid is not None else [])
            probe.spin_until(lambda: diagnostics and _stamp_s(diagnostics[-1][1]) > 0, 60.0)
            probe.spin_for(0.5)
            t0, sim0 = _next_message(probe, diagnostics)
            cpu0 = [_cpu_seconds(p) for p in procs]
            end = t0 + max(seconds - 1.5, 1.0)
            while True:
                t1, sim1 = _next_message(probe, diagnostics)
                if t1 >= end - 0.1:
                    break
            cpu1 = [_cpu_seconds(p) for p in procs]
            ticks = (sim1 - sim0) / PUBLISH_PERIOD
            if cpu is not None:
                cpu.extend((b - a) / ticks if ticks > 0 else math.nan
                           for a, b in zip(cpu0, cpu1))
            return (sim1 - sim0) / (t1 - t0)
        probe.spin_until(lambda: clocks, 60.0)
        probe.spin_for(1.0)
        sim0, t0 = _sim_seconds(clocks[-1][1]), time.monotonic()
        probe.spin_for(seconds)
        factor = (_sim_seconds(clocks[-1][1]) - sim0) / (time.monotonic() - t0)
    finally:
        probe.close()
        node.stop()
        if pid is not None:
            pid.stop()
    return factor


def _next_message(probe, rows, timeout=5.0):
    """Spin until one more stamped message is in ``rows``; return (receipt s, stamp s)."""
    count = len(rows)
    if not probe.spin_until(lambda: len(rows) > count, timeout):
        return math.nan, math.nan
    return rows[-1][0], _stamp_s(rows[-1][1])


def bench_round_trip(log_dir, executor, trips=3000):
    """Return (median, mean) round trip (s) of a Float64 ping-pong between two processes.

    Both spin ``executor`` ('events' or 'single'); one message is in flight at a time,
    as in a lockstep loop. The mean sets the loop's rate.
    """
    procs = [NodeProcess([sys.executable, str(HERE / 'ros_ping_pong.py'), role, executor,
                          str(trips)],
                         pathlib.Path(log_dir) / f'{role}_{executor}.log')
             for role in ('echo', 'ping')]
    try:
        procs[1].proc.wait(150.0)
        line = re.search(r'round trip ([0-9.e-]+) ([0-9.e-]+)', procs[1].log())
        return (float(line.group(1)), float(line.group(2))) if line else (math.nan, math.nan)
    finally:
        for proc in procs:
            proc.stop()


def lockstep_round(log_dir, model, seconds, executor):
    """Return one round of the lockstep figures of ``executor`` (the table's rows)."""
    env = dict(os.environ, TCA_EXECUTOR=executor)
    median, mean = bench_round_trip(log_dir, executor)
    cpu, cpu_be = [], []
    row = [bench_fastest(log_dir, model, seconds, env=env),
           bench_fastest(log_dir, model, seconds, reader=True, env=env),
           bench_fastest(log_dir, model, seconds, lockstep=True, env=env, cpu=cpu),
           bench_fastest(log_dir, model, seconds, lockstep=True, env=env, cpu=cpu_be,
                         node_args=BEST_EFFORT_COMMANDS),
           bench_fastest(log_dir, model, seconds, lockstep=True, pid_sim_time=True, env=env),
           1e6 * median, 1e6 * mean, 0.01 / mean]
    row[4:4] = [1e6 * c for c in cpu] + [1e6 * c for c in cpu_be]
    return row


def lockstep_table(log_dir, model, seconds, executors, rounds=3):
    """Print the lockstep figures, one column per executor, measured in this run.

    ``rounds`` rounds, the executors interleaved in each (the machine's load drifts);
    each cell is the median of the rounds and, in brackets, the best of them.
    """
    runs = {e: [] for e in executors}
    load = []
    for _ in range(rounds):
        for executor in executors:
            runs[executor].append(lockstep_round(log_dir, model, seconds, executor))
            load.append(os.getloadavg()[0])
    print(f'lockstep speed, model {model}, {seconds:g} s per figure, {os.cpu_count()} cores, '
          f'{rounds} rounds: median (best); 1-min load average {min(load):.1f}-{max(load):.1f}')
    labels = ['node alone, publish_clock, factor 0 (x)',
              '  with a client reading /clock (x)',
              'lockstep, tca_pid reading joint_states (x), target 30',
              '  power_cmd read best effort (qos_overrides) (x)',
              '  CPU per tick: node (us)',
              '  CPU per tick: tca_pid (us)',
              '  CPU per tick, power_cmd best effort: node (us)',
              '  CPU per tick, power_cmd best effort: tca_pid (us)',
              'lockstep, tca_pid on use_sim_time (+ /clock) (x)',
              'rclpy round trip, two processes, median (us)',
              '  mean (us)',
              '  lockstep limit at 100 Hz: 10 ms / mean (x)']
    print(f'{"figure":56s}' + ''.join(f'{e + " executor":>20s}' for e in executors))
    for i, label in enumerate(labels):
        best = max if '(x)' in label else min
        cells = []
        for e in executors:
            values = [run[i] for run in runs[e] if not math.isnan(run[i])]
            cells.append(f'{statistics.median(values):10.1f} ({best(values):6.1f})'
                         if values else f'{"nan":>20s}')
        print(f'{label:56s}' + ''.join(f'{c:>20s}' for c in cells))


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
    parser.add_argument('--only-fastest', action='store_true',
                        help='only the lockstep speed table')
    parser.add_argument('--only-gaps', action='store_true',
                        help='only the longest output gap per config')
    parser.add_argument('--busy', type=int, default=0,
                        help='also measure the gaps with this many busy Python processes')
    parser.add_argument('--executors', default='events,single',
                        help='executors of the lockstep table (TCA_EXECUTOR values)')
    parser.add_argument('--rounds', type=int, default=3,
                        help='rounds of the lockstep table (median and best printed)')
    args = parser.parse_args()
    executors = args.executors.split(',')
    if args.only_gaps:
        print_gaps(args.seconds, args.busy)
        return 0
    if args.only_fastest:
        with tempfile.TemporaryDirectory() as log_dir:
            lockstep_table(log_dir, args.model, args.seconds / 2, executors, args.rounds)
        return 0
    with tempfile.TemporaryDirectory() as log_dir:
        cpu, rate = bench_cpu(log_dir, args.model, args.seconds)
        lat = sorted(bench_latency(log_dir, args.model, 100))
        load1, load5, _ = os.getloadavg()
        print(f'tca_node benchmark, model {args.model}, {os.cpu_count()} cores, '
              f'load average {load1:.1f} / {load5:.1f} (1 / 5 min: other work shares the '
              f'cores), executor {os.environ.get("TCA_EXECUTOR", "default")}')
        print(f'{"figure":58s} {"value":>10s}  target')
        print(f'{"CPU at 1 kHz physics / 100 Hz publishing (% of a core)":58s} '
              f'{100 * cpu:10.1f}  < 25')
        print(f'{"  publish rate seen by a client (Hz)":58s} {rate:10.1f}')
        if lat:
            print(f'{"power_cmd -> power latency, median (ms)":58s} '
                  f'{1e3 * statistics.median(lat):10.2f}')
            print(f'{"power_cmd -> power latency, 95th percentile (ms)":58s} '
                  f'{1e3 * lat[int(0.95 * (len(lat) - 1))]:10.2f}')
            print(f'{"power_cmd -> power latency, max (ms)":58s} {1e3 * lat[-1]:10.2f}')
        lockstep_table(log_dir, args.model, args.seconds / 2, executors, args.rounds)
    print_gaps(args.seconds, args.busy)
    return 0


def print_gaps(seconds, busy=0):
    """Print the longest output gap under a 2 W step for each shipped config.

    Each config first with an empty table cache (the conical rows are then built while
    the node runs), then the conical one again with the rows its first run cached (those
    its temperatures reached, and the worker's meanwhile); with
    ``busy``, all of it again while that many busy processes load the machine.
    """
    for load in ([0, busy] if busy else [0]):
        procs = start_busy(load)
        try:
            time.sleep(1.0 if load else 0.0)
            _print_gap_table(seconds, load)
        finally:
            stop_busy(procs)


def _print_gap_table(seconds, busy):
    load1, _, _ = os.getloadavg()
    print(f'longest gap between outputs, {STEP_POWER:g} W step, commands at 10 Hz for '
          f'{seconds:g} s (publish period 10 ms, target < 3 periods; {busy} busy processes, '
          f'load average {load1:.1f} on {os.cpu_count()} cores, executor '
          f'{os.environ.get("TCA_EXECUTOR", "default")})')
    print(f'{"config":28s} {"ready (s)":>10s} {"gap (ms)":>10s} {"periods":>8s} '
          f'{"at (s)":>7s} {"node gap (ms)":>14s} {"node gaps >= 3":>15s} {"watchdog":>9s}')
    with tempfile.TemporaryDirectory() as log_dir:
        runs = [(config, 'empty cache', config) for config in CONFIGS]
        runs.append(('conical', 'run 1 rows cached', 'conical'))
        for config, cache_state, cache in runs:
            gap, at, ready, watchdog, node_gap, late = bench_gap(
                log_dir, config, seconds, pathlib.Path(log_dir) / f'cache_{cache}')
            print(f'{config + ", " + cache_state:28s} {ready:10.1f} {1e3 * gap:10.1f} '
                  f'{gap / PUBLISH_PERIOD:8.1f} {at:7.2f} {1e3 * node_gap:14.1f} {late:15d} '
                  f'{watchdog:9d}')


if __name__ == '__main__':
    sys.exit(main())
