"""tca_pid's control law, without ROS: limits, anti-windup, no derivative kick."""
import pytest

from tca_ros.model.dynamics import TcaSimulator
from tca_ros.params.files import load_params
from tca_ros.ros.pid_node import checked_value, PidController

from test_node_harness import module_command, NodeProcess  # noqa: I100

DT = 0.01  # s, the 100 Hz feedback of tca_node


def _pid(**overrides):
    gains = dict(kp=1500.0, ki=1000.0, kd=0.0, derivative_filter=0.05, feedforward=0.0,
                 min_power=0.0, max_power=2.0)
    gains.update(overrides)
    return PidController(**gains)


def test_output_stays_within_the_limits():
    pid = _pid()
    assert pid.update(1.0, 0.0, 0.0) == 2.0  # huge positive error: upper limit
    assert pid.update(-1.0, 0.0, DT) == 0.0  # huge negative error: lower limit


def test_integral_does_not_wind_up_while_saturated():
    pid = _pid()
    for _ in range(1000):  # 10 s far below the setpoint, output pinned at max_power
        pid.update(0.01, 0.0, DT)
    # Conditional integration: the integral stops growing once kp e alone saturates.
    assert pid.integral == pytest.approx(0.0, abs=1e-12)
    # At the setpoint the output is back inside the limits at once.
    assert pid.update(0.01, 0.01, DT) < 2.0


def test_derivative_acts_on_the_measurement_not_on_setpoint_steps():
    pid = _pid(kp=0.0, ki=0.0, kd=10.0, max_power=100.0, min_power=-100.0)
    pid.update(0.0, 0.001, 0.0)
    assert pid.update(0.005, 0.001, DT) == 0.0  # setpoint step: no kick
    assert pid.update(0.005, 0.002, DT) < 0.0  # rising measurement: damping


def test_closed_loop_on_the_model_tracks_a_step():
    """The shipped gains settle a 2 mm step of the free-stroke TCA within 0.1 mm."""
    params = load_params('free_stroke', model='cst')
    sim = TcaSimulator(params, dt=1e-3)
    pid = _pid()
    y = []
    for k in range(400):  # 4 s at 100 Hz, 10 physics steps per sample
        power = pid.update(0.002, sim.state.measured_displacement, DT if k else 0.0)
        for _ in range(10):
            sim.step(power, params.dynamics.load)
        y.append(sim.state.measured_displacement)
    # Tuning gave 1.1 s into the band; from 2 s on it must stay in it.
    assert all(abs(v - 0.002) < 1e-4 for v in y[200:])


def test_parameter_check_names_parameter_value_and_range():
    assert checked_value('kp', 20) == 20.0  # a params file may write ints
    with pytest.raises(ValueError, match=r"'kp' = -1: must be a number in \[0, 1e\+06\] W/m"):
        checked_value('kp', -1)
    with pytest.raises(ValueError, match="'max_power' = 'hot'"):
        checked_value('max_power', 'hot')


@pytest.mark.parametrize('rule, line', [
    ('min_power:=3.0', "'min_power' = 3: must not exceed max_power (2 W)"),
    ("joint_name:=''", "'joint_name' = '': must be a non-empty name"),
])
def test_bad_start_up_parameter_exits_with_one_line(tmp_path, rule, line):
    node = NodeProcess(module_command('tca_ros.ros.pid_node', ['-p', rule]), tmp_path / 'pid.log')
    try:
        assert node.proc.wait(60) == 2
    finally:
        node.stop()
    log = node.log().strip()
    assert len(log.splitlines()) == 1 and 'Traceback' not in log
    assert line in log
