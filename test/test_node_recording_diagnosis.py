"""A recording of the node itself, made the way a ROS user makes one, diagnoses as nominal.

tca_node runs the free-stroke config (cst model, no effect, sensor noise) on its own
clock in lockstep; a recorder node in this process answers every tick with the power
of a fixed profile, publishes a load step half-way, and writes what it receives
(joint_states, temperature, power_cmd, load) into an MCAP file with the receive
times, as `ros2 bag record` would. The diagnosis reads the bag (header stamps for
the stamped topics, the config's load before the first load message), calibrates,
and must name no effect: the recording holds none.
"""
import time

import numpy as np
import pytest
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64

from conftest import once_per_worker  # noqa: I100
from test_node_harness import CONFIG, Probe, stamp_seconds, start_tca  # noqa: I100

pytestmark = pytest.mark.timeout(400)

RATE = 10.0  # Hz, publish rate (one lockstep tick)
DURATION = 120.0  # s of simulated time
LOAD_STEP = (62.0, 0.3924)  # (s, N): 30 g -> 40 g of tension while the muscle is cool
PROFILE = ((8.0, 0.8), (30.0, 1.5), (52.0, 0.0), (78.0, 1.2), (100.0, 0.0))  # (s, W)


def power_at(t):
    """Return the commanded power (W) of PROFILE at sim time t (s)."""
    p = 0.0
    for start, value in PROFILE:
        if t >= start - 1e-9:
            p = value
    return p


def record_node(log_dir, bag_path):
    """Run the node in lockstep, drive it, write the MCAP; return the joint samples."""
    from rclpy.serialization import serialize_message
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import get_typestore, Stores
    from rclpy.qos import QoSProfile
    probe = Probe()
    rows = {name: [] for name in ('joint_states', 'temperature', 'power_cmd', 'load')}
    state = {'load_sent': False}
    pubs = {name: probe.create_publisher(Float64, name, QoSProfile(depth=10))
            for name in ('power_cmd', 'load')}

    def on_joint(msg):
        rows['joint_states'].append((time.time_ns(), msg))
        t = stamp_seconds(msg.header)
        if not state['load_sent'] and t >= LOAD_STEP[0]:
            load = Float64(data=LOAD_STEP[1])
            pubs['load'].publish(load)
            rows['load'].append((time.time_ns(), load))
            state['load_sent'] = True
        command = Float64(data=power_at(t))
        pubs['power_cmd'].publish(command)
        rows['power_cmd'].append((time.time_ns(), command))

    probe.create_subscription(JointState, 'joint_states', on_joint, 10000)
    probe.create_subscription(Temperature, 'temperature',
                              lambda m: rows['temperature'].append((time.time_ns(), m)),
                              10000)
    tca = start_tca(log_dir, '-p', 'publish_clock:=true',
                    '-p', 'real_time_factor:=0.0', '-p', 'lockstep:=true',
                    '-p', f'publish_rate:={RATE}', '-p', 'command_timeout:=0.0',
                    '-p', 'noise.displacement:=4e-6', '-p', 'noise.temperature:=0.15',
                    '-p', 'noise.seed:=11', '-p', 'shape_rate:=0.0', name='tca_rec')
    try:
        assert probe.spin_until(lambda: all(p.get_subscription_count() > 0
                                            for p in pubs.values()), 30.0), tca.log()
        done = probe.spin_until(
            lambda: rows['joint_states']
            and stamp_seconds(rows['joint_states'][-1][1].header) >= DURATION, 300.0)
        assert done, tca.log()
    finally:
        code = tca.stop()
        probe.close()
    assert code == 0, tca.log()
    types = {'joint_states': 'sensor_msgs/msg/JointState',
             'temperature': 'sensor_msgs/msg/Temperature',
             'power_cmd': 'std_msgs/msg/Float64', 'load': 'std_msgs/msg/Float64'}
    with Writer(bag_path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        store = get_typestore(Stores.ROS2_JAZZY)
        conns = {name: writer.add_connection(f'/{name}', kind, typestore=store)
                 for name, kind in types.items()}
        merged = sorted((ns, name, msg) for name, items in rows.items() for ns, msg in items)
        for ns, name, msg in merged:
            writer.write(conns[name], ns, serialize_message(msg))
    return rows['joint_states']


@pytest.fixture(scope='module')
def recording(tmp_path_factory):
    def compute():
        work = tmp_path_factory.mktemp('recording')
        bag = work / 'bag'
        return bag, record_node(work, bag)
    return once_per_worker('test_node_recording_diagnosis.recording', compute)


def test_the_bag_keeps_the_load_step_and_the_config_load_before_it(recording):
    from tca_ros.params.files import load_params
    from tca_ros.records.data import read_bag_record
    bag, _ = recording
    rec = read_bag_record(str(bag), tca=str(CONFIG), mass_kg=0.03)
    before = rec.time < LOAD_STEP[0] - 1.0
    after = rec.time > LOAD_STEP[0] + 1.0
    np.testing.assert_allclose(rec.load[before], load_params(str(CONFIG)).dynamics.load)
    np.testing.assert_allclose(rec.load[after], LOAD_STEP[1])
    assert rec.sample_rate == pytest.approx(RATE, rel=1e-6)  # the header stamps' rate
    assert rec.duration == pytest.approx(DURATION, abs=2.0 / RATE)


def test_a_recording_of_the_nominal_node_names_no_effect(recording):
    from tca_ros.diagnosis import diagnose
    bag, _ = recording
    # the model the node ran (cst: the rod model's full dynamics made this test take
    # longer than its 400 s timeout on the 2-core machine)
    result = diagnose(str(bag), str(CONFIG), progress=False, model='cst')
    assert result.model == 'cst'
    assert result.effects == [], result.explanation
    assert result.helpful == [], result.explanation
    assert result.verdict == 'adequate', result.explanation
