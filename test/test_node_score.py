"""`tca_sim score --namespace`: tasks played over ROS against tca_pid in /finger1.

tca_node and tca_pid (stamped_reference) run as subprocesses in /finger1; the scorer
runs in the test process. The scores must equal the in-process ones of tca_pid's law
(same reference, load, physics; only the float rounding of the sample time differs)
and two runs must give identical samples. No node or no controller: one line, exit 2.
"""
import numpy as np
import pytest

from tca_ros.cli.common import InputError
from tca_ros.cli.main import main as cli_main
from tca_ros.cli.score_ros import score_over_ros
from tca_ros.params.files import load_params
from tca_ros.ros.node_task import parse_record, parse_task, task_message
from tca_ros.ros.pid_node import PARAMETERS, PidController
from tca_ros.toolkit.scoring import law_controller, run_tasks
from tca_ros.toolkit.tasks import Task

from test_node_harness import (  # noqa: I100
    ensure_rclpy, module_command, NodeProcess, start_tca)

NAMESPACE = '/finger1'
#: Short tasks (1 s of sim time each): a step, and a step with a load disturbance.
TASKS = (
    Task('step_short', 1.0, 'step 0 -> 0.5 S at 0.2 s', 'steps', ((0.2, 0.5),)),
    Task('load_short', 1.0, '0.3 S from 0.1 s; load x1.5 from 0.4 s to 0.7 s', 'steps',
         ((0.1, 0.3),), load_steps=((0.4, 1.5), (0.7, 1.0))),
)
# Over ROS, tca_pid's sample time is (stamp difference) * 1e-9 = 0.01 s exactly; in
# process t[k] - t[k-1] of k * 0.01, off by up to ~1e-17 s: the samples agree to
# rounding, far inside these bounds.
SAMPLE_TOLERANCE = 1e-12  # m, degC, W
METRIC_TOLERANCE = 1e-9  # relative


@pytest.fixture(scope='module')
def logs(tmp_path_factory):
    """Return the directory of the nodes' logs."""
    return tmp_path_factory.mktemp('score')


@pytest.fixture(scope='module')
def node(logs):
    """tca_node in /finger1: own clock, lockstep, as fast as possible."""
    ensure_rclpy()
    process = start_tca(logs, '-r', f'__ns:={NAMESPACE}', '-p', 'publish_clock:=true', '-p',
                        'lockstep:=true', '-p', 'real_time_factor:=0.0')
    yield process
    process.stop()


@pytest.fixture(scope='module')
def loop(node, logs):
    """tca_pid (stamped_reference) in /finger1 with the node."""
    pid = NodeProcess(module_command('tca_ros.ros.pid_node', [
        '-r', f'__ns:={NAMESPACE}', '-p', 'stamped_reference:=true']), logs / 'pid.log')
    yield node, pid
    pid.stop()


def _in_process():
    gains = {name: default for name, default, *_ in PARAMETERS if name != 'setpoint'}
    return run_tasks(TASKS, load_params('free_stroke'),
                     law_controller(lambda: PidController(**gains)), model='cst')


def test_no_controller_is_one_line_within_the_timeout(node):
    """Runs before tca_pid starts: the node is there, nothing answers it."""
    with pytest.raises(InputError, match=r'^no controller in /finger1 within 2 s \(nothing '
                                         r'publishes /finger1/power_cmd'):
        score_over_ros(TASKS[:1], NAMESPACE, timeout=2.0, discovery=30.0)


def test_scores_over_ros_equal_in_process_and_repeat(loop):
    first, values = score_over_ros(TASKS, NAMESPACE, timeout=20.0)
    second, _ = score_over_ros(TASKS, NAMESPACE, timeout=20.0)
    assert values['stamped_reference'] and values['model'] == 'cst'
    for ros, again, local in zip(first, second, _in_process()):
        for key in ('displacement', 'temperature', 'power'):
            assert np.array_equal(ros[key], again[key]), (ros['task'], key)  # determinism
            np.testing.assert_allclose(ros[key], local[key], rtol=0, atol=SAMPLE_TOLERANCE,
                                       err_msg=f'{ros["task"]} {key}')
        assert ros['metrics'] == again['metrics']
        for name, value in local['metrics'].items():
            assert ros['metrics'][name] == pytest.approx(value, rel=METRIC_TOLERANCE,
                                                         nan_ok=True), (ros['task'], name)
        assert not ros['broken']
    # The runs did what the tasks say: full power after the step, the muscle
    # contracting (2.3 mm of the 9.2 mm step in 0.8 s), the load at x1.5.
    assert first[0]['power'][0] == 0.0 and first[0]['power'].max() == 2.0
    assert first[0]['displacement'][-1] > 0.2 * first[0]['reference'][-1]
    assert first[1]['load'].max() == pytest.approx(1.5 * first[1]['load'][0])


def test_no_tca_node_exits_2_with_one_line(capsys):
    status = cli_main(['score', '--namespace', '/nobody', '--timeout', '1', '--tasks',
                       'step_up', '--duration', '1'])
    assert status == 2
    assert capsys.readouterr().err == (
        'tca_sim score: error: no tca node answers in /nobody within 1 s (nothing reads '
        '/nobody/task; start one, or use --start-node)\n')


def test_task_and_record_layouts_round_trip():
    serial, reference, load = parse_task(task_message(7, [0.0, 0.001], [0.3, 0.45]).data)
    assert (serial, reference, load) == (7.0, [0.0, 0.001], [0.3, 0.45])
    record = parse_record([7, 1, 2, 0, 2, 1e-3, 2e-3, 30.0, 31.0, 0.5, 0.6])
    assert record == {'serial': 7, 'missed': 1, 'extra': 2, 'broken': False,
                      'displacement': [1e-3, 2e-3], 'temperature': [30.0, 31.0],
                      'power': [0.5, 0.6]}
    for bad, why in (([1, 3, 0.0, 0.0], 'N = 3 with 4 values'),
                     ([1, 1, 0.0, 0.0], 'N = 1'),
                     ([1, 2, 0.0, float('nan'), 0.3, 0.3], 'all finite'),
                     ([1, 2, 0.0, 0.0, 0.3, -0.1], 'load -0.1 N')):
        with pytest.raises(ValueError, match=why):
            parse_task(bad)


class _DroppingClient:
    """A service client whose first ``drops`` requests get no response (a response
    Fast DDS dropped), then answered with ``response``."""

    def __init__(self, drops, response):
        self.sent, self.removed = 0, 0
        self._drops, self._response = drops, response

    def call_async(self, request):
        from rclpy.task import Future
        self.sent += 1
        future = Future()
        if self.sent > self._drops:
            future.set_result(self._response)
        return future

    def remove_pending_request(self, future):
        self.removed += 1


def test_a_dropped_get_parameters_response_is_asked_again_until_the_timeout(monkeypatch):
    """A request left unanswered is sent again every RESEND_AFTER s (the earlier one is
    forgotten) until one is answered; nothing answering within timeout gives None. The
    scorer's get_parameters goes through service_call.answer_of."""
    from tca_ros.cli import score_ros
    from tca_ros.ros import service_call
    assert score_ros.answer_of is service_call.answer_of
    clock = [0.0]
    monkeypatch.setattr(service_call.time, 'monotonic', lambda: clock[0])

    def spin_until(predicate, wait):  # the fake executor: the wait passes, no callback
        if predicate():
            return True
        clock[0] += wait
        return False

    def ask(client):
        return service_call.answer_of(lambda: client.call_async('request'), spin_until,
                                      10.0, client.remove_pending_request)
    client = _DroppingClient(2, 'values')
    assert ask(client) == 'values'
    assert (client.sent, client.removed, clock[0]) == (3, 2, 2 * service_call.RESEND_AFTER)
    clock[0] = 0.0
    silent = _DroppingClient(100, 'values')
    assert ask(silent) is None
    assert clock[0] == 10.0 and silent.sent == 5 == silent.removed
