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
ambient) are required; ``temperature`` (degC) and ``resistance`` (ohm) are
optional. A rosbag2 recording of the node's own topics (``power_cmd``, ``load``,
``displacement``, ``temperature``; any namespace) is read with ``rosbags`` and
resampled onto a uniform grid. Every malformed input raises ``DataError`` with one
line naming the file, the row (1-based line number) and the column.
"""
from dataclasses import dataclass, field, replace
import math
import os

import numpy as np

from tca_ros.model.params import GRAVITY

REQUIRED_COLUMNS = ('time', 'power', 'load', 'displacement')
OPTIONAL_COLUMNS = ('temperature', 'resistance')
REQUIRED_HEADER = ('tca', 'mass_kg', 'sample_rate_hz')
JITTER_TOLERANCE = 0.01  # relative spread of sample intervals accepted as uniform
RATE_TOLERANCE = 0.05  # relative mismatch allowed between sample_rate_hz and the time column
MIN_SAMPLES = 20  # fewer samples cannot be split into train and held-out parts
# 'power' is the power the node applied (after clamping, watchdog, V^2/R); preferred over
# the commanded 'power_cmd' when the bag has it
BAG_TOPICS = ('power', 'power_cmd', 'load', 'displacement', 'temperature')
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


def read_record(path):
    """Return the Record in ``path``: a CSV file, an MCAP file or a rosbag2 directory.

    Raises
    ------
    DataError
        One line naming the file, the row and the column of the first problem.
    """
    if not os.path.exists(path):
        raise DataError(f'{path}: no such file or directory')
    if os.path.isdir(path) or path.endswith('.mcap'):
        return read_bag_record(path)
    return read_csv_record(path)


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
    """Return ``text`` as a finite float, or raise DataError naming file, row, column."""
    try:
        value = float(text)
    except ValueError:
        raise DataError(f'{path}: row {row}, column {column!r}: {text.strip()!r} is not a '
                        'number') from None
    if not math.isfinite(value):
        raise DataError(f'{path}: row {row}, column {column!r}: {text.strip()!r} is not '
                        'finite')
    return value


def read_csv_record(path):
    """Return the Record of a CSV file with a ``# key: value`` header (see module doc)."""
    try:
        with open(path, encoding='utf-8') as fh:
            lines = fh.read().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f'{path}: cannot read ({exc})') from None
    meta, meta_rows, header_row, columns = {}, {}, None, None
    rows = []
    for number, line in enumerate(lines, start=1):
        text = line.strip()
        if not text:
            continue
        if columns is None and text.startswith('#'):
            key, sep, value = text[1:].partition(':')
            if sep:
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
    record = Record(time=data['time'] - data['time'][0], power=data['power'],
                    load=data['load'], displacement=data['displacement'],
                    temperature=data.get('temperature'), resistance=data.get('resistance'),
                    meta=meta, source=str(path), meta_rows=meta_rows)
    _check_rate(record, path, header_row)
    return uniform_record(record)


def _check_columns(columns, path, row):
    known = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
    for c in columns:
        if c not in known:
            raise DataError(f'{path}: row {row}, column {c!r}: unknown column (known: '
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


def _check_values(data, row_numbers, path):
    time = data['time']
    bad = np.flatnonzero(np.diff(time) <= 0.0)
    if bad.size:
        raise DataError(f'{path}: row {row_numbers[bad[0] + 1]}, column {TIME!r}: '
                        f'{time[bad[0] + 1]:g} s is not after {time[bad[0]]:g} s')
    for column, low in (('power', 0.0), ('load', 0.0), ('resistance', 0.0)):
        if column in data:
            neg = np.flatnonzero(data[column] < low)
            if neg.size:
                raise DataError(f'{path}: row {row_numbers[neg[0]]}, column {column!r}: '
                                f'{data[column][neg[0]]:g} is negative')


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
                   resistance=interp(record.resistance))


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
               'temperature': '%.3f', 'resistance': '%.4f'}
    with open(path, 'w', encoding='utf-8') as fh:
        for key in REQUIRED_HEADER:
            fh.write(f'# {key}: {record.meta[key]}\n')
        for line in comments:
            fh.write(f'# {line}\n')
        fh.write(','.join(columns) + '\n')
        table = np.column_stack(arrays)
        fmt = ','.join(formats[c] for c in columns)
        np.savetxt(fh, table, fmt=fmt)


def read_bag_record(path, sample_rate=None, tca='', mass_kg=None):
    """Return the Record of a rosbag2 recording (MCAP or sqlite3) of the node's topics.

    Topics are matched by their last name (``/finger1/displacement`` counts as
    ``displacement``): ``power_cmd`` and ``load`` (std_msgs/Float64, held until the
    next message), ``displacement`` (std_msgs/Float64, m) and optionally
    ``temperature`` (sensor_msgs/Temperature, degC); the node's ``power`` topic (the
    power it applied) replaces ``power_cmd`` when present. Times are the recording times;
    the grid starts at the first displacement message and has the displacement
    topic's median rate unless ``sample_rate`` (Hz) is given. ``tca`` and
    ``mass_kg`` fill the header a bag lacks (the caller takes them from the config).
    """
    try:
        from rosbags.highlevel import AnyReader
    except ImportError:  # pragma: no cover - rosbags is a declared dependency
        raise DataError(f'{path}: reading rosbag2 recordings needs the rosbags package '
                        '(pip install rosbags)') from None
    from pathlib import Path
    bag = Path(path)
    if bag.is_file():
        bag = bag.parent
    series = {name: ([], []) for name in BAG_TOPICS}
    try:
        with AnyReader([bag]) as reader:
            wanted = [c for c in reader.connections
                      if c.topic.rstrip('/').rsplit('/', 1)[-1] in BAG_TOPICS]
            for conn, stamp, raw in reader.messages(connections=wanted):
                name = conn.topic.rstrip('/').rsplit('/', 1)[-1]
                msg = reader.deserialize(raw, conn.msgtype)
                value = msg.temperature if name == 'temperature' else msg.data
                series[name][0].append(stamp)  # int ns: float s would lose precision
                series[name][1].append(float(value))
    except DataError:
        raise
    except Exception as exc:  # rosbags raises several unrelated types
        raise DataError(f'{path}: row 1, column {TIME!r}: not a readable rosbag2 recording '
                        f'({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ""})'
                        ) from None
    power_topic = 'power' if series['power'][0] else 'power_cmd'
    for name in (power_topic, 'displacement'):
        if not series[name][0]:
            raise DataError(f'{path}: row 1, column {name!r}: topic {name!r} (or power) not '
                            'in the recording')
    origin = series['displacement'][0][0]
    for name in series:
        series[name] = ([(s - origin) * 1e-9 for s in series[name][0]], series[name][1])
    t_x, x = (np.asarray(v) for v in series['displacement'])
    for name, (stamps, values) in series.items():
        bad = [i for i, v in enumerate(values) if not math.isfinite(v)]
        if bad:
            raise DataError(f'{path}: row {bad[0] + 1}, column {name!r}: message value '
                            f'{values[bad[0]]!r} is not finite')
    rate = sample_rate or 1.0 / float(np.median(np.diff(t_x)))
    t0 = t_x[0]
    grid = np.arange(0.0, t_x[-1] - t0 + 0.5 / rate, 1.0 / rate)

    def hold(name, default):
        stamps, values = series[name]
        if not stamps:
            return np.full_like(grid, default if default is not None else 0.0)
        stamps, values = np.asarray(stamps) - t0, np.asarray(values)
        idx = np.searchsorted(stamps, grid, side='right') - 1
        first = values[0] if default is None else default
        return np.where(idx >= 0, values[np.clip(idx, 0, None)], first)

    mass = float(mass_kg) if mass_kg is not None else 0.0
    power = np.clip(hold(power_topic, 0.0), 0.0, None)
    load = hold('load', None if series['load'][0] else mass * GRAVITY)
    disp = np.interp(grid, t_x - t0, x)
    temp = None
    if series['temperature'][0]:
        stamps, values = series['temperature']
        temp = np.interp(grid, np.asarray(stamps) - t0, np.asarray(values))
    meta = {'tca': tca, 'mass_kg': mass, 'sample_rate_hz': rate}
    if grid.size < MIN_SAMPLES:
        raise DataError(f'{path}: row {grid.size}, column {DISPLACEMENT!r}: {grid.size} '
                        f'samples, need at least {MIN_SAMPLES}')
    return Record(time=grid, power=power, load=load, displacement=disp, temperature=temp,
                  meta=meta, source=str(path))
