"""tca_node over real topics, wall-clock mode: one node process for the module."""
import math
import time

import numpy as np
import pytest
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64
from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker

from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.thermal import thermal_conductance, thermal_time_constant
from tca_ros.params.files import load_params

from test_node_harness import Probe, start_tca  # noqa: I100

pytestmark = pytest.mark.timeout(120)

PARAMS = load_params('free_stroke', model='cst')
MAX_POWER = 5.0  # W, the node's default limit


@pytest.fixture(scope='module')
def tca(tmp_path_factory):
    node = start_tca(tmp_path_factory.mktemp('node'))
    yield node
    assert node.stop() == 0, node.log()


@pytest.fixture(scope='module')
def probe(tca):
    p = Probe()
    for topic, kind in (('temperature', Temperature), ('power', Float64),
                        ('resistance', Float64), ('displacement', Float64),
                        ('joint_states', JointState), ('shape', Marker)):
        p.record(topic, kind)
    p.reset_client = p.create_client(Trigger, 'tca/reset')
    p.wait_matched(*p.records)
    assert p.spin_until(lambda: len(p.records['temperature']) > 0, 20.0), tca.log()
    yield p
    p.close()


@pytest.fixture
def fresh(probe):
    """Reset the node (nominal load, no command), clear the records, return the probe."""
    probe.publish('load', Float64(data=PARAMS.dynamics.load))
    probe.spin_for(0.05)
    response = probe.call(probe.reset_client, Trigger.Request())
    assert response.success
    probe.spin_for(0.1)
    for rows in probe.records.values():
        rows.clear()
    return probe


def _power_after(probe, topic, value, settle=0.3):
    probe.publish(topic, Float64(data=value))
    probe.spin_for(settle)
    return probe.records['power'][-1][1].data


def test_power_step_heats_with_the_thermal_time_constant(fresh):
    """Eq. (1): T = T_amb + P/(h c_s A)(1 - exp(-t/tau)); fit tau from the topic."""
    power = 1.0  # W
    # on a loaded machine the probe's commands can come later than the 0.5 s watchdog
    # allows, which would cut the step: a longer timeout for this test only
    assert fresh.set_params('tca', command_timeout=5.0)[0].successful
    try:
        for _ in range(25):  # 2.5 s, commands every 0.1 s
            fresh.publish('power_cmd', Float64(data=power))
            fresh.spin_for(0.1)
    finally:
        assert fresh.set_params('tca', command_timeout=0.5)[0].successful
    rows = fresh.records['temperature']
    t = np.array([m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for _, m in rows])
    temp = np.array([m.temperature for _, m in rows])
    steady = PARAMS.thermal.ambient_temperature + power / thermal_conductance(
        PARAMS.fiber, PARAMS.thermal)
    heating = temp > PARAMS.thermal.ambient_temperature + 0.5  # clear of the step instant
    slope, _ = np.polyfit(t[heating], np.log(steady - temp[heating]), 1)
    tau = thermal_time_constant(PARAMS.fiber, PARAMS.thermal)
    # The physics updates eq. (1) exactly and the stamps are the physics time: the fit of
    # noise-free samples is limited by the stamp resolution (1 ms of 3 s), so 1 %.
    assert -1.0 / slope == pytest.approx(tau, rel=0.01)
    assert len(t) > 150  # 100 Hz for 2.5 s, minus start-up slack


def test_load_step_settles_at_the_model_equilibrium(fresh):
    """A load step stretches the TCA by the static elongation difference of the model."""
    sim = TcaSimulator(PARAMS, dt=1e-3)
    load = 0.5  # N
    expected = sim.equilibrium(PARAMS.dynamics.load, 25.0) - sim.equilibrium(load, 25.0)
    fresh.publish('load', Float64(data=load))
    fresh.spin_for(2.0)  # damping ratio ~0.3, omega ~27 rad/s: settled in < 1 s
    assert fresh.records['displacement'][-1][1].data == pytest.approx(expected, rel=1e-3)
    joint = fresh.records['joint_states'][-1][1]
    assert joint.effort[0] == pytest.approx(load, rel=1e-3)  # tension balances the load
    # Same sample on both topics; the last messages may come from neighbouring ticks, in
    # which the mass still creeps by < 1e-10 m.
    assert joint.position[0] == pytest.approx(fresh.records['displacement'][-1][1].data,
                                              abs=1e-9)


def test_bad_power_commands_are_rejected_clamped_or_floored(fresh, tca):
    # A rejected command does not feed the watchdog (0.5 s): re-send a valid one first.
    for bad in (math.nan, math.inf, -math.inf):
        assert _power_after(fresh, 'power_cmd', 0.7, settle=0.15) == 0.7
        assert _power_after(fresh, 'power_cmd', bad, settle=0.15) == 0.7  # last valid kept
    assert 'power_cmd: rejected non-finite value nan' in tca.log()
    assert _power_after(fresh, 'power_cmd', -3.0, settle=0.15) == 0.0
    assert _power_after(fresh, 'power_cmd', 1e6, settle=0.15) == MAX_POWER
    assert _power_after(fresh, 'load', math.nan, settle=0.15) == MAX_POWER  # load ignored
    assert fresh.records['joint_states'][-1][1].effort[0] > 0.0
    assert tca.proc.poll() is None  # still alive
    fresh.publish('power_cmd', Float64(data=0.0))


def test_voltage_command_heats_with_v_squared_over_r(fresh):
    voltage = 5.0  # V
    rows = fresh.records['power']
    fresh.publish('voltage_cmd', Float64(data=voltage))
    # waits for the event: the first power the voltage drives, then one tick more
    assert fresh.spin_until(lambda: rows and rows[-1][1].data > 0.0, 10.0)
    count = len(rows)
    assert fresh.spin_until(lambda: len(rows) > count, 10.0)
    power = fresh.records['power'][-1][1].data
    res = fresh.records['resistance'][-1][1].data
    # R is re-read every physics step; between the two samples R moves by < 0.1 %.
    assert power == pytest.approx(voltage ** 2 / res, rel=2e-3)
    fresh.publish('power_cmd', Float64(data=0.0))


def test_watchdog_cuts_power_after_command_timeout(fresh, tca):
    # waits for the events, not for wall-clock deadlines: on a loaded machine the cut
    # can reach the probe later than command_timeout plus a publish period
    rows = fresh.records['power']
    last = lambda: rows[-1][1].data if rows else None  # noqa: E731
    sent = time.monotonic()
    fresh.publish('power_cmd', Float64(data=1.0))
    assert fresh.spin_until(lambda: last() == 1.0, 10.0)
    assert fresh.spin_until(lambda: last() == 0.0, 10.0)
    on = next(i for i, (t, m) in enumerate(rows) if t > sent and m.data == 1.0)
    cut = next(t for t, m in rows[on:] if m.data == 0.0)
    assert cut - sent >= 0.5  # command_timeout: never before it (received after it is sent)
    assert 'no power or voltage command for 0.5 s' in tca.log()


def test_overheat_and_melt_break_the_muscle_until_reset(fresh, tca):
    result = fresh.set_params('tca', max_temperature=40.0, melt_temperature=50.0)
    assert all(r.successful for r in result)
    try:
        for _ in range(10):
            fresh.publish('power_cmd', Float64(data=MAX_POWER))
            fresh.spin_for(0.1)
        log = tca.log()
        assert 'above max_temperature' in log
        assert 'the muscle broke' in log
        joint = fresh.records['joint_states'][-1][1]
        assert joint.effort[0] == 0.0
        assert fresh.records['resistance'][-1][1].data == math.inf
        assert fresh.records['power'][-1][1].data == 0.0  # no current through a break
    finally:
        result = fresh.set_params('tca', melt_temperature=250.0, max_temperature=180.0)
    assert all(r.successful for r in result)
    assert fresh.call(fresh.reset_client, Trigger.Request()).success
    temps, res = fresh.records['temperature'], fresh.records['resistance']
    # waits for the event: a state published after the reset, every topic of its tick
    assert fresh.spin_until(lambda: temps and temps[-1][1].temperature == 25.0 and res
                            and math.isfinite(res[-1][1].data), 10.0)
    assert fresh.records['resistance'][-1][1].data == pytest.approx(
        PARAMS.electrical.resistance, rel=1e-9)
    assert fresh.records['temperature'][-1][1].temperature == 25.0


@pytest.mark.parametrize('values, reason', [
    ({'fiber__radius': 0.5}, ('fiber.radius', '0.5', '0.005')),  # rclpy's range check
    ({'fiber__radius': 'thick'}, ("'fiber.radius' = 'thick'", '[1e-06, 0.005] m')),
    ({'model': 'spring'}, ('must be one of rod, cst, love',)),
    ({'melt_temperature': 100.0}, ('must be above max_temperature',)),
    ({'physics_rate': 50.0}, ('must not exceed physics_rate',)),
    ({'dynamics__mass': 1e-12}, ('dynamics.mass', 'substeps')),  # 2/omega = 0.4 us
    ({'publish_clock': True}, ('read-only',)),
])
def test_invalid_parameter_set_is_refused_with_a_reason(probe, tca, values, reason):
    (result, *_) = probe.set_params('tca', **values)
    assert not result.successful
    for text in reason:
        assert text in result.reason
    assert tca.proc.poll() is None


def test_valid_parameter_set_is_applied(fresh):
    result = fresh.set_params('tca', dynamics__load=0.4, noise__temperature=0.5)
    assert all(r.successful for r in result)
    rows = fresh.records['temperature']
    count = len(rows)
    # waits for ten states published after the set (a tick may be in flight: one more)
    assert fresh.spin_until(lambda: len(rows) >= count + 11, 10.0)
    temps = [m.temperature for _, m in rows[-10:]]
    assert np.std(temps) > 0.05  # noise of 0.5 K std is now on
    result = fresh.set_params('tca', dynamics__load=PARAMS.dynamics.load,
                              noise__temperature=0.0)
    assert all(r.successful for r in result)


def test_shape_marker_is_a_line_strip_of_the_current_length(fresh):
    assert fresh.spin_until(lambda: fresh.records['shape'], 2.0)  # shape_rate 2 Hz
    marker = fresh.records['shape'][-1][1]
    assert marker.type == Marker.LINE_STRIP and marker.header.frame_id == 'tca_base'
    assert len(marker.points) == 1000
    sim = TcaSimulator(PARAMS, dt=1e-3)
    length = sim.kinetostatics.natural_length + sim.state.elongation
    z = [p.z for p in marker.points]
    assert max(z) - min(z) == pytest.approx(length, rel=1e-3)  # at the loaded equilibrium
