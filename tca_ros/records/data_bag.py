"""Read a rosbag2 recording (MCAP or sqlite3) of the node's topics into a Record.

The node's topics (``power`` or ``power_cmd``, ``load``, ``joint_states`` or
``displacement``, ``temperature``; any namespace) are read with ``rosbags`` and
resampled onto a uniform grid: inputs (W, N) as their time average over each
sample interval, outputs (m, degC) interpolated linearly. An MCAP file's
integrity is checked first (bag_integrity.py). Errors are ``DataError`` lines
naming the topic as the column and the message (1-based) as the row. The CSV
reader and the choice between the two are in data.py.
"""
import math

import numpy as np

from tca_ros.model.params_schema import GRAVITY
from tca_ros.records.record import clip, DataError, DISPLACEMENT, held_average, MIN_SAMPLES, \
    Record, TIME, VALUE_RANGES

# 'power' is the power the node applied (after clamping, watchdog, V^2/R); preferred over
# the commanded 'power_cmd' when the bag has it
BAG_TOPICS = ('power', 'power_cmd', 'load', 'displacement', 'joint_states', 'temperature')
BAG_TYPES = {'power': 'std_msgs/msg/Float64', 'power_cmd': 'std_msgs/msg/Float64',
             'load': 'std_msgs/msg/Float64', 'displacement': 'std_msgs/msg/Float64',
             'joint_states': 'sensor_msgs/msg/JointState',
             'temperature': 'sensor_msgs/msg/Temperature'}
DEFAULT_JOINT = 'tca_joint'  # the node's default joint_name


def read_bag_record(path, sample_rate=None, tca='', mass_kg=None, load=None,
                    joint_name=None, max_samples=None):
    """Return the Record of a rosbag2 recording (MCAP or sqlite3) of the node's topics.

    Topics are matched by their last name (``/finger1/joint_states`` counts as
    ``joint_states``). Displacement (m) is the position of ``joint_states``
    (sensor_msgs/JointState: the joint ``joint_name``, default the node's
    ``tca_joint`` or ``<namespace>/tca_joint``, or its only joint) at its header
    stamps, or else the ``displacement`` topic (std_msgs/Float64) at its receive times. Temperature
    (sensor_msgs/Temperature, degC) is taken at its header stamps, on the same
    clock. ``power`` (the power the node applied) or else ``power_cmd`` (W) and
    ``load`` (N; std_msgs/Float64, unstamped) are held from their receive times,
    mapped onto the stamp clock through the displacement messages' receive times;
    before the first message the power is 0 W and the load ``load`` (N), or the
    config ``tca``'s dynamics.load, or ``mass_kg`` times GRAVITY. The grid starts
    at the first displacement sample with the displacement's median rate unless
    ``sample_rate`` (Hz) is given. An MCAP file is checked for integrity first;
    a single ``.mcap`` file is read alone, never its directory's other files.
    Errors name the topic as the column and the message (1-based) as the row.
    """
    try:
        from rosbags.highlevel import AnyReader
    except ImportError:  # pragma: no cover - rosbags is a declared dependency
        raise DataError(f'{path}: reading rosbag2 recordings needs the rosbags package '
                        '(pip install rosbags)') from None
    from pathlib import Path
    bag = Path(path)
    _check_bag_files(bag)
    series = {name: [] for name in BAG_TOPICS}  # (receive ns, header stamp ns or 0, value)
    try:
        with AnyReader([bag]) as reader:
            wanted = [c for c in reader.connections if _topic(c.topic) in BAG_TOPICS]
            for conn in wanted:
                expected = BAG_TYPES[_topic(conn.topic)]
                if conn.msgtype != expected:
                    raise DataError(f'{path}: row 1, column {_topic(conn.topic)!r}: topic '
                                    f'{clip(conn.topic)!r} has type {clip(conn.msgtype)!r}, '
                                    f'expected {expected!r}')
            for conn, stamp, raw in reader.messages(connections=wanted):
                name = _topic(conn.topic)
                msg = reader.deserialize(raw, conn.msgtype)
                row = len(series[name]) + 1
                series[name].append((stamp, _header_stamp(msg),
                                     _bag_value(name, msg, joint_name, path, row)))
    except DataError:
        raise
    except Exception as exc:  # rosbags raises several unrelated types
        first = str(exc).splitlines()[0] if str(exc) else ''
        raise DataError(f'{path}: row 1, column {TIME!r}: not a readable rosbag2 recording '
                        f'({type(exc).__name__}: {clip(first, 80)})') from None
    power_topic = 'power' if series['power'] else 'power_cmd'
    disp_topic = 'joint_states' if series['joint_states'] else DISPLACEMENT
    for name, what in ((power_topic, 'power_cmd (or power)'),
                       (disp_topic, 'joint_states (or displacement)')):
        if not series[name]:
            raise DataError(f'{path}: row 1, column {name!r}: topic {what} not in the '
                            'recording')
    for name, samples in series.items():
        _check_bag_values(name, [s[2] for s in samples], path)
    disp = series[disp_topic]
    receive = np.array([s[0] for s in disp], dtype=np.int64)
    stamped = disp_topic == 'joint_states' and any(s[1] for s in disp)
    clock = np.array([s[1] for s in disp], dtype=np.int64) if stamped else receive
    _check_increasing(clock, disp_topic, 'header stamp' if stamped else 'receive time', path)
    origin = int(clock[0])
    t_x = (clock - origin) * 1e-9
    x = np.array([s[2] for s in disp])
    if t_x.size < 2:
        raise DataError(f'{path}: row {len(disp)}, column {disp_topic!r}: {len(disp)} '
                        f'samples, need at least {MIN_SAMPLES}')
    rate = sample_rate or 1.0 / float(np.median(np.diff(t_x)))
    if not (math.isfinite(rate) and rate > 0.0):
        raise DataError(f'{path}: row {len(disp)}, column {disp_topic!r}: {len(disp)} '
                        f'samples, need at least {MIN_SAMPLES}')
    count = t_x[-1] * rate + 1.0
    if max_samples is not None and not count <= max_samples:
        raise DataError(f'{path}: row {len(disp)}, column {disp_topic!r}: the recording '
                        f'spans {t_x[-1]:.4g} s = {count:.4g} samples at {rate:.4g} Hz; the '
                        f'limit is {max_samples} (--max-samples)')
    if count < MIN_SAMPLES:
        raise DataError(f'{path}: row {len(disp)}, column {disp_topic!r}: {int(count)} '
                        f'samples, need at least {MIN_SAMPLES}')
    grid = np.arange(int(math.floor(count + 1e-9))) / rate
    grid = grid[grid <= t_x[-1] + 0.5 / rate]

    def on_clock(samples):
        """Return the times (s, from the first displacement) of unstamped messages."""
        got = np.array([s[0] for s in samples], dtype=np.int64)
        if not stamped:
            return (got - origin) * 1e-9
        # receive time -> stamp clock, through the displacement messages' receive times
        rel, ref = (got - receive[0]) * 1e-9, (receive - receive[0]) * 1e-9
        out = np.interp(rel, ref, t_x)
        out = np.where(rel < ref[0], t_x[0] + rel - ref[0], out)
        return np.where(rel > ref[-1], t_x[-1] + rel - ref[-1], out)

    def hold(name, before):
        """Return the input over each interval [t_k, t_k+1) of the grid.

        It is the time average of the messages' held values: a command that
        arrives within an interval acts for the rest of it, as the node applies
        it from the physics step it arrives in; the record holds sample k over
        that interval.
        """
        samples = series[name]
        if not samples:
            return np.full_like(grid, before)
        return held_average(on_clock(samples), [s[2] for s in samples], grid, rate, before)

    mass = float(mass_kg) if mass_kg is not None else 0.0
    if load is None and tca:
        from tca_ros.params.files import load_params
        load = load_params(tca).dynamics.load
    initial_load = float(load) if load is not None else mass * GRAVITY
    power = hold(power_topic, 0.0)
    load_series = hold('load', initial_load)
    temp = None
    if series['temperature']:
        samples = series['temperature']
        if stamped and any(s[1] for s in samples):
            t_temp = (np.array([s[1] for s in samples], dtype=np.int64) - origin) * 1e-9
            kind = 'header stamp'
        else:
            t_temp, kind = on_clock(samples), 'receive time'
        _check_increasing(t_temp, 'temperature', kind, path)
        temp = np.interp(grid, t_temp, np.array([s[2] for s in samples]))
    meta = {'tca': tca, 'mass_kg': mass, 'sample_rate_hz': rate,
            # the command alone: what the node delivered is not in the bag
            'power_logged': 'measured' if power_topic == 'power' else 'command'}
    return Record(time=grid, power=power, load=load_series,
                  displacement=np.interp(grid, t_x, x), temperature=temp, meta=meta,
                  source=str(path))


def _topic(name):
    return name.rstrip('/').rsplit('/', 1)[-1]


def _header_stamp(msg):
    """Return the header stamp (int ns) of a stamped message, 0 if it has none.

    A topic whose stamps are all 0 was published unstamped: its receive times count.
    """
    header = getattr(msg, 'header', None)
    if header is None:
        return 0
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


def _bag_value(name, msg, joint_name, path, row):
    """Return the float a message carries: data, temperature or the joint's position."""
    if name == 'temperature':
        return float(msg.temperature)
    if name != 'joint_states':
        return float(msg.data)
    names, position = list(msg.name), list(msg.position)
    wanted = joint_name or DEFAULT_JOINT
    suffixed = [i for i, n in enumerate(names) if joint_name is None
                and n.endswith('/' + DEFAULT_JOINT)]
    if wanted in names:
        index = names.index(wanted)
    elif len(suffixed) == 1:
        index = suffixed[0]  # a namespaced node's default name, e.g. finger1/tca_joint
    elif joint_name is None and len(position) == 1 and len(names) <= 1:
        index = 0  # a lone joint is the muscle, whatever its name
    else:
        raise DataError(f'{path}: row {row}, column {"joint_states"!r}: no joint '
                        f'{clip(wanted)!r} (joints: {clip(", ".join(names))})')
    if index >= len(position):
        raise DataError(f'{path}: row {row}, column {"joint_states"!r}: joint {clip(wanted)!r} '
                        f'has no position ({len(position)} positions for {len(names)} names)')
    return float(position[index])


def _check_bag_values(name, values, path):
    """Refuse non-finite values and values outside VALUE_RANGES."""
    low, high, unit = VALUE_RANGES.get(name, (-math.inf, math.inf, ''))
    for row, value in enumerate(values, start=1):
        if not math.isfinite(value) or not low <= value <= high:
            allowed = f'{low:g} to {high:g} {unit}'.rstrip()
            raise DataError(f'{path}: row {row}, column {name!r}: message value {value!r} '
                            f'is out of range (allowed: {allowed})')


def _check_increasing(times, name, kind, path):
    bad = np.flatnonzero(np.diff(times) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise DataError(f'{path}: row {i + 1}, column {name!r}: {kind} does not increase '
                        f'(message {i + 1} is not after message {i})')


def _check_bag_files(bag):
    """Refuse a bag whose MCAP files are not intact (see bag_integrity)."""
    from tca_ros.records.bag_integrity import BagCorrupt, check_mcap
    files = sorted(bag.glob('*.mcap')) if bag.is_dir() else [bag]
    for file in files:
        if file.suffix != '.mcap':
            continue
        try:
            check_mcap(file)
        except BagCorrupt as exc:
            raise DataError(f'{file}: row 1, column {TIME!r}: not a readable rosbag2 '
                            f'recording (MCAP {exc})') from None
        except OSError as exc:
            raise DataError(f'{file}: cannot read ({exc.strerror})') from None
