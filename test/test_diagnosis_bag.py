"""rosbag2 (MCAP) records: header stamps, inputs before their first message, integrity."""
import numpy as np
import pytest

from tca_ros.model.params_schema import GRAVITY
from tca_ros.params.files import load_params
from tca_ros.records.data import DataError, read_bag_record, read_record

RATE = 20.0  # Hz, the joint_states rate of the bags below
N = 60  # joint_states messages
SIM_T0 = 100 * 10**9  # ns, header stamps: the node's (simulated) clock
WALL_T0 = 1_700_000_000 * 10**9  # ns, receive times: the recorder's clock
LATENCY = (2_000_000, 31_000_000)  # ns, alternating transport delays (2 ms, 31 ms)
LOAD_STEP = (30, 0.49)  # (message index, N): a load published mid-recording
POWER_ON = 20  # joint_states message after which the first power command arrives


def _stamp(store, ns):
    return store.types['builtin_interfaces/msg/Time'](sec=ns // 10**9, nanosec=ns % 10**9)


def write_stamped_bag(path, load_step=True, stamped=True, joints=('tca_joint',)):
    """Write the node's topics: joint_states and temperature stamped, commands not.

    Message i is stamped SIM_T0 + i / RATE and received LATENCY[i % 2] later on the
    recorder's clock, so receive times are jittered by 29 ms and offset by decades.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    T = store.types
    Float64 = T['std_msgs/msg/Float64']

    def receive(i):
        return WALL_T0 + int(i * 1e9 / RATE) + LATENCY[i % 2]

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        kinds = (('power_cmd', 'std_msgs/msg/Float64'), ('load', 'std_msgs/msg/Float64'),
                 ('joint_states', 'sensor_msgs/msg/JointState'),
                 ('temperature', 'sensor_msgs/msg/Temperature'))
        conns = {name: writer.add_connection(f'/tca/{name}', kind, typestore=store)
                 for name, kind in kinds}
        for i in range(N):
            stamp = SIM_T0 + int(i * 1e9 / RATE) if stamped else 0
            header = T['std_msgs/msg/Header'](stamp=_stamp(store, stamp), frame_id='')
            joint = T['sensor_msgs/msg/JointState'](
                header=header, name=list(joints),
                position=np.array([1e-4 * i * (j + 1) for j in range(len(joints))]),
                velocity=np.zeros(len(joints)), effort=np.zeros(len(joints)))
            writer.write(conns['joint_states'], receive(i), store.serialize_cdr(
                joint, 'sensor_msgs/msg/JointState'))
            temp = T['sensor_msgs/msg/Temperature'](header=header, temperature=25.0 + 0.1 * i,
                                                    variance=0.0)
            writer.write(conns['temperature'], receive(i) + 1000, store.serialize_cdr(
                temp, 'sensor_msgs/msg/Temperature'))
            if i == POWER_ON:
                writer.write(conns['power_cmd'], receive(i) + 2000, store.serialize_cdr(
                    Float64(data=0.5), 'std_msgs/msg/Float64'))
            if load_step and i == LOAD_STEP[0]:
                writer.write(conns['load'], receive(i) + 2000, store.serialize_cdr(
                    Float64(data=LOAD_STEP[1]), 'std_msgs/msg/Float64'))


def test_load_step_survives_and_load_before_it_comes_from_the_config(tmp_path):
    bag = tmp_path / 'bag'
    write_stamped_bag(bag)
    rec = read_bag_record(str(bag), tca='free_stroke', mass_kg=0.03)
    config_load = load_params('free_stroke').dynamics.load
    k = LOAD_STEP[0]
    # received 2 us (stamp clock) after joint_states k: it acts over nearly all of the
    # interval [t_k, t_k+1), which sample k holds (the time average of the held value)
    np.testing.assert_allclose(rec.load[:k], config_load)
    np.testing.assert_allclose(rec.load[k + 1:], LOAD_STEP[1])
    assert rec.load[k] == pytest.approx(LOAD_STEP[1], abs=1e-3 * LOAD_STEP[1])
    assert rec.load[k] != LOAD_STEP[1]  # the 2 us before the message hold the config load
    # before the first power command: 0 W, not the command's value
    np.testing.assert_allclose(rec.power[:POWER_ON], 0.0)
    np.testing.assert_allclose(rec.power[POWER_ON + 1:], 0.5)
    assert rec.power[POWER_ON] == pytest.approx(0.5, rel=1e-3)


def test_a_namespaced_joint_is_found_among_others(tmp_path):
    # two muscles merged into one joint_states: finger1's default joint name
    bag = tmp_path / 'bag'
    write_stamped_bag(bag, joints=('finger2/elbow', 'finger1/tca_joint'))
    rec = read_bag_record(str(bag), tca='free_stroke', mass_kg=0.03)
    np.testing.assert_allclose(rec.displacement, 2e-4 * np.arange(N), rtol=0, atol=1e-12)
    with pytest.raises(DataError, match="no joint 'tca_joint'"):
        write_stamped_bag(tmp_path / 'two', joints=('a/tca_joint', 'b/tca_joint'))
        read_bag_record(str(tmp_path / 'two'), tca='free_stroke', mass_kg=0.03)


def test_without_a_config_the_load_before_the_first_message_is_mass_times_g(tmp_path):
    bag = tmp_path / 'bag'
    write_stamped_bag(bag)
    rec = read_bag_record(str(bag), mass_kg=0.05)
    np.testing.assert_allclose(rec.load[:LOAD_STEP[0]], 0.05 * GRAVITY)
    rec = read_bag_record(str(bag), mass_kg=0.05, load=0.1)
    np.testing.assert_allclose(rec.load[:LOAD_STEP[0]], 0.1)


def test_header_stamps_set_the_time_of_displacement_and_temperature(tmp_path):
    bag = tmp_path / 'bag'
    write_stamped_bag(bag)
    rec = read_bag_record(str(bag), tca='free_stroke', mass_kg=0.03)
    # stamps are exactly 1 / RATE apart: the grid falls on them; the receive times,
    # 2 ms / 31 ms late in turn, would give a different rate and interpolated values
    assert rec.sample_rate == pytest.approx(RATE, rel=1e-9)
    assert rec.time.size == N
    np.testing.assert_allclose(rec.displacement, 1e-4 * np.arange(N), rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.temperature, 25.0 + 0.1 * np.arange(N), rtol=0, atol=1e-9)


def test_unstamped_joint_states_fall_back_to_receive_times(tmp_path):
    bag = tmp_path / 'bag'
    write_stamped_bag(bag, stamped=False)
    rec = read_bag_record(str(bag), tca='free_stroke', mass_kg=0.03)
    # receive-time intervals alternate 79 ms and 21 ms: their median is not 1 / RATE
    assert rec.sample_rate != pytest.approx(RATE, rel=0.05)
    assert rec.time.size != N


def _copy_bag_file(tmp_path):
    bag = tmp_path / 'bag'
    write_stamped_bag(bag)
    return next(bag.glob('*.mcap'))


def test_single_mcap_file_is_read_alone_not_its_neighbours(tmp_path):
    good = _copy_bag_file(tmp_path)
    assert read_record(str(good)).time.size == N
    other = good.parent / 'other.mcap'
    other.write_bytes(b'\x89MCAP0\r\n' + b'\0' * 200)
    with pytest.raises(DataError, match='other.mcap'):
        read_record(str(other))


def _log_time_offsets(data):
    """Return the byte offsets of the log_time fields of messages in the first chunk."""
    import struct
    pos = data.index(b'\x06', 8)  # first chunk record (after the 8-byte magic + header)
    while data[pos] != 0x06:
        pos += 9 + struct.unpack_from('<Q', data, pos + 1)[0]
    clen = struct.unpack_from('<I', data, pos + 9 + 28)[0]
    start = pos + 9 + 40 + clen
    end = start + struct.unpack_from('<Q', data, pos + 9 + 32 + clen)[0]
    offsets, p = [], start
    while p < end:
        if data[p] == 0x05:
            offsets.append(p + 9 + 2 + 4)
        p += 9 + struct.unpack_from('<Q', data, p + 1)[0]
    return offsets


@pytest.mark.parametrize('which', [0, 7, -1])
def test_flipped_log_time_is_refused(tmp_path, which):
    good = _copy_bag_file(tmp_path)
    data = bytearray(good.read_bytes())
    offset = _log_time_offsets(bytes(data))[which]
    data[offset + 1] ^= 0x10  # 4096 ns: indistinguishable by value alone
    good.write_bytes(bytes(data))
    with pytest.raises(DataError, match='not a readable rosbag2 recording') as info:
        read_record(str(good))
    assert '\n' not in str(info.value)


def test_out_of_range_message_values_are_refused(tmp_path):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    Float64 = store.types['std_msgs/msg/Float64']
    bag = tmp_path / 'bag'
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        power = writer.add_connection('/power_cmd', 'std_msgs/msg/Float64', typestore=store)
        disp = writer.add_connection('/displacement', 'std_msgs/msg/Float64', typestore=store)
        for i in range(30):
            writer.write(disp, 10**9 + i * 10**8, store.serialize_cdr(
                Float64(data=0.0), 'std_msgs/msg/Float64'))
            writer.write(power, 10**9 + i * 10**8 + 1, store.serialize_cdr(
                Float64(data=-1.0 if i == 4 else 0.5), 'std_msgs/msg/Float64'))
    with pytest.raises(DataError, match=r"row 5, column 'power_cmd': message value -1\.0 "
                                        r'is out of range \(allowed: 0 to 1000 W\)'):
        read_record(str(bag))


def _with_chunk_crcs(data):
    """Return MCAP bytes with each chunk's uncompressed_crc filled in.

    rosbags writes 0 (no CRC); the mcap C++ writer of ``ros2 bag record`` stores
    chunk CRCs by default (McapWriterOptions::noChunkCRC = false).
    """
    import struct
    import zlib
    data = bytearray(data)
    pos = 8
    while pos < len(data) - 8:
        op, length = data[pos], struct.unpack_from('<Q', data, pos + 1)[0]
        if op == 0x06:
            c0 = pos + 9
            clen = struct.unpack_from('<I', data, c0 + 28)[0]
            assert bytes(data[c0 + 32:c0 + 32 + clen]) == b''  # uncompressed chunks
            rlen = struct.unpack_from('<Q', data, c0 + 32 + clen)[0]
            records = bytes(data[c0 + 40 + clen:c0 + 40 + clen + rlen])
            struct.pack_into('<I', data, c0 + 24, zlib.crc32(records))
        pos += 9 + length
    return bytes(data)


def test_with_chunk_crcs_a_flipped_payload_byte_is_refused(tmp_path):
    good = _copy_bag_file(tmp_path)
    intact = _with_chunk_crcs(good.read_bytes())
    good.write_bytes(intact)
    assert read_record(str(good)).time.size == N  # CRCs as stored are accepted
    data = bytearray(intact)
    value = np.float64(1e-4 * 17).tobytes()  # joint_states position of message 17
    offset = bytes(data).index(value)
    data[offset] ^= 0x01  # the lowest mantissa bit: a change of about 2e-19 m
    good.write_bytes(bytes(data))
    with pytest.raises(DataError, match='chunk CRC mismatch'):
        read_record(str(good))
