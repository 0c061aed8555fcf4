"""`tca_sim score --namespace`: tasks played over ROS against tca_pid in /finger1.

tca_node and tca_pid (stamped_reference) run as subprocesses in /finger1; the scorer
runs in the test process. The scores must equal the in-process ones of tca_pid's law
(same reference, load, physics; only the float rounding of the sample time differs)
and two runs must give identical samples. No node or no controller: one line, exit 2.
"""
import subprocess

import numpy as np
import pytest

from tca_ros.cli_common import InputError
from tca_ros.model.params import load_params
from tca_ros.node_task import parse_record, parse_task, task_message
from tca_ros.pid_node import PARAMETERS, PidController
from tca_ros.score_ros import score_over_ros
from tca_ros.toolkit.scoring import law_controller, run_tasks
from tca_ros.toolkit.tasks import Task

from test_node_harness import (  # noqa: I100
    ensure_rclpy, module_command, NodeProcess, PYTHON, ROOT, start_tca)

NAMESPACE = '/finger1'
#: Short tasks (< 1 s of wall each): a step, a sine and a load disturbance with a step.
TASKS = (
    Task('step_short', 1.5, 'step 0 -> 0.5 S at 0.2 s', 'steps', ((0.2, 0.5),)),
    Task('load_short', 1.5, '0.3 S from 0.1 s; load x1.5 from 0.6 s to 1.1 s', 'steps',
         ((0.1, 0.3),), load_steps=((0.6, 1.5), (1.1, 1.0))),
    Task('sine_short', 1.0, '0.4 S + 0.25 S sin, period 1 s', 'sine', period=1.0),
)
# Over ROS, tca_pid's sample time is (stamp difference) * 1e-9 = 0.01 s exactly; in
# process t[k] - t[k-1] of k * 0.01, off by up to ~1e-17 s: the samples agree to
# rounding, far inside these bounds.
SAMPLE_TOLERANCE = 1e-12  # m, degC, W
METRIC_TOLERANCE = 1e-9  # relative


@pytest.fixture(scope='module')
def loop(tmp_path_factory):
    """tca_node (own clock, lockstep, as fast as possible) and tca_pid in /finger1."""
    logs = tmp_path_factory.mktemp('score')
    ensure_rclpy()
    node = start_tca(logs, '-r', f'__ns:={NAMESPACE}', '-p', 'publish_clock:=true', '-p',
                     'lockstep:=true', '-p', 'real_time_factor:=0.0')
    pid = NodeProcess(module_command('tca_ros.pid_node', [
        '-r', f'__ns:={NAMESPACE}', '-p', 'stamped_reference:=true']), logs / 'pid.log')
    yield node, pid
    pid.stop()
    node.stop()


def _in_process():
    gains = {name: default for name, default, *_ in PARAMETERS if name != 'setpoint'}
    return run_tasks(TASKS, load_params('free_stroke'),
                     law_controller(lambda: PidController(**gains)), model='cst')


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
    # The tasks did what they say: heating to follow the step, the load at x1.5.
    assert first[0]['displacement'][-1] > 0.3 * first[0]['reference'][-1]
    assert first[1]['load'].max() == pytest.approx(1.5 * first[1]['load'][0])


def test_no_tca_node_in_the_namespace_is_one_line_and_exit_2(loop):
    with pytest.raises(InputError, match=r'^no tca node answers in /nobody within 1 s'):
        score_over_ros(TASKS[:1], '/nobody', timeout=1.0)


def test_no_controller_exits_2_with_one_line_and_stops_its_node(tmp_path):
    """--start-node in a namespace without a controller: exit 2 within the timeout."""
    command = [PYTHON, '-m', 'tca_ros.cli', 'score', '--namespace', '/lonely',
               '--start-node', '--model', 'cst', '--timeout', '2', '--tasks', 'step_up',
               '--duration', '1', '--out', str(tmp_path)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count('\n') == 1
    assert done.stderr.startswith('tca_sim score: error: no controller in /lonely within '
                                  '2 s'), done.stderr
    assert 'tca node ready' in (tmp_path / 'tca_node.log').read_text()


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
