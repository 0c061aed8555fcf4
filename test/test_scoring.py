"""The task set and metrics of tca_ros.toolkit.tasks and the in-process scorer."""
import math

import numpy as np
import pytest

from tca_ros.ros.pid_node import PARAMETERS, PidController
from tca_ros.toolkit import tasks
from tca_ros.toolkit.scoring import format_table, law_controller, run_task, stroke_scales


def test_first_order_step_metrics_match_closed_form():
    tau, size = 0.5, 0.004  # s, m
    t = np.arange(0.0, 6.0 + 1e-9, 1e-3)
    reference = np.where(t >= 1.0, size, 0.0)
    y = np.where(t >= 1.0, size * (1.0 - np.exp(-(t - 1.0) / tau)), 0.0)
    temp = 100.0 + 100.0 * (t > 5.0)  # above 180 degC for the last second
    power = np.full(t.size, 1.5)
    m = tasks.score(t, reference, y, temp, power, max_temperature=180.0)
    assert m['overshoot'] == 0.0
    # the error leaves the 5 % band at 3 tau = tau ln 20, to one sample
    assert m['settling_time'] == pytest.approx(tau * math.log(20.0), abs=2e-3)
    assert m['max_error'] == pytest.approx(size, rel=1e-12)
    assert m['energy'] == pytest.approx(1.5 * 6.0, rel=1e-9)
    assert m['time_above_max'] == pytest.approx(1.0, abs=2e-3)
    assert m['peak_temperature'] == 200.0


def test_underdamped_overshoot_is_the_closed_form():
    zeta, wn = 0.3, 10.0  # -, rad/s: overshoot exp(-pi zeta / sqrt(1 - zeta^2))
    t = np.arange(0.0, 5.0, 1e-4)
    wd = wn * math.sqrt(1.0 - zeta ** 2)
    y = 1.0 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    reference = np.ones_like(t)
    reference[0] = 0.0
    m = tasks.score(t, reference, y, np.zeros_like(t), np.zeros_like(t), 180.0)
    expected = 100.0 * math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta ** 2))
    assert m['overshoot'] == pytest.approx(expected, rel=1e-4)


def test_default_tasks_stay_within_their_scales(free_stroke):
    stroke, hot = stroke_scales(free_stroke, 'cst')
    assert 0.0 < stroke < hot
    for task in tasks.DEFAULT_TASKS:
        t = np.arange(0.0, task.duration + 1e-9, 0.01)
        r = task.reference(t, stroke, hot)
        assert r.min() >= 0.0 and r.max() <= (hot if task.kind == 'overheat' else stroke)
        assert np.all(task.load(t, 0.3) > 0.0)
    assert len({task.name for task in tasks.DEFAULT_TASKS}) == len(tasks.DEFAULT_TASKS)


def pid_factory():
    defaults = {name: default for name, default, *_ in PARAMETERS if name != 'setpoint'}
    return law_controller(lambda: PidController(**defaults))


def test_tca_pid_reference_entry_is_deterministic_and_settles(free_stroke):
    task = tasks.DEFAULT_TASKS[0]  # step_up
    first = run_task(task, free_stroke, pid_factory(), model='cst')
    second = run_task(task, free_stroke, pid_factory(), model='cst')
    assert first['metrics'] == second['metrics']
    m = first['metrics']
    assert m['settling_time'] < 5.0 and m['peak_temperature'] < 180.0
    assert m['energy'] == pytest.approx(np.sum(first['power'][:-1]) * 0.01, rel=1e-12)
    assert '| step_up |' in format_table([first])


def lossy(params, factor):
    """Return ``params`` with ``factor`` times the convection coefficient (more heat loss)."""
    h = params.thermal.convection_coefficient
    return params.with_values(**{'thermal.convection_coefficient': factor * h})


def test_reach_is_the_statics_at_the_steady_state_temperature(free_stroke):
    from tca_ros.model.simulation import static_displacement
    from tca_ros.model.thermal import steady_state_temperature
    from tca_ros.toolkit.scoring import reachable_contraction, steady_temperature
    load = free_stroke.dynamics.load
    temp = steady_state_temperature(1.0, free_stroke.fiber, free_stroke.thermal)
    assert steady_temperature(free_stroke, 1.0) == pytest.approx(temp, rel=1e-12)
    reach, at = reachable_contraction(free_stroke, 1.0, load, load, 'cst')
    assert at == pytest.approx(temp)
    expected = static_displacement(free_stroke, load, [25.0, temp], model='cst')[-1]
    assert reach == pytest.approx(expected, rel=1e-6)
    # a heavier load than the one the task started with reads lower: it stretches first
    heavier, _ = reachable_contraction(free_stroke, 1.0, 1.5 * load, load, 'cst')
    assert heavier < reach


def test_task_limits_say_out_of_reach_when_the_power_limit_cannot_get_there(free_stroke):
    from tca_ros.toolkit.scoring import task_limits
    task = tasks.DEFAULT_TASKS[0]  # step_up to 0.5 S
    inside = task_limits(task, free_stroke, 2.0, 'tca_pid max_power', 'cst')
    assert inside['in_reach'] and inside['warning'] == ''
    assert inside['text'].startswith('P <= 2 W (tca_pid max_power); T_max 180 degC')
    assert inside['text'].endswith('in reach') and inside['reach'] > inside['peak'] > 0.0
    cold = task_limits(task, lossy(free_stroke, 5.0), 2.0, 'tca_pid max_power', 'cst')
    assert not cold['in_reach'] and cold['reach'] < cold['peak']
    assert cold['text'].endswith('OUT OF REACH')
    assert cold['warning'].startswith('task step_up: the reference reaches ')
    assert 'at the 2 W power limit (tca_pid max_power)' in cold['warning']
    assert '\n' not in cold['warning']


def test_score_warns_before_an_unreachable_task_and_each_row_names_its_limits(
        tmp_path, capsys, free_stroke):
    import io
    from tca_ros.cli.main import main
    from tca_ros.params.files import dump_params
    config = tmp_path / 'lossy.yaml'
    dump_params(lossy(free_stroke, 5.0), str(config))
    argv = ['score', '--model', 'cst', '--tasks', 'step_up,ramp', '--duration', '4']
    out = io.StringIO()
    assert main(argv + ['--config', str(config)], out=out) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and all(line.startswith('tca_sim score: warning: task ')
                                 for line in err)
    assert 'step_up' in err[0] and 'ramp' in err[1] and 'out of reach' in err[0]
    rows = [line for line in out.getvalue().splitlines() if line.startswith('| step_up')
            or line.startswith('| ramp')]
    assert len(rows) == 2 and all('P <= 2 W (tca_pid max_power; driver 5 W)' in row
                                  and row.endswith('OUT OF REACH |') for row in rows)
    out = io.StringIO()
    assert main(argv, out=out) == 0
    assert capsys.readouterr().err == ''
    assert '| limits |' in out.getvalue() and out.getvalue().count(': in reach |') == 2
