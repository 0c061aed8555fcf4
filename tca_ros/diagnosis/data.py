"""Measured TCA records: CSV with a ``# key: value`` header, or a rosbag2 (MCAP).

CSV layout (SI units, temperatures in degC)::

    # tca: free_stroke
    # mass_kg: 0.03
    # sample_rate_hz: 100
    time,power,load,displacement,temperature,resistance
    0.00,0.0,0.2943,0.0,25.01,25.0
    ...

``time`` (s), ``power`` (W, electrical), ``load`` (N, tensile) and ``displacement``
(m, contraction from the state at the start of the record, which begins at
ambient) are required; ``temperature`` (degC), ``resistance`` (ohm) and ``force``
(N, tensile, a gauge in series: the isometric and spring rigs, docs/rigs.md) are
optional; ``force`` is read, not yet fitted. A rosbag2 recording of the node's own
topics (``power_cmd``, ``load``, ``displacement``, ``temperature``; any namespace) is
read with ``rosbags`` and resampled onto a uniform grid. Every malformed input
raises ``DataError`` with one line naming the file, the row (1-based line number)
and the column.
"""
from dataclasses import dataclass, field, replace
import math
import os
import re

import numpy as np

from tca_ros.model.params import GRAVITY, SPECS

REQUIRED_COLUMNS = ('time', 'power', 'load', 'displacement')
OPTIONAL_COLUMNS = ('temperature', 'resistance', 'force')
REQUIRED_HEADER = ('tca', 'mass_kg', 'sample_rate_hz')
JITTER_TOLERANCE = 0.01  # relative spread of sample intervals accepted as uniform
RATE_TOLERANCE = 0.05  # relative mismatch allowed between sample_rate_hz and the time column
MIN_SAMPLES = 20  # fewer samples cannot be split into train and held-out parts
MAX_SAMPLES = 1_000_000  # default bound on a record's samples: about 50 MB of arrays
MAX_LINE_BYTES = 4096  # a line of six numbers needs < 200 bytes; longer is not a record
ECHO_CHARS = 40  # characters of a bad value quoted in an error message
# plain ASCII decimal numbers only: float() also takes '1_000' and non-ASCII digits
NUMBER = re.compile(r'[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?', re.ASCII)
NON_FINITE = re.compile(r'[+-]?(?:nan|inf|infinity)', re.ASCII | re.IGNORECASE)
# 'power' is the power the node applied (after clamping, watchdog, V^2/R); preferred over
# the commanded 'power_cmd' when the bag has it
BAG_TOPICS = ('power', 'power_cmd', 'load', 'displacement', 'joint_states', 'temperature')
BAG_TYPES = {'power': 'std_msgs/msg/Float64', 'power_cmd': 'std_msgs/msg/Float64',
             'load': 'std_msgs/msg/Float64', 'displacement': 'std_msgs/msg/Float64',
             'joint_states': 'sensor_msgs/msg/JointState',
             'temperature': 'sensor_msgs/msg/Temperature'}
MAX_POWER_W = 1e3  # power bound: 200x the node's default driver limit (max_power 5 W)
MAX_LOAD_N = SPECS['dynamics.load'].high  # the params schema's dynamics.load range (N)
ABSOLUTE_ZERO_DEGC = -273.15
MIN_MASS_KG = 1e-6  # a moving mass below a milligram: 0 (quasi-static) is meant
MAX_MASS_KG = SPECS['dynamics.mass'].high  # the params schema's dynamics.mass range (kg)
MAX_TEMPERATURE_DEGC = 1000.0  # nylon melts near 260 degC: a hotter reading is no TCA's
MAX_DISPLACEMENT_M = 10.0  # |x| bound: about 100 times a TCA's length
MAX_RESISTANCE_OHM = 1e6  # a heater wire reads ohms to kilohms; beyond this it is open
# allowed values (low, high, unit): power is dissipated (>= 0), load is tensile. A value
# past a physical bound (bench/fuzz_cli.py: a temperature of 1e308) only made the fit's
# residuals non-finite and the diagnosis fail (exit 1) instead of naming the row.
VALUE_RANGES = {'power': (0.0, MAX_POWER_W, 'W'), 'power_cmd': (0.0, MAX_POWER_W, 'W'),
                'load': (0.0, MAX_LOAD_N, 'N'),
                'resistance': (0.0, MAX_RESISTANCE_OHM, 'ohm'),
                # a gauge reads a slack muscle slightly negative: both signs allowed
                'force': (-MAX_LOAD_N, MAX_LOAD_N, 'N'),
                'displacement': (-MAX_DISPLACEMENT_M, MAX_DISPLACEMENT_M, 'm'),
                'temperature': (ABSOLUTE_ZERO_DEGC, MAX_TEMPERATURE_DEGC, 'degC')}
DEFAULT_JOINT = 'tca_joint'  # the node's default joint_name
TIME, DISPLACEMENT = 'time', 'displacement'  # column names quoted in errors


class DataError(ValueError):
    """A measured record is malformed; the message names file, row and column."""


@dataclass
class Record:
    """A measured (or synthetic) record on a uniform time grid.

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times (s), uniform, starting at 0.
    power, load : ndarray, shape (n,)
        Electrical power (W) and tensile load (N), held from each sample to the next.
    displacement : ndarray, shape (n,)
        Measured contraction (m) from the state at the start of the record.
    temperature, resistance : ndarray, shape (n,), or None
        Measured fiber temperature (degC) and resistance (ohm) when recorded.
    force : ndarray, shape (n,), or None
        Measured tension (N) of a gauge in series (isometric or spring rig).
    meta : dict
        Header values: ``tca`` (config name), ``mass_kg`` (kg), ``sample_rate_hz``
        (Hz) and any other ``# key: value`` lines, as strings or floats.
    source : str
        Path the record was read from.
    meta_rows : dict
        Line number (1-based) of each header key in the file, for error messages.
    """

    time: np.ndarray
    power: np.ndarray
    load: np.ndarray
    displacement: np.ndarray
    temperature: np.ndarray = None
    resistance: np.ndarray = None
    meta: dict = field(default_factory=dict)
    source: str = ''
    meta_rows: dict = field(default_factory=dict)  # header key -> line number (1-based)
    force: np.ndarray = None  # N, optional gauge column (after meta: positional callers)

    @property
    def sample_rate(self):
        """Return the sample rate (Hz) of the uniform grid."""
        return 1.0 / float(np.median(np.diff(self.time)))

    @property
    def duration(self):
        """Return the record length (s)."""
        return float(self.time[-1] - self.time[0])

    @property
    def mass(self):
        """Return the moving mass (kg) from the header."""
        return float(self.meta['mass_kg'])


def read_record(path, max_samples=None):
    """Return the Record in ``path``: a CSV file, an MCAP file or a rosbag2 directory.

    ``max_samples`` bounds the samples of the (uniform) record; a record needing
    more is refused before it is built (default: no bound).

    Raises
    ------
    DataError
        One line naming the file, the row and the column of the first problem.
    """
    if not os.path.exists(path):
        raise DataError(f'{path}: no such file or directory')
    if os.path.isdir(path) or path.endswith('.mcap'):
        return read_bag_record(path, max_samples=max_samples)
    return read_csv_record(path, max_samples=max_samples)


def record_config(record):
    """Return the params file a record's ``tca`` header names: a shipped name or a path.

    A header may name a shipped config (``free_stroke``) or a params file in the
    record's own directory (``my_tca.yaml``, or ``my_tca`` for ``my_tca.yaml``),
    never any other path: a record is data, and only the command line may point
    the reader at arbitrary files. Raises DataError naming the header line.
    """
    from tca_ros.model.params import shipped_configs
    name = str(record.meta.get('tca', '')).strip()
    folder = os.path.dirname(os.path.abspath(record.source)) if record.source else None
    plain = name not in ('', '.', '..') and os.path.basename(name) == name and \
        '/' not in name and '\\' not in name and '\0' not in name
    shipped = shipped_configs()
    if plain and name in shipped:
        return name
    if plain and folder:
        for candidate in (name, name + '.yaml'):
            path = os.path.join(folder, candidate)
            if os.path.isfile(path):
                return path
    if plain and os.path.splitext(name)[0] in shipped:
        return os.path.splitext(name)[0]
    row = record.meta_rows.get('tca', 1)
    raise DataError(f'{record.source}: row {row}, column {"tca"!r}: {clip(name)!r} is '
                    f'neither a shipped config ({", ".join(shipped)}) nor a params file '
                    'beside the record; pass --config PATH')


def clip(text, limit=40):
    """Return ``text`` cut to ``limit`` characters (an ellipsis marks the cut)."""
    text = str(text)
    return text if len(text) <= limit else text[:limit] + '...'


def parse_number(text, path, row, column):
    """Return ``text`` as a finite float, or raise DataError naming file, row, column.

    Only plain ASCII decimals (``-1.5e-3``) are numbers: no digit separators, no
    non-ASCII digits, no hex; ``nan`` and ``inf`` are refused as not finite.
    """
    text = text.strip()
    if NON_FINITE.fullmatch(text):
        raise DataError(f'{path}: row {row}, column {column!r}: {text!r} is not finite')
    if not NUMBER.fullmatch(text):
        raise DataError(f'{path}: row {row}, column {column!r}: {clip(text, ECHO_CHARS)!r} '
                        'is not a number (allowed: ASCII decimal, e.g. -1.5e-3)')
    value = float(text)
    if not math.isfinite(value):
        raise DataError(f'{path}: row {row}, column {column!r}: {clip(text, ECHO_CHARS)!r} '
                        'is not finite (beyond +-1.8e308)')
    return value


def read_text_lines(path, max_lines=None, max_line_bytes=MAX_LINE_BYTES):
    """Yield (row, text) of a UTF-8 text file, row 1-based; a leading BOM is dropped.

    Reads one bounded line at a time, so neither a huge line nor a huge file is
    held in memory. Raises DataError naming the row of a line that is not UTF-8,
    longer than ``max_line_bytes``, or beyond ``max_lines``.
    """
    try:
        fh = open(path, 'rb')
    except OSError as exc:
        raise DataError(f'{path}: cannot open ({exc.strerror})') from None
    with fh:
        row = 0
        while True:
            try:
                raw = fh.readline(max_line_bytes + 1)
            except OSError as exc:
                raise DataError(f'{path}: row {row + 1}: cannot read ({exc.strerror})') \
                    from None
            if not raw:
                return
            row += 1
            if len(raw) > max_line_bytes and not raw.endswith(b'\n'):
                raise DataError(f'{path}: row {row}: line longer than {max_line_bytes} bytes '
                                '(a record line holds a few numbers)')
            if max_lines is not None and row > max_lines:
                raise DataError(f'{path}: row {row}: more than {max_lines} lines (limit; '
                                'raise it with --max-samples)')
            if row == 1 and raw.startswith(b'\xef\xbb\xbf'):
                raw = raw[3:]  # UTF-8 byte-order mark, as some spreadsheets write
            try:
                text = raw.decode('utf-8')
            except UnicodeDecodeError as exc:
                raise DataError(f'{path}: row {row}: byte {exc.start + 1} '
                                f'(0x{raw[exc.start]:02x}) is not UTF-8 text') from None
            yield row, text.rstrip('\r\n')


def read_csv_record(path, max_samples=None):
    """Return the Record of a CSV file with a ``# key: value`` header (see module doc).

    ``max_samples`` (default: no bound) bounds the data rows and the samples of
    the uniform grid; a record beyond it is refused before it is built.
    """
    meta, meta_rows, header_row, columns = {}, {}, None, None
    rows = []
    max_lines = None if max_samples is None else max_samples + 1000  # + header lines
    for number, line in read_text_lines(path, max_lines):
        text = line.strip()
        if not text:
            continue
        if columns is None and text.startswith('#'):
            key, sep, value = text[1:].partition(':')
            if sep:
                if key.strip() in meta:
                    raise DataError(f'{path}: row {number}, column {clip(key.strip())!r}: '
                                    f'header key repeated (first on row '
                                    f'{meta_rows[key.strip()]})')
                meta[key.strip()] = value.strip()
                meta_rows[key.strip()] = number
            continue
        if columns is None:
            columns = [c.strip() for c in text.split(',')]
            header_row = number
            _check_columns(columns, path, number)
            continue
        cells = text.split(',')
        if len(cells) != len(columns):
            column = columns[min(len(cells), len(columns) - 1)]
            raise DataError(f'{path}: row {number}, column {column!r}: expected '
                            f'{len(columns)} values, found {len(cells)}')
        rows.append((number, [parse_number(c, path, number, col)
                              for c, col in zip(cells, columns)]))
    if columns is None:
        raise DataError(f'{path}: row 1, column {TIME!r}: no column header line '
                        f'({",".join(REQUIRED_COLUMNS)},...)')
    _check_meta(meta, path, meta_rows)
    if len(rows) < MIN_SAMPLES:
        raise DataError(f'{path}: row {header_row + len(rows)}, column {TIME!r}: '
                        f'{len(rows)} data rows, need at least {MIN_SAMPLES}')
    values = np.array([r[1] for r in rows])
    row_numbers = [r[0] for r in rows]
    data = {c: values[:, i] for i, c in enumerate(columns)}
    _check_values(data, row_numbers, path)
    _check_span(data['time'], float(meta['sample_rate_hz']), row_numbers, path, max_samples)
    record = Record(time=data['time'] - data['time'][0], power=data['power'],
                    load=data['load'], displacement=data['displacement'],
                    temperature=data.get('temperature'), resistance=data.get('resistance'),
                    meta=meta, source=str(path), meta_rows=meta_rows, force=data.get('force'))
    _check_rate(record, path, header_row)
    return uniform_record(record)


def _check_columns(columns, path, row):
    known = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
    for c in columns:
        if c not in known:
            raise DataError(f'{path}: row {row}, column {clip(c)!r}: unknown column (known: '
                            f'{", ".join(known)})')
    if len(set(columns)) != len(columns):
        dup = next(c for c in columns if columns.count(c) > 1)
        raise DataError(f'{path}: row {row}, column {dup!r}: column appears twice')
    for c in REQUIRED_COLUMNS:
        if c not in columns:
            raise DataError(f'{path}: row {row}, column {c!r}: required column missing')


def _check_meta(meta, path, meta_rows):
    for key in REQUIRED_HEADER:
        if key not in meta:
            raise DataError(f'{path}: row 1, column {key!r}: header line "# {key}: ..." '
                            'missing')
    for key in ('mass_kg', 'sample_rate_hz'):
        value = parse_number(meta[key], path, meta_rows[key], key)
        low = 0.0 if key == 'mass_kg' else 1e-9
        if value < low:
            raise DataError(f'{path}: row {meta_rows[key]}, column {key!r}: {value:g} must '
                            f'be >= {low:g}')
        meta[key] = value
    mass = meta['mass_kg']
    if mass != 0.0 and not MIN_MASS_KG <= mass <= MAX_MASS_KG:
        # a subnormal mass passed and the simulation refused it (> 1000 substeps), exit 1
        raise DataError(f"{path}: row {meta_rows['mass_kg']}, column 'mass_kg': {mass:g} kg; "
                        f'allowed 0 (quasi-static) or {MIN_MASS_KG:g} to {MAX_MASS_KG:g} kg')


def _check_span(time, rate, row_numbers, path, max_samples):
    """Refuse times whose differences lose precision or whose grid exceeds the bound."""
    shifted = time - time[0]
    steps = np.diff(shifted)
    bad = np.flatnonzero(~(np.isfinite(steps) & (steps > 0.0)))
    if bad.size:
        i = int(bad[0]) + 1
        raise DataError(f'{path}: row {row_numbers[i]}, column {TIME!r}: {time[i]:g} s is '
                        f'not resolvable after {time[0]:g} s (times must stay within about '
                        '1e15 sample intervals of the first)')
    if max_samples is not None:
        samples = shifted[-1] * rate + 1.0
        if not samples <= max_samples:
            raise DataError(f'{path}: row {row_numbers[-1]}, column {TIME!r}: {time[-1]:g} s '
                            f'spans {shifted[-1]:.4g} s = {samples:.4g} samples at '
                            f'{rate:g} Hz; the limit is {max_samples} (--max-samples)')


def _check_values(data, row_numbers, path):
    time = data['time']
    bad = np.flatnonzero(np.diff(time) <= 0.0)
    if bad.size:
        raise DataError(f'{path}: row {row_numbers[bad[0] + 1]}, column {TIME!r}: '
                        f'{time[bad[0] + 1]:g} s is not after {time[bad[0]]:g} s')
    for column, (low, high, unit) in VALUE_RANGES.items():
        if column in data:
            bad = np.flatnonzero((data[column] < low) | (data[column] > high))
            if bad.size:
                raise DataError(f'{path}: row {row_numbers[bad[0]]}, column {column!r}: '
                                f'{data[column][bad[0]]:g} {unit} is out of range (allowed '
                                f'{low:g} to {high:g} {unit})')


def _check_rate(record, path, row):
    rate = float(record.meta['sample_rate_hz'])
    measured = 1.0 / float(np.median(np.diff(record.time)))
    if abs(measured - rate) > RATE_TOLERANCE * rate:
        raise DataError(f'{path}: row {row + 1}, column {TIME!r}: sample rate {measured:.4g} '
                        f'Hz does not match header sample_rate_hz = {rate:g}')


def uniform_record(record, rate=None):
    """Return ``record`` on a uniform grid at ``rate`` (Hz, default the header rate).

    Inputs (power, load) are held from each sample to the next (zero-order hold,
    as the simulator applies them); outputs are interpolated linearly. A record
    already uniform within JITTER_TOLERANCE is returned unchanged.
    """
    rate = float(rate or record.meta.get('sample_rate_hz') or record.sample_rate)
    steps = np.diff(record.time)
    if np.ptp(steps) <= JITTER_TOLERANCE / rate:
        return record
    grid = np.arange(0.0, record.time[-1] + 0.5 / rate, 1.0 / rate)
    grid = grid[grid <= record.time[-1]]
    hold = np.clip(np.searchsorted(record.time, grid, side='right') - 1, 0, None)

    def interp(y):
        return None if y is None else np.interp(grid, record.time, y)

    return replace(record, time=grid, power=record.power[hold], load=record.load[hold],
                   displacement=interp(record.displacement),
                   temperature=interp(record.temperature),
                   resistance=interp(record.resistance), force=interp(record.force))


def write_csv_record(record, path, comments=()):
    """Write ``record`` as a diagnosis CSV (header lines first, then columns).

    ``comments`` are extra ``# text`` lines placed after the key lines.
    """
    columns = ['time', 'power', 'load', 'displacement']
    arrays = [record.time, record.power, record.load, record.displacement]
    for name in OPTIONAL_COLUMNS:
        value = getattr(record, name)
        if value is not None:
            columns.append(name)
            arrays.append(value)
    formats = {'time': '%.4f', 'power': '%.5f', 'load': '%.5f', 'displacement': '%.4e',
               'temperature': '%.3f', 'resistance': '%.4f', 'force': '%.6f'}
    with open(path, 'w', encoding='utf-8') as fh:
        for key in REQUIRED_HEADER:
            fh.write(f'# {key}: {record.meta[key]}\n')
        for line in comments:
            fh.write(f'# {line}\n')
        fh.write(','.join(columns) + '\n')
        table = np.column_stack(arrays)
        fmt = ','.join(formats[c] for c in columns)
        np.savetxt(fh, table, fmt=fmt)


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
        times = on_clock(samples)
        rel = np.array([s[2] for s in samples]) - before  # held value after each message
        # F(t) = integral of (held - before) up to t: piecewise linear, kinks at messages
        at_messages = np.concatenate(([0.0], np.cumsum(rel[:-1] * np.diff(times))))
        edges = np.append(grid, grid[-1] + 1.0 / rate)
        j = np.searchsorted(times, edges, side='right') - 1
        inside = np.clip(j, 0, None)
        integral = np.where(j >= 0, at_messages[inside] + rel[inside] * (edges - times[inside]),
                            0.0)
        return before + np.diff(integral) * rate

    mass = float(mass_kg) if mass_kg is not None else 0.0
    if load is None and tca:
        from tca_ros.model.params import load_params
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
    meta = {'tca': tca, 'mass_kg': mass, 'sample_rate_hz': rate}
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
    from tca_ros.diagnosis.bag_integrity import BagCorrupt, check_mcap
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
