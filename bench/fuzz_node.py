"""Randomised campaign against tca_node (issue 10): it must never die (printed counts).

Seeded and budgeted. A node (cst model by default: fast start-up) receives a random
mix of the following, in two segments of half the budget each: the config's rig (dead
weight), then ``rig.mode:=antagonistic`` (which adds the ``antagonist/power_cmd`` input
and the ``force``, ``antagonist/force`` and ``antagonist/temperature`` outputs):

- command messages on every subscribed topic (power_cmd, voltage_cmd, load,
  antagonist/power_cmd) drawn from extreme doubles (nan, +-inf, +-1e308, +-5e-324,
  -0.0, +-1e9) and ordinary values, paced in bursts of a few so that the reliable
  depth-10 queues do not drop them;
- parameter requests (set_parameters and set_parameters_atomically) on schema names,
  unknown names and rclpy's own, with every type code 0-9 plus invalid ones
  (10, 99, 255) and values drawn from range ends, subnormals and extreme doubles;
- ``~/reset`` calls;

then a series of bad start-ups: corrupted copies of config/free_stroke.yaml and bad
``-p`` rules. Counted: node deaths (restarted and the campaign goes on), tracebacks in
the logs, requests left without an answer, published values that are not finite
(resistance = +inf of a broken muscle, documented, is counted apart), refusals whose
reason is not one line, and start-ups that do not end in one line with exit 2 or 0.

Published values are counted as they arrive (nothing is stored), so the campaign's
memory stays flat; the time of each phase and the slowest request are printed.

Usage: python bench/fuzz_node.py [--seed 1] [--messages 10000] [--requests 2000]
       [--files 50] [--model cst|love|rod] [--code DIR]

``--code DIR`` runs the node from another checkout (e.g. a git worktree of an older
commit), for a before/after comparison with the same seed.
"""
import argparse
import math
import os
import pathlib
import random
import sys
import tempfile
import time

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / 'test'))
os.environ.setdefault('TCA_TEST_DOMAIN', str(random.randint(151, 200)))

from rcl_interfaces.msg import Parameter as ParameterMsg  # noqa: E402
from rcl_interfaces.msg import ParameterValue  # noqa: E402
from rcl_interfaces.srv import SetParameters, SetParametersAtomically  # noqa: E402
from rclpy.qos import QoSProfile  # noqa: E402
from sensor_msgs.msg import JointState, Temperature  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from tca_ros.model.params_schema import SCHEMA  # noqa: E402
from tca_ros.ros.node import NODE_SCHEMA  # noqa: E402
from test_node_harness import (  # noqa: E402, I100, I201
    CONFIG, module_command, NodeProcess, Probe)

EXTREME = [math.nan, math.inf, -math.inf, 1e308, -1e308, 5e-324, -5e-324, 0.0, -0.0,
           1e9, -1e9, 1.7976931348623157e308]
BAD_TYPE_CODES = [10, 99, 255]
CALL_TIMEOUT = 3.0  # s a request may take before it counts as unanswered
START_UP_WAIT = 60.0  # s a bad start-up may take to refuse or to be ready
RULES = [['-p', 'physics_rate:=[1, "a"'], ['-p', 'nonexistent:=1.0'], ['-p', 'a:='],
         ['-p', 'fiber.radius:={a: 1}'], ['-p', 'fiber.radius:=null'],
         ['-p', 'thermal.convection_coefficient:=0.0'], ['-p', 'dynamics.mass:=5e-324']]


def _node_process(args, ros_args, log):
    """Return a NodeProcess of tca_node, run from --code DIR when given."""
    env, cwd = os.environ.copy(), None
    if args.code:
        cwd = pathlib.Path(args.code).resolve()
        env['PYTHONPATH'] = str(cwd)
    return NodeProcess(module_command('tca_ros.ros.node', ros_args), log, env=env,
                       **({'cwd': cwd} if cwd else {}))


def _double(rng, spec=None):
    r = rng.random()
    if r < 0.4:
        return rng.choice(EXTREME)
    if spec is not None and r < 0.7 and math.isfinite(spec.low) and math.isfinite(spec.high):
        return rng.choice([spec.low, spec.high, rng.uniform(spec.low, spec.high)])
    return rng.uniform(-10.0, 10.0) * 10.0 ** rng.randint(-6, 6)


def random_parameter(rng, specs):
    """Return a rcl_interfaces/Parameter with a random name, type code and value."""
    r = rng.random()
    if r < 0.85:
        spec = rng.choice(specs)
        name = spec.name
    else:
        spec = None
        name = rng.choice(['foo', '', 'use_sim_time', 'fiber.radiuss', 'fiber',
                           'qos_overrides./tca/displacement.publisher.depth', '/tca'])
    value = ParameterValue()
    r = rng.random()
    if r < 0.1:
        value.type = rng.choice(BAD_TYPE_CODES)
        value.double_value = _double(rng, spec)
    elif r < 0.15:
        value.type = 0  # NOT_SET
    elif r < 0.7:
        value.type = 3
        value.double_value = _double(rng, spec)
    else:
        value.type = rng.randint(1, 9)
        if value.type == 1:
            value.bool_value = rng.random() < 0.5
        elif value.type == 2:
            value.integer_value = rng.choice([0, 1, -1, 2 ** 63 - 1, -2 ** 63, 1000])
        elif value.type == 3:
            value.double_value = _double(rng, spec)
        elif value.type == 4:
            value.string_value = rng.choice(['', 'rod', 'cst', 'love', 'helix', 'x' * 1000,
                                             'conical', '\u00e9'])
        elif value.type == 5:
            value.byte_array_value = [bytes([rng.randint(0, 255)]) for _ in range(3)]
        elif value.type == 6:
            value.bool_array_value = [True, False]
        elif value.type == 7:
            value.integer_array_value = [rng.randint(-5, 5) for _ in range(rng.randint(0, 4))]
        elif value.type == 8:
            value.double_array_value = [_double(rng) for _ in range(rng.randint(0, 4))]
        else:
            value.string_array_value = ['a', 'b']
    return ParameterMsg(name=name, value=value)


def _shown(value):
    """Return a short text of a ParameterValue (its type's field)."""
    field = {1: 'bool_value', 2: 'integer_value', 3: 'double_value', 4: 'string_value'}
    return repr(getattr(value, field[value.type]))[:20] if value.type in field \
        else f'<type {value.type}>'


COMMAND_TOPICS = ('power_cmd', 'voltage_cmd', 'load', 'antagonist/power_cmd')
STATE_TOPICS = (('displacement', Float64), ('resistance', Float64), ('power', Float64),
                ('force', Float64), ('antagonist/force', Float64),
                ('temperature', Temperature), ('antagonist/temperature', Temperature),
                ('joint_states', JointState))
BURST = 5  # messages published between two spins of the probe (reliable, depth 10)
SLOW_REQUEST = 1.0  # s: a request answered later than this is counted as slow
SEGMENTS = ((), ('-p', 'rig.mode:=antagonistic'))  # extra -p rules of each segment


def published_values(topic, msg):
    """Return the float values a state message carries."""
    if topic.endswith('temperature'):
        return [msg.temperature]
    if topic == 'joint_states':
        return list(msg.position) + list(msg.velocity) + list(msg.effort)
    return [msg.data]


class Campaign:
    """One running node, its probe and the counts."""

    def __init__(self, args, log_dir):
        self.args = args
        self.log_dir = pathlib.Path(log_dir)
        self.rng = random.Random(args.seed)
        self.specs = list(SCHEMA) + list(NODE_SCHEMA)
        self.counts = dict(messages=0, requests=0, accepted=0, refused=0, resets=0,
                           deaths=0, tracebacks=0, unanswered=0, slow_requests=0,
                           multiline_reasons=0, samples=0, non_finite=0,
                           broken_resistance_inf=0, bad_type_refused=0)
        self.per_topic = dict.fromkeys(COMMAND_TOPICS, 0)
        self.slowest = (0.0, '')
        self.logs = []
        self.accepted = []  # 'name=value' of the accepted requests, in order
        self.node = None
        self.extra = ()
        self.probe = Probe()
        for topic, kind in STATE_TOPICS:
            self.probe.create_subscription(
                kind, topic, lambda m, t=topic: self.count(t, m), QoSProfile(depth=100))
        self.set_client = self.probe.create_client(SetParameters, 'tca/set_parameters')
        self.atomic = self.probe.create_client(SetParametersAtomically,
                                               'tca/set_parameters_atomically')
        self.reset = self.probe.create_client(Trigger, 'tca/reset')

    def count(self, topic, msg):
        """Count one published message's values and the non-finite ones."""
        for value in published_values(topic, msg):
            self.counts['samples'] += 1
            if topic == 'resistance' and value == math.inf:
                self.counts['broken_resistance_inf'] += 1
            elif not math.isfinite(value):
                self.counts['non_finite'] += 1

    def start(self, extra=None):
        """Start (or restart) the node and wait until its services answer."""
        self.extra = self.extra if extra is None else tuple(extra)
        path = self.log_dir / f'tca_{len(self.logs)}.log'
        self.logs.append(path)
        self.node = _node_process(self.args, [
            '--params-file', CONFIG, '-p', f'model:={self.args.model}', *self.extra], path)
        self.node.wait_for_log('tca node ready', timeout=120.0)
        assert self.set_client.wait_for_service(timeout_sec=30.0)

    def alive(self):
        """Return True if the node runs; count a death and restart it otherwise."""
        if self.node.proc.poll() is None:
            return True
        self.counts['deaths'] += 1
        print(f'node died (exit {self.node.proc.returncode}); log {self.logs[-1]}')
        self.start()
        return False

    def call(self, client, request, what=''):
        start = time.monotonic()
        future = client.call_async(request)
        self.probe.spin_until(future.done, CALL_TIMEOUT)
        took = time.monotonic() - start
        if took > SLOW_REQUEST:
            self.counts['slow_requests'] += 1
        if took > self.slowest[0]:
            self.slowest = (took, what)
        if not future.done():
            self.counts['unanswered'] += 1
            if self.args.verbose:
                print(f'unanswered {what} after: {self.accepted[-3:]}', flush=True)
            client.remove_pending_request(future)
            return None
        return future.result()

    def message(self):
        topic = self.rng.choice(COMMAND_TOPICS if self.extra else COMMAND_TOPICS[:3])
        value = _double(self.rng) if self.rng.random() < 0.6 else self.rng.uniform(0.0, 3.0)
        self.probe.publish(topic, Float64(data=value))
        self.counts['messages'] += 1
        self.per_topic[topic] += 1

    def request(self):
        self.counts['requests'] += 1
        atomic = self.rng.random() < 0.2
        msgs = [random_parameter(self.rng, self.specs)
                for _ in range(self.rng.randint(1, 3) if atomic else 1)]
        what = ', '.join(f'{m.name}={_shown(m.value)}' for m in msgs)
        if atomic:
            response = self.call(self.atomic,
                                 SetParametersAtomically.Request(parameters=msgs), what)
            results = [response.result] if response is not None else []
        else:
            response = self.call(self.set_client, SetParameters.Request(parameters=msgs), what)
            results = response.results if response is not None else []
        for result in results:
            self.counts['accepted' if result.successful else 'refused'] += 1
            if result.successful:
                self.accepted.append(what)
            if '\n' in result.reason:
                self.counts['multiline_reasons'] += 1
            if not result.successful and any(m.value.type in BAD_TYPE_CODES for m in msgs):
                self.counts['bad_type_refused'] += 1

    def run(self, messages, requests):
        """Spend a message and request budget in a random order on the running node."""
        budget = ['m'] * messages + ['r'] * requests + ['x'] * max(1, requests // 20)
        self.rng.shuffle(budget)
        since_spin = 0
        for action in budget:
            if action == 'm':
                self.message()
                since_spin += 1
                if since_spin < BURST:
                    continue
            elif action == 'r':
                self.request()
            else:
                self.counts['resets'] += 1
                self.call(self.reset, Trigger.Request(), '~/reset')
            since_spin = 0
            self.probe.spin_for(0.005)
            self.alive()
        self.probe.spin_for(1.0)
        self.alive()

    def run_segments(self):
        """Run half the budget with the config's rig, half with the antagonistic rig."""
        times = []
        chosen = SEGMENTS if self.args.segment is None else [SEGMENTS[self.args.segment]]
        for k, extra in enumerate(chosen):
            t0 = time.monotonic()
            share = (lambda n: n // 2) if k == 0 and len(chosen) > 1 else \
                (lambda n: n - n // 2 if len(chosen) > 1 else n)
            self.start(extra)
            self.run(share(self.args.messages), share(self.args.requests))
            self.node.stop()
            times.append(round(time.monotonic() - t0, 1))
        return times

    def close(self):
        if self.node is not None:
            self.node.stop()
        self.counts['tracebacks'] = sum(p.read_text().count('Traceback') for p in self.logs)
        self.probe.close()


def corrupt_configs(rng, n, out_dir):
    """Return n params files: random corruptions of config/free_stroke.yaml."""
    text = CONFIG.read_text()
    lines = text.splitlines(keepends=True)
    paths = []
    for i in range(n):
        kind = rng.choice(['truncate', 'tab', 'bytes', 'drop_line', 'unknown', 'value',
                           'alias', 'toplist', 'null_section'])
        body = text
        if kind == 'truncate':
            body = text[:rng.randint(0, len(text))]
        elif kind == 'tab':
            k = rng.randrange(len(lines))
            body = ''.join(lines[:k] + ['\t' + lines[k]] + lines[k + 1:])
        elif kind == 'bytes':
            k = rng.randrange(len(text))
            body = text[:k] + ''.join(chr(rng.randint(0, 255)) for _ in range(8)) + text[k:]
        elif kind == 'drop_line':
            k = rng.randrange(len(lines))
            body = ''.join(lines[:k] + lines[k + 1:])
        elif kind == 'unknown':
            body = text + rng.choice(['    foo: 1\n', '    fiber:\n      radiuss: 0.1\n'])
        elif kind == 'value':
            spec = rng.choice([s for s in SCHEMA if isinstance(s.default, float)])
            group, _, leaf = spec.name.rpartition('.')
            value = rng.choice(['.nan', '.inf', '-.inf', '1e308', '5e-324', '0.0', '-0.0',
                                'abc', '[1, "a"]', 'null', str(spec.low), str(spec.high)])
            body = text + (f'    {group}:\n      {leaf}: {value}\n' if group
                           else f'    {leaf}: {value}\n')
        elif kind == 'alias':
            body = text.replace('length: 0.175', 'length: &l 0.175', 1) + '    x: *l\n'
        elif kind == 'toplist':
            body = '- ' + text.replace('\n', '\n  ')
        elif kind == 'null_section':
            body = '/**/tca:\n  ros__parameters:\n'
        path = pathlib.Path(out_dir) / f'bad_{i}_{kind}.yaml'
        path.write_text(body, encoding='utf-8', errors='surrogateescape')
        paths.append((kind, path))
    return paths


def run_start_ups(rng, n, out_dir, args):
    """Start the node with n bad files and the bad -p rules; return counts."""
    cases = [(kind, ['--params-file', str(p)]) for kind, p in corrupt_configs(rng, n, out_dir)]
    cases += [('rule', rule) for rule in RULES]
    counts = dict(start_ups=len(cases), exit2_one_line=0, started=0, bad_exits=0,
                  start_up_tracebacks=0)
    batch = 4
    for i in range(0, len(cases), batch):
        procs = []
        for j, (kind, ros_args) in enumerate(cases[i:i + batch]):
            log = pathlib.Path(out_dir) / f'start_{i + j}_{kind}.log'
            procs.append((kind, ros_args, _node_process(
                args, [*ros_args, '-p', f'model:={args.model}'], log)))
        for kind, ros_args, proc in procs:
            deadline = time.monotonic() + START_UP_WAIT
            while proc.proc.poll() is None and time.monotonic() < deadline \
                    and 'tca node ready' not in proc.log():
                time.sleep(0.1)  # exited (refused) or ready (a valid file): both decide it
            code = proc.stop()
            text = proc.log().strip()
            counts['start_up_tracebacks'] += text.count('Traceback')
            if code == 2 and len(text.splitlines()) == 1:
                counts['exit2_one_line'] += 1
            elif 'tca node ready' in text and 'Traceback' not in text:
                counts['started'] += 1
            else:
                counts['bad_exits'] += 1
                print(f'bad start-up ({kind}, exit {code}): {ros_args}\n{text[:300]}')
    return counts


def main(argv=None):
    """Run the campaign and print its counts."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument('--seed', type=int, default=1, help='random seed (-)')
    ap.add_argument('--messages', type=int, default=10000, help='command messages (-)')
    ap.add_argument('--requests', type=int, default=2000, help='parameter requests (-)')
    ap.add_argument('--files', type=int, default=50, help='bad params files (-)')
    ap.add_argument('--model', default='cst', choices=['cst', 'love', 'rod'],
                    help='kinetostatic model of the node')
    ap.add_argument('--code', default='', help='run the node from this checkout (dir)')
    ap.add_argument('--verbose', action='store_true', help='print unanswered requests')
    ap.add_argument('--segment', type=int, choices=(0, 1), default=None,
                    help='run only this segment (0 dead weight, 1 antagonistic), whole budget')
    ap.add_argument('--keep', default=None, help='keep the node logs in this directory')
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix='tca_fuzz_') as tmp:
        tmp = args.keep or tmp
        os.makedirs(tmp, exist_ok=True)
        t0 = time.monotonic()
        campaign = Campaign(args, tmp)
        try:
            segment_s = campaign.run_segments()
        finally:
            campaign.close()
        counts = campaign.counts
        counts['messages_per_topic'] = campaign.per_topic
        counts['slowest_request'] = f'{campaign.slowest[0]:.2f} s: {campaign.slowest[1]}'
        counts['segment_seconds'] = segment_s
        t1 = time.monotonic()
        counts.update(run_start_ups(random.Random(args.seed + 1), args.files, tmp, args))
        counts['start_up_seconds'] = round(time.monotonic() - t1, 1)
        counts['seconds'] = round(time.monotonic() - t0, 1)
    print(f'fuzz_node seed {args.seed}, model {args.model}:')
    for key, value in counts.items():
        print(f'  {key:24s} {value}')
    failed = counts['deaths'] + counts['tracebacks'] + counts['non_finite'] \
        + counts['multiline_reasons'] + counts['bad_exits'] + counts['start_up_tracebacks']
    return 1 if failed else 0


if __name__ == '__main__':
    raise SystemExit(main())
