"""The muscle's state on /diagnostics (issue 13, item 8).

The status builder is checked alone (tca_ros.ros.node_diagnostics is pure), then over real
topics: a node's status goes OK, WARN (overheat, watchdog), ERROR (melt), back to OK on
~/reset, and STALE while it waits for /clock; a physics failure (no valid input reaches
one) is injected into an in-process node, as test_node_hardening does.
"""
import math
import re

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
import pytest
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from tca_ros.ros.node_diagnostics import (DIAGNOSTICS_PERIOD, hardware_id, level_name,
                                          muscle_status, MuscleState, status_name)

from test_node_harness import CONFIG, ensure_rclpy, Probe, start_tca  # noqa: I100

pytestmark = pytest.mark.timeout(120)

OK, WARN, ERROR, STALE = (DiagnosticStatus.OK, DiagnosticStatus.WARN,
                          DiagnosticStatus.ERROR, DiagnosticStatus.STALE)
NOMINAL = MuscleState(temperature=25.0, power=0.0, displacement=0.0, load=0.3,
                      max_temperature=180.0, melt_temperature=250.0, command_timeout=0.5)
MAX_POWER = 5.0  # W, the node's default limit


def _values(status):
    return {kv.key: kv.value for kv in status.values}


# -- the status builder ------------------------------------------------------------
@pytest.mark.parametrize('changes, level, words', [
    ({}, OK, ('ok',)),
    ({'overheated': True, 'temperature': 190.0}, WARN,
     ('overheated: 190.0 degC', 'max_temperature 180 degC')),
    ({'watchdog_tripped': True}, WARN, ('no power or voltage command for 0.5 s',)),
    ({'broken': True}, ERROR, ('broken above melt_temperature 250 degC', '~/reset')),
    ({'broken': True, 'failure': 'ZeroDivisionError: float division by zero'}, ERROR,
     ('physics failed: ZeroDivisionError',)),
    ({'waiting': 'the first /clock message'}, STALE, ('waiting for the first /clock',)),
])
def test_each_state_has_its_level_and_message(changes, level, words):
    from dataclasses import replace
    status = muscle_status(replace(NOMINAL, **changes), '/tca: muscle', 'tca')
    assert status.level == level, level_name(status.level)
    assert all(w in status.message for w in words), status.message
    assert (status.name, status.hardware_id) == ('/tca: muscle', 'tca')


def test_the_worst_condition_sets_the_level_and_all_are_named():
    from dataclasses import replace
    state = replace(NOMINAL, overheated=True, watchdog_tripped=True, broken=True,
                    temperature=260.0)
    status = muscle_status(state, 'x', 'y')
    assert status.level == ERROR
    parts = status.message.split('; ')
    assert parts[0].startswith('broken') and parts[1].startswith('overheated') and \
        parts[2].startswith('watchdog'), status.message


def test_key_values_carry_the_state_and_the_limits():
    from dataclasses import replace
    state = replace(NOMINAL, temperature=42.125, power=1.5, displacement=-2.5e-3, load=0.25,
                    overheated=True, failure='boom', broken=True)
    values = _values(muscle_status(state, 'x', 'y'))
    expected = {'temperature (degC)': 42.125, 'power (W)': 1.5, 'max_temperature (degC)': 180.0,
                'melt_temperature (degC)': 250.0, 'displacement (m)': -2.5e-3, 'load (N)': 0.25}
    assert {k: float(values[k]) for k in expected} == expected
    assert (values['overheated'], values['broken'], values['watchdog_tripped'],
            values['physics_failure']) == ('true', 'true', 'false', 'boom')


def test_names_follow_the_node():
    assert status_name('/finger1/tca') == '/finger1/tca: muscle'
    assert hardware_id('/finger1', 'tca') == 'finger1'
    assert hardware_id('/', 'tca') == 'tca'


def test_flags_change_only_with_the_state_not_with_the_readings():
    from dataclasses import replace
    assert replace(NOMINAL, temperature=99.0, power=3.0).flags() == NOMINAL.flags()
    assert replace(NOMINAL, overheated=True).flags() != NOMINAL.flags()


# -- over real topics --------------------------------------------------------------
def _status(rows, name):
    """Return the last status named ``name`` recorded on /diagnostics (or None)."""
    for _, msg in reversed(rows):
        for status in msg.status:
            if status.name == name:
                return status
    return None


def _wait_level(probe, rows, level, name='/tca: muscle', timeout=10.0, feed=None):
    """Spin (publishing ``feed()`` every 0.1 s) until the status has ``level``.

    Return the first status of that level: the one sent when the state changed.
    """
    def reached():
        status = _status(rows, name)
        return status is not None and status.level == level
    waited = 0.0
    while waited < timeout and not reached():
        if feed:
            feed()
        probe.spin_until(reached, 0.1)
        waited += 0.1
    assert reached(), (level_name(level), _status(rows, name))
    return next(s for _, m in rows for s in m.status if s.name == name and s.level == level)


@pytest.fixture(scope='module')
def tca(tmp_path_factory):
    node = start_tca(tmp_path_factory.mktemp('diagnostics'))
    yield node
    assert node.stop() == 0, node.log()
    assert 'Traceback' not in node.log()


@pytest.fixture(scope='module')
def probe(tca):
    probe = Probe()
    probe.rows = probe.record('/diagnostics', DiagnosticArray)
    probe.reset_client = probe.create_client(Trigger, 'tca/reset')
    probe.wait_matched('/diagnostics')
    yield probe
    probe.close()


def test_ok_at_start_about_once_a_second(probe):
    status = _wait_level(probe, probe.rows, OK)
    assert status.hardware_id == 'tca' and status.message == 'ok'
    values = _values(status)
    assert float(values['temperature (degC)']) == pytest.approx(25.0, abs=0.5)
    assert float(values['power (W)']) == 0.0
    assert float(values['max_temperature (degC)']) == 180.0
    probe.rows.clear()
    probe.spin_for(2.2 * DIAGNOSTICS_PERIOD)
    # the 1 s timer only: not once per 100 Hz tick while nothing changes
    assert 1 <= len(probe.rows) <= 4, len(probe.rows)
    assert all(m.header.stamp.sec > 0 for _, m in probe.rows)  # node time (wall here)


def test_overheat_warns_melt_errs_reset_clears(tca, probe):
    assert all(r.successful for r in probe.set_params(
        'tca', max_temperature=30.0, melt_temperature=40.0))
    try:
        heat = lambda: probe.publish('power_cmd', Float64(data=MAX_POWER))  # noqa: E731
        status = _wait_level(probe, probe.rows, WARN, feed=heat)
        assert 'overheated' in status.message, status.message
        values = _values(status)
        assert float(values['temperature (degC)']) > 30.0
        assert values['overheated'] == 'true' and values['broken'] == 'false'
        status = _wait_level(probe, probe.rows, ERROR, feed=heat)
        assert 'broken above melt_temperature 40 degC' in status.message, status.message
        values = _values(status)
        assert values['broken'] == 'true' and float(values['power (W)']) == 0.0
        # the status goes out at the end of the tick that broke it: a tick catching up
        # on a loaded machine runs several steps, cooling the unpowered thread after the
        # step that broke it (39.7 degC seen), so the break's own temperature is the log's
        tca.wait_for_log('above melt_temperature 40 degC: the muscle broke')
        broke = re.findall(r'temperature ([0-9.]+) degC above melt_temperature 40 degC',
                           tca.log())
        assert broke and float(broke[-1]) >= 40.0, tca.log()  # printed to 0.1 K
        assert float(values['temperature (degC)']) > 30.0
    finally:
        results = probe.set_params('tca', melt_temperature=250.0, max_temperature=180.0)
    assert all(r.successful for r in results)
    probe.rows.clear()
    assert probe.call(probe.reset_client, Trigger.Request()).success
    status = _wait_level(probe, probe.rows, OK, timeout=DIAGNOSTICS_PERIOD / 2)
    assert float(_values(status)['temperature (degC)']) == 25.0
    assert 'Traceback' not in tca.log()


def test_watchdog_trip_warns_and_a_command_clears_it(probe):
    probe.publish('power_cmd', Float64(data=0.5))
    status = _wait_level(probe, probe.rows, WARN)  # command_timeout 0.5 s
    assert 'watchdog: no power or voltage command for 0.5 s' in status.message
    assert _values(status)['watchdog_tripped'] == 'true'
    probe.rows.clear()
    probe.publish('power_cmd', Float64(data=0.0))
    # at the next tick, not at the next 1 s repeat
    _wait_level(probe, probe.rows, OK, timeout=DIAGNOSTICS_PERIOD / 2)
    assert probe.call(probe.reset_client, Trigger.Request()).success


def test_stale_until_the_clock_starts_in_a_namespace(tmp_path, probe):
    node = start_tca(tmp_path, '-r', '__ns:=/finger1', '-p', 'use_sim_time:=true')
    try:
        status = _wait_level(probe, probe.rows, STALE, name='/finger1/tca: muscle')
        assert status.hardware_id == 'finger1'
        assert 'waiting for the first /clock message' in status.message
        assert 'sim clock (use_sim_time: /clock)' in node.log()  # the ready line says so
        ticks = iter(range(1, 10 ** 6))  # a simulator's /clock, 0.1 s per wall 0.1 s

        def clock():
            sec, tenths = divmod(next(ticks), 10)
            probe.publish('/clock', Clock(clock=Time(sec=sec, nanosec=100_000_000 * tenths)))
        _wait_level(probe, probe.rows, OK, name='/finger1/tca: muscle', feed=clock)
    finally:
        assert node.stop() == 0, node.log()
    assert 'Traceback' not in node.log()


def test_a_physics_failure_is_an_error_until_reset():
    from rclpy.parameter import Parameter
    from tca_ros.model.tca_params import to_flat_dict
    from tca_ros.params.files import load_params
    from tca_ros.ros.node import TcaSimNode
    ensure_rclpy()
    flat = to_flat_dict(load_params(str(CONFIG)))
    flat['model'] = 'cst'
    node = TcaSimNode(parameter_overrides=[Parameter(k, value=v) for k, v in flat.items()],
                      namespace='/injected')
    sent = []
    node._diagnostics._pub = type('Recorder', (), {'publish': staticmethod(sent.append)})
    ep = node.core.episode
    try:
        ep.advance(10, node.core.now_ns())
        node._publish_state(node.core.now_ns())
        assert [s.level for m in sent for s in m.status] == [OK]

        def broken_step(power, load=None):
            raise ZeroDivisionError('float division by zero')
        ep.sim.step = broken_step
        for _ in range(20):  # 20 ticks: one status for the change, not one per tick
            ep.advance(10, node.core.now_ns())
            node._publish_state(node.core.now_ns())
        (status,) = sent[1].status
        assert len(sent) == 2 and status.level == ERROR, [m.status for m in sent]
        assert status.message.startswith('physics failed: ZeroDivisionError: float division')
        assert math.isfinite(float(_values(status)['temperature (degC)']))
        assert status.name == '/injected/tca: muscle'
        del ep.sim.step
        assert node._on_reset(Trigger.Request(), Trigger.Response()).success
        assert len(sent) == 3 and sent[2].status[0].level == OK
    finally:
        node.destroy_node()
