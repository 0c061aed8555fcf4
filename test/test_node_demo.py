"""The closed-loop demo (tca_node + tca_pid + recorder) writes its figure and table."""
import math

import pytest

from tca_ros.cli.demo import run_demo, setpoint_at

pytestmark = pytest.mark.timeout(120)


def test_setpoint_profile_steps_then_sine():
    assert setpoint_at(0.0, 30.0) == 0.0
    assert setpoint_at(5.0, 30.0) == 0.002
    assert setpoint_at(12.0, 30.0) == 0.004
    assert setpoint_at(20.0, 30.0) == 0.001
    assert setpoint_at(24.0, 30.0) == pytest.approx(0.0025)  # sine starts at its mean


def test_demo_runs_and_writes_the_tracking_figure(tmp_path, capsys):
    """run_demo uses its own rclpy context and random domain beside the other tests."""
    summary = run_demo(tmp_path, sim_seconds=4.0, model='cst')
    assert (tmp_path / 'demo_tracking.png').stat().st_size > 10_000
    assert 'overall rms error' in capsys.readouterr().out
    assert math.isfinite(summary['rms_error'])
    assert summary['max_temperature'] > 40.0  # the controller did heat the muscle
