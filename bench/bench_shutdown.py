"""Benchmark of clean stops: N start/stop cycles of tca_node, SIGINT and SIGTERM alternating.

Issue 13 asks that 50 consecutive stops give 0 tracebacks. Each cycle starts the
installed ``tca_node`` executable (what ``ros2 run tca_ros tca_node`` runs), waits for
it to be ready with a reader on its outputs and one power command, lets it publish for
0-0.2 s (so the signal lands at varying points of a tick), then sends the signal. Odd
and even cycles also alternate the time mode: wall clock at publish_rate 1 kHz, and
the node's own clock as fast as possible (publish_clock, real_time_factor 0). A stop
counts as bad when the exit status is not 0, the output holds a traceback or an error
line, or the node has not exited STOP_GRACE s after the signal; an abort (SIGABRT, e.g.
rclpy's EventsExecutor "Destroying callback manager with callbacks remaining") is counted
apart too. ``--max-run 0`` signals right after ``ready``; ``--busy N`` runs N busy Python
processes meanwhile (a loaded machine). The executor is the node's default or
TCA_EXECUTOR's (events | single).

Usage: python bench/bench_shutdown.py [--cycles 50] [--model cst] [--exe PATH]
       [--max-run 0.2] [--busy 0]
Prints one row per signal and time mode, and the totals (printed, not asserted).
"""
import argparse
import os
import pathlib
import random
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / 'test'))
os.environ.setdefault('TCA_TEST_DOMAIN', str(random.randint(100, 150)))

from sensor_msgs.msg import JointState, Temperature  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402
from visualization_msgs.msg import Marker  # noqa: E402

from test_node_harness import CONFIG, NodeProcess, Probe, PYTHON, STOP_GRACE  # noqa: E402, I100

SIGNALS = (signal.SIGINT, signal.SIGTERM)
MODES = {
    'wall 1 kHz': ['-p', 'publish_rate:=1000.0'],
    'own clock x0': ['-p', 'publish_clock:=true', '-p', 'real_time_factor:=0.0'],
}
MAX_RUN = 0.2  # s, longest time a node publishes before its signal


def _executable(path):
    """Return the command of tca_node: the given path, the venv's script, or the module."""
    exe = path or shutil.which('tca_node', path=str(pathlib.Path(PYTHON).parent))
    return [exe] if exe else [PYTHON, '-m', 'tca_ros.ros.node']


def _stop(node, sig):
    """Send ``sig``; return (exit status or 'hung', seconds from signal to exit)."""
    t0 = time.monotonic()
    node.proc.send_signal(sig)
    try:
        node.proc.wait(STOP_GRACE)
    except subprocess.TimeoutExpired:
        node.proc.kill()
        node.proc.wait()
        return 'hung', time.monotonic() - t0
    return node.proc.returncode, time.monotonic() - t0


def run_cycles(command, model, cycles, log_dir, rng, max_run=MAX_RUN):
    """Run the start/stop cycles; return one dict per cycle."""
    probe = Probe()
    for topic, kind in (('joint_states', JointState), ('temperature', Temperature),
                        ('shape', Marker)):
        probe.record(topic, kind, depth=10)
    rows = []
    try:
        for i in range(cycles):
            sig = SIGNALS[i % 2]
            mode = list(MODES)[(i // 2) % 2]  # both signals meet both modes
            node = NodeProcess([*command, '--ros-args', '--params-file', CONFIG,
                                '-p', f'model:={model}', '-p', 'shape_rate:=10.0',
                                *MODES[mode]], pathlib.Path(log_dir) / f'stop{i}.log')
            node.wait_for_log('tca node ready', timeout=120.0)
            probe.publish('power_cmd', Float64(data=0.5))
            if max_run > 0:
                probe.spin_for(rng.uniform(0.0, max_run))
            code, seconds = _stop(node, sig)
            node.stop()  # closes the log file
            log = node.log()
            rows.append({'signal': sig.name, 'mode': mode, 'code': code, 'seconds': seconds,
                         'traceback': 'Traceback' in log, 'error': '[ERROR]' in log,
                         'abort': code == -signal.SIGABRT or 'Fatal Python error' in log})
            if code != 0 or rows[-1]['traceback'] or rows[-1]['error']:
                print(f'cycle {i} ({sig.name}, {mode}): exit {code}\n{log}', file=sys.stderr)
    finally:
        probe.close()
    return rows


def _row(label, rows):
    times = [r['seconds'] * 1e3 for r in rows if r['code'] != 'hung']
    median = f'{statistics.median(times):8.0f}' if times else '       -'
    return (f'{label:<24} {len(rows):6d} {sum(r["code"] not in (0, "hung") for r in rows):8d} '
            f'{sum(r["abort"] for r in rows):6d} '
            f'{sum(r["traceback"] for r in rows):10d} {sum(r["error"] for r in rows):6d} '
            f'{sum(r["code"] == "hung" for r in rows):5d} {median}')


BUSY = 'import time\nwhile True:\n    sum(i * i for i in range(10000))\n'


def start_busy(count):
    """Start ``count`` Python processes that keep a core busy each; return them."""
    return [subprocess.Popen([sys.executable, '-c', BUSY]) for _ in range(count)]


def main():
    """Run the cycles and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument('--cycles', type=int, default=50, help='start/stop cycles')
    parser.add_argument('--model', default='cst', choices=('rod', 'cst', 'love'),
                        help='model (cst starts fastest)')
    parser.add_argument('--exe', help='tca_node executable (default: the venv script)')
    parser.add_argument('--seed', type=int, default=0, help='seed of the run times')
    parser.add_argument('--max-run', type=float, default=MAX_RUN,
                        help='longest publishing time before the signal, s (0: at ready)')
    parser.add_argument('--busy', type=int, default=0,
                        help='busy Python processes loading the machine meanwhile')
    args = parser.parse_args()
    command = _executable(args.exe)
    busy = start_busy(args.busy)
    try:
        with tempfile.TemporaryDirectory() as log_dir:
            rows = run_cycles(command, args.model, args.cycles, log_dir,
                              random.Random(args.seed), args.max_run)
    finally:
        for proc in busy:
            proc.kill()
            proc.wait()
    print(f'tca_node stops: {" ".join(command)}, model {args.model}, {args.cycles} cycles, '
          f'executor {os.environ.get("TCA_EXECUTOR", "default")}, signal 0-{args.max_run:g} s '
          f'after ready, {args.busy} busy processes')
    print(f'{"signal, time mode":<24} {"stops":>6} {"exit!=0":>8} {"aborts":>6} '
          f'{"tracebacks":>10} {"ERROR":>6} {"hung":>5} {"stop ms":>8}')
    for sig in SIGNALS:
        for mode in MODES:
            subset = [r for r in rows if r['signal'] == sig.name and r['mode'] == mode]
            if subset:
                print(_row(f'{sig.name}, {mode}', subset))
    print(_row('all', rows))


if __name__ == '__main__':
    main()
