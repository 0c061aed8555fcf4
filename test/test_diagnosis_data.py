"""Tests of measured-data input: CSV records, rosbag2 (MCAP) records, one-line errors."""
import numpy as np
import pytest

from tca_ros.records.data import DataError, read_bag_record, read_record, Record, \
    uniform_record, write_csv_record

HEADER = '# tca: free_stroke\n# mass_kg: 0.03\n# sample_rate_hz: 10\n'


def _rows(n=30, temperature=True):
    cols = 'time,power,load,displacement' + (',temperature' if temperature else '')
    lines = [cols]
    for i in range(n):
        row = f'{i / 10:.1f},0.5,0.2943,{1e-4 * i:.6f}'
        lines.append(row + (f',{25 + 0.1 * i:.2f}' if temperature else ''))
    return lines


def _drop_column(line, index):
    cells = line.split(',')
    return ','.join(cells[:index] + cells[index + 1:])


def _write(tmp_path, text, name='rec.csv'):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_csv_round_trip(tmp_path):
    t = np.arange(50) / 20.0
    rec = Record(time=t, power=0.5 + 0.1 * np.sin(t), load=np.full_like(t, 0.3),
                 displacement=1e-3 * np.sin(t), temperature=25.0 + t,
                 meta={'tca': 'free_stroke', 'mass_kg': 0.03, 'sample_rate_hz': 20.0})
    path = str(tmp_path / 'rec.csv')
    write_csv_record(rec, path, comments=['synthetic'])
    back = read_record(path)
    np.testing.assert_allclose(back.time, t, atol=1e-4)  # written with 4 decimals
    np.testing.assert_allclose(back.displacement, rec.displacement, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(back.temperature, rec.temperature, atol=1e-3)
    assert back.resistance is None
    assert back.meta['tca'] == 'free_stroke' and back.mass == pytest.approx(0.03)
    assert back.sample_rate == pytest.approx(20.0, rel=1e-6)


def test_csv_round_trip_keeps_a_laser_sensors_resolution(tmp_path):
    # a 50 mm stroke read to 10 nm: the written record keeps every step (the former
    # 5 significant digits rounded it to 0.5 um)
    t = np.arange(400) / 100.0
    x = 0.05 + 1e-8 * np.round(1e6 * np.sin(t))
    rec = Record(time=t, power=np.full_like(t, 1.0), load=np.full_like(t, 0.1),
                 displacement=x, meta={'tca': 'free_stroke', 'mass_kg': 0.01,
                                       'sample_rate_hz': 100.0})
    path = str(tmp_path / 'laser.csv')
    write_csv_record(rec, path)
    back = read_record(path).displacement
    assert np.max(np.abs(back - x)) < 1e-10
    assert np.unique(np.round(np.diff(back) / 1e-8)).size > 50


@pytest.mark.parametrize('mutate, row, column', [
    (lambda h, r: (h.replace('# mass_kg: 0.03\n', ''), r), 1, 'mass_kg'),
    (lambda h, r: (h.replace('0.03', 'heavy'), r), 2, 'mass_kg'),
    (lambda h, r: (h, [r[0].replace('load', 'weight')] + r[1:]), 4, 'weight'),
    (lambda h, r: (h, [_drop_column(x, 2) for x in r]), 4, 'load'),
    (lambda h, r: (h, r[:7] + [r[7].replace('0.5', 'abc', 1)] + r[8:]), 11, 'power'),
    (lambda h, r: (h, r[:6] + [r[6].replace('0.2943', 'nan')] + r[7:]), 10, 'load'),
    (lambda h, r: (h, r[:8] + [r[8].replace('0.7', '0.1', 1)] + r[9:]), 12, 'time'),
    (lambda h, r: (h, r[:5] + [r[5] + ',1.0'] + r[6:]), 9, 'temperature'),
    (lambda h, r: (h, r[:5] + [r[5].replace('0.5', '-0.5', 1)] + r[6:]), 9, 'power'),
    (lambda h, r: (h.replace('sample_rate_hz: 10', 'sample_rate_hz: 50'), r), 5, 'time'),
])
def test_csv_error_names_file_row_and_column(tmp_path, mutate, row, column):
    header, rows = mutate(HEADER, _rows())
    path = _write(tmp_path, header + '\n'.join(rows) + '\n')
    with pytest.raises(DataError) as info:
        read_record(path)
    message = str(info.value)
    assert '\n' not in message
    assert path in message and f'row {row}' in message and repr(column) in message, message


def test_missing_file_and_too_short(tmp_path):
    with pytest.raises(DataError, match='no such file'):
        read_record(str(tmp_path / 'absent.csv'))
    path = _write(tmp_path, HEADER + '\n'.join(_rows(5)) + '\n')
    with pytest.raises(DataError, match='need at least'):
        read_record(path)


def test_jittered_times_are_resampled_to_a_uniform_grid():
    t = np.arange(40) / 10.0 + np.r_[0.0, 0.003 * np.sin(np.arange(1, 40))]
    rec = Record(time=t, power=np.where(t < 2.0, 1.0, 0.0), load=np.full_like(t, 0.3),
                 displacement=t * 1e-3, meta={'sample_rate_hz': 10.0})
    out = uniform_record(rec)
    assert np.ptp(np.diff(out.time)) < 1e-9
    np.testing.assert_allclose(out.displacement, out.time * 1e-3, atol=1e-12)  # linear
    # held from each stamp, averaged over each grid interval: the step stamped at
    # t[20] = 2.0 + 0.003 sin(20) s leaves its interval [2.0, 2.1) s that share of 1 W
    late = t[20] - 2.0
    np.testing.assert_allclose(out.power[20], late / 0.1, rtol=1e-9)
    np.testing.assert_array_equal(out.power[:20], 1.0)
    np.testing.assert_array_equal(out.power[21:], 0.0)


def test_a_step_stamped_late_is_averaged_over_its_interval_not_delayed_a_sample():
    """A command stamped 0.2 periods late keeps 0.8 of its first interval (1 Hz, 1 W)."""
    t = np.arange(30.0)
    t[10] += 0.2  # the step to 1 W was stamped 0.2 s after the grid time it belongs to
    rec = Record(time=t, power=np.where(np.arange(30) >= 10, 1.0, 0.0),
                 load=np.full_like(t, 0.3), displacement=np.zeros(30),
                 meta={'sample_rate_hz': 1.0})
    out = uniform_record(rec)
    np.testing.assert_allclose(out.power[9:12], [0.0, 0.8, 1.0], atol=1e-12)
    # the energy over the record is the held signal's (a zero-order hold on the grid
    # would have delivered the first second at 0 W: 1 J short)
    assert np.sum(out.power) * 1.0 == pytest.approx(np.sum(rec.power) - 0.2, abs=1e-12)


@pytest.mark.parametrize('rate', [20.0, 30.0, 100.0])
def test_a_record_decimated_for_the_calibration_keeps_its_timing(rate):
    """A measured ramp read at 10 Hz is the ramp at the coarse times, for even and odd k."""
    from tca_ros.records.record_ops import decimated
    t = np.arange(0.0, 12.0, 1.0 / rate)
    rec = Record(time=t, power=np.ones_like(t), load=np.full_like(t, 0.3),
                 displacement=1e-3 * t, temperature=25.0 + 2.0 * t,
                 meta={'sample_rate_hz': rate})
    out = decimated(rec, 10.0)
    assert out.sample_rate == pytest.approx(10.0)
    # a window of k samples from k/2 before each coarse sample read 20 Hz 25 ms late:
    # 25 um on this ramp, 50 mK on the temperature
    np.testing.assert_allclose(out.displacement, 1e-3 * out.time, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(out.temperature, 25.0 + 2.0 * out.time, rtol=0.0, atol=1e-9)
    # and it still averages the noise: the white part of a coarse sample falls as 1/sqrt(k)
    noisy = Record(time=t, power=np.ones_like(t), load=np.full_like(t, 0.3),
                   displacement=np.random.default_rng(1).standard_normal(t.size),
                   meta={'sample_rate_hz': rate})
    k = int(round(rate / 10.0))
    assert np.std(decimated(noisy, 10.0).displacement[1:-1]) < 1.3 / np.sqrt(k)


def _write_bag(path, n=60, rate=20.0, namespace='/finger1'):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    Float64 = store.types['std_msgs/msg/Float64']
    Temperature = store.types['sensor_msgs/msg/Temperature']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    t0 = 1_700_000_000_000_000_000
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {name: writer.add_connection(f'{namespace}/{name}', msgtype, typestore=store)
                 for name, msgtype in (('power_cmd', 'std_msgs/msg/Float64'),
                                       ('load', 'std_msgs/msg/Float64'),
                                       ('displacement', 'std_msgs/msg/Float64'),
                                       ('temperature', 'sensor_msgs/msg/Temperature'))}
        writer.write(conns['load'], t0 - 1000, store.serialize_cdr(
            Float64(data=0.2943), 'std_msgs/msg/Float64'))
        for i in range(n):
            stamp = t0 + int(i * 1e9 / rate)
            if i % 20 == 0:
                writer.write(conns['power_cmd'], stamp, store.serialize_cdr(
                    Float64(data=0.5 if i % 40 == 0 else 0.0), 'std_msgs/msg/Float64'))
            writer.write(conns['displacement'], stamp + 10, store.serialize_cdr(
                Float64(data=1e-4 * i), 'std_msgs/msg/Float64'))
            msg = Temperature(header=Header(stamp=Time(sec=stamp // 10**9,
                                                       nanosec=stamp % 10**9), frame_id=''),
                              temperature=25.0 + 0.1 * i, variance=0.0)
            writer.write(conns['temperature'], stamp + 20, store.serialize_cdr(
                msg, 'sensor_msgs/msg/Temperature'))


def test_mcap_bag_of_the_node_topics(tmp_path):
    bag = tmp_path / 'bag'
    _write_bag(bag)
    rec = read_bag_record(str(bag), tca='free_stroke', mass_kg=0.03)
    assert rec.sample_rate == pytest.approx(20.0, rel=1e-6)
    assert rec.time.size == 60
    np.testing.assert_allclose(rec.displacement, 1e-4 * np.arange(60), atol=1e-12)
    np.testing.assert_allclose(rec.load, 0.2943)
    # commands land 10 ns before their tick: 10 ns of the next value in the interval before
    np.testing.assert_allclose(rec.power[:20], 0.5, atol=1e-6)
    np.testing.assert_allclose(rec.power[20:40], 0.0, atol=1e-6)
    np.testing.assert_allclose(rec.temperature, 25.0 + 0.1 * np.arange(60), atol=1e-6)
    mcap = next(bag.glob('*.mcap'))
    assert read_record(str(mcap)).time.size == 60  # a single .mcap file works too


def test_bag_without_displacement_is_a_one_line_error(tmp_path):
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    bag = tmp_path / 'bag'
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection('/power_cmd', 'std_msgs/msg/Float64', typestore=store)
        writer.write(conn, 1, store.serialize_cdr(store.types['std_msgs/msg/Float64'](data=1.0),
                                                  'std_msgs/msg/Float64'))
    with pytest.raises(DataError, match="column 'displacement'"):
        read_record(str(bag))
    garbage = tmp_path / 'junk.mcap'
    garbage.write_bytes(b'not a bag')
    with pytest.raises(DataError, match='not a readable rosbag2'):
        read_record(str(garbage))


def test_shipped_example_recording_is_a_valid_record():
    import pathlib

    import tca_ros
    path = pathlib.Path(tca_ros.__file__).parent / 'data' / 'example_recording.csv'
    rec = read_record(str(path))
    assert rec.meta['tca'] == 'free_stroke'
    assert rec.duration == pytest.approx(240.0) and rec.sample_rate == pytest.approx(20.0)
    assert rec.temperature is not None and rec.resistance is not None


def test_bad_header_value_names_its_own_line(tmp_path):
    path = tmp_path / 'reordered.csv'
    path.write_text('# a comment first\n# sample_rate_hz: 10\n# tca: free_stroke\n'
                    '# mass_kg: heavy\ntime,power,load,displacement\n0,0,0,0\n')
    with pytest.raises(DataError, match=r"row 4, column 'mass_kg': 'heavy' is not a number"):
        read_record(str(path))
