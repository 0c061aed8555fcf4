"""The task set and metrics of tca_ros.toolkit.tasks and the in-process scorer."""
import math

import numpy as np
import pytest

from tca_ros.pid_node import PARAMETERS, PidController
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
