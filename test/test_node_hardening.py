"""tca_node never dies (issue 10): bad parameter requests, bad start-ups, physics failures.

Over real topics and services (test_node_harness), with the exact inputs of the fuzz
campaign, plus in-process checks of the failure path that no valid input reaches any
more (a step that raises or goes non-finite is injected).
"""
import math

import pytest
from rcl_interfaces.msg import Parameter as ParameterMsg
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters, SetParametersAtomically
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from test_node_harness import (CONFIG, ensure_rclpy, module_command, NodeProcess,  # noqa: I100
                               Probe, start_tca)

pytestmark = pytest.mark.timeout(180)


def _raw_param(name, type_code, **value):
    return ParameterMsg(name=name, value=ParameterValue(type=type_code, **value))


def _finite_outputs(rows):
    return all(math.isfinite(m.data) for _, m in rows)


def test_parameter_requests_never_kill_the_node(tmp_path):
    node = start_tca(tmp_path)
    probe = Probe()
    try:
        disp = probe.record('displacement', Float64)
        probe.wait_matched('displacement')
        set_client = probe.create_client(SetParameters, 'tca/set_parameters')
        atomic = probe.create_client(SetParametersAtomically, 'tca/set_parameters_atomically')
        # 1. type codes outside ParameterType, and NOT_SET (would undeclare)
        for code in (10, 99, 255):
            results = probe.call(set_client, SetParameters.Request(parameters=[
                _raw_param('fiber.radius', code, double_value=1e-4)])).results
            assert not results[0].successful
            assert f'type code {code} is not a ParameterType' in results[0].reason
        result = probe.call(atomic, SetParametersAtomically.Request(parameters=[
            _raw_param('dynamics.mass', ParameterType.PARAMETER_DOUBLE, double_value=0.05),
            _raw_param('fiber.radius', 99, double_value=1e-4)])).result
        assert not result.successful and 'type code 99' in result.reason
        results = probe.call(set_client, SetParameters.Request(parameters=[
            _raw_param('fiber.radius', ParameterType.PARAMETER_NOT_SET)])).results
        assert not results[0].successful and 'NOT_SET' in results[0].reason
        # 2.-4. in-range values that would make the model non-finite: refused, one line
        refused = [
            ({'dynamics.mass': 5e-324}, 'dynamics.mass = 4.94066e-324 kg'),
            ({'thermal.convection_coefficient': 0.0}, "'thermal.convection_coefficient' = 0.0"),
            ({'thermal.convection_coefficient': -0.0}, "'thermal.convection_coefficient'"),
            ({'thermal.convection_coefficient': 5e-324}, 'h c_s A_0 = 0 W/K'),
            ({'fiber.radius': 0.005}, 'must be at least fiber.radius (0.005 m)'),
            ({'effects.creep_compliance': 2.959}, "'effects.creep_compliance' = 2.959"),
        ]
        for values, text in refused:
            result = probe.set_params('tca', **values)[0]
            assert not result.successful, values
            assert text in result.reason and '\n' not in result.reason, result.reason
        # 12. every clamp warns, the voltage one included
        for volts in (1e308, -1e308, 1e9):
            # one command per tick: commands landing in one tick leave only the last applied
            probe.publish('voltage_cmd', Float64(data=volts))
            probe.spin_for(0.1)
        probe.spin_for(0.5)
        # The node is up, its outputs finite, reset and a valid change still answer.
        reset = probe.create_client(Trigger, 'tca/reset')
        assert probe.call(reset, Trigger.Request()).success
        assert probe.set_params('tca', **{'dynamics.mass': 0.05})[0].successful
        n = len(disp)
        probe.spin_until(lambda: len(disp) > n + 10, 10.0)
        assert len(disp) > n + 10 and _finite_outputs(disp)
        assert node.proc.poll() is None
        log = node.log()
        assert 'Traceback' not in log and 'division by zero' not in log
        assert 'voltage_cmd 1e+308 V gives' in log and 'max_power 5 W: clamped' in log
    finally:
        probe.close()
        assert node.stop() == 0


def _bad_starts(tmp_path):
    """Return [(name, ros args)] of start-ups that must end in one line and exit 2."""
    head = '/**/tca:\n  ros__parameters:\n'
    files = {
        'unclosed': head + '    fiber: {radius: 0.0002\n',
        'tabs': head + '\tfiber:\n\t\tradius: 0.0002\n',
        'toplist': '- /**/tca\n- ros__parameters\n',
        'no_ros_parameters': '/**/tca:\n  fiber:\n    radius: 0.0002\n',
        'null_ros_parameters': '/**/tca:\n  ros__parameters:\n',
        'alias': head + '    fiber:\n      radius: &r 0.0002\n    coil:\n      radius: *r\n',
        'misspelt': head + '    fiber:\n      radiuss: 0.1\n',
        'unknown': head + '    foo: 1\n',
        'no_convection': head + '    thermal:\n      convection_coefficient: 0.0\n',
    }
    starts = []
    for name, text in files.items():
        path = tmp_path / f'{name}.yaml'
        path.write_text(text)
        starts.append((name, ['--params-file', path]))
    binary = tmp_path / 'binary.yaml'
    binary.write_bytes(bytes(range(256)))
    starts += [('binary', ['--params-file', binary]),
               ('missing', ['--params-file', tmp_path / 'missing.yaml']),
               ('directory', ['--params-file', tmp_path]),
               ('bad_rule', ['-p', 'physics_rate:=[1, "a"']),
               ('unknown_rule', ['-p', 'nonexistent:=1.0']),
               ('empty_name', ['-p', "joint_name:=''"])]
    return starts


def test_bad_start_ups_end_in_one_line_and_exit_2(tmp_path):
    starts = _bad_starts(tmp_path)
    batch = 4  # at a time: each costs ~2 s of imports on 2 cores
    for i in range(0, len(starts), batch):
        nodes = [(name, NodeProcess(module_command('tca_ros.ros.node', [str(a) for a in args]),
                                    tmp_path / f'{name}.log'))
                 for name, args in starts[i:i + batch]]
        for name, node in nodes:
            try:
                code = node.proc.wait(60)
            finally:
                node.stop()
            log = node.log().strip()
            assert code == 2, (name, log)
            assert len(log.splitlines()) == 1 and 'Traceback' not in log, (name, log)
            assert '[FATAL]' in log, (name, log)
    logs = {name: (tmp_path / f'{name}.log').read_text() for name, _ in starts}
    assert "'fiber.radiuss' = 0.1: unknown parameter" in logs['misspelt']
    assert "'foo' = 1: unknown parameter" in logs['unknown']
    assert "'nonexistent' = 1.0: unknown parameter" in logs['unknown_rule']
    assert "'joint_name' = '': must be a non-empty name" in logs['empty_name']
    assert 'no such file' in logs['missing'] and 'not a regular file' in logs['directory']
    assert 'aliases' in logs['alias'] and 'invalid YAML (line 3' in logs['tabs']
    assert "'thermal.convection_coefficient' = 0.0" in logs['no_convection']


# -- the failure path, in process ------------------------------------------------------
# (the episode's own failure paths are tested without ROS: test/test_node_core.py)
class _Log:
    """Logger stand-in that records (level, message)."""

    def __init__(self):
        self.lines = []

    def __getattr__(self, level):
        return lambda message, **_: self.lines.append((level, message))


@pytest.fixture
def tca():
    from rclpy.parameter import Parameter
    from tca_ros.model.tca_params import to_flat_dict
    from tca_ros.params.files import load_params
    from tca_ros.ros.node import TcaSimNode
    ensure_rclpy()
    flat = to_flat_dict(load_params(str(CONFIG)))
    flat['model'] = 'cst'
    node = TcaSimNode(parameter_overrides=[Parameter(k, value=v) for k, v in flat.items()])
    log = _Log()
    node.get_logger = lambda: log
    node.test_log = log
    yield node
    node.destroy_node()


def _errors(node):
    return [m for level, m in node.test_log.lines if level == 'error']


def _sample_finite(sample):
    return all(map(math.isfinite, (sample.displacement, sample.rate, sample.tension,
                                   sample.temperature, sample.power)))


def test_a_physics_failure_in_a_tick_is_logged_once_by_the_node(tca):
    ep = tca.core.episode

    def broken_step(power, load=None):
        raise ZeroDivisionError('float division by zero')
    ep.sim.step = broken_step
    for _ in range(50):  # 50 ticks of 10 steps: one error line, not 500
        ep.advance(10, tca.core.now_ns())
        tca._publish_state(tca.core.now_ns())
    errors = _errors(tca)
    assert len(errors) == 1, errors
    assert 'physics failed' in errors[0] and 'until ~/reset' in errors[0]
    assert ep.broken and _sample_finite(ep.sample)
    del ep.sim.step  # back to the class's step
    response = tca._on_reset(Trigger.Request(), Trigger.Response())
    assert response.success, response.message
    assert not ep.broken


def test_a_failed_reset_answers_and_a_parameter_change_recovers(tca):
    ep = tca.core.episode
    ep.fail('injected')
    ep.load = 1e4  # far beyond what the coil holds: no equilibrium
    response = tca._on_reset(Trigger.Request(), Trigger.Response())
    assert not response.success and 'reset failed' in response.message
    assert ep.broken
    ep.load = 0.3
    from rclpy.parameter import Parameter
    result = tca.set_parameters([Parameter('dynamics.damping', value=0.6)])[0]
    assert result.successful, result.reason
    assert not ep.broken and ep.failure is None
    ep.advance(10, tca.core.now_ns())
    tca._publish_state(tca.core.now_ns())
    assert _sample_finite(ep.sample)


def test_a_core_log_line_of_each_level_reaches_the_node_logger(tca):
    """rclpy ties one severity to each call site: each level has its own (a bug once)."""
    for level in ('info', 'warning', 'error', 'info'):
        tca.core.log(level, f'a {level} line')
    assert tca.test_log.lines[-4:] == [('info', 'a info line'), ('warning', 'a warning line'),
                                       ('error', 'a error line'), ('info', 'a info line')]
