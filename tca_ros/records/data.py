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
optional; a record whose header says ``# rig: isometric`` needs only ``time``,
``power`` and ``force`` (its load is ``# pretension_n:`` in N, or ``pretension_g``,
``pretension_kg``, or else the first force).
A rosbag2 recording of the node's own topics (``power_cmd``, ``load``,
``displacement``, ``temperature``; any namespace) is read by ``read_bag_record``
(data_bag.py) and resampled onto a uniform grid; ``read_record`` picks the reader
by file type. Every malformed input raises
``DataError`` with one line naming the file, the row (1-based line number) and the
column. ``Record``, ``DataError`` and the value bounds are defined in record.py and
importable from here too.
"""
from dataclasses import replace
import math
import os
import re

import numpy as np

from tca_ros.model.params_schema import SPECS
from tca_ros.records.data_bag import read_bag_record
# the bounds marked noqa are not used here: the CLI checks its options against them
from tca_ros.records.record import ABSOLUTE_ZERO_DEGC, MAX_LOAD_N, MAX_POWER_W  # noqa: F401
from tca_ros.records.record import clip, DataError, held_average, MIN_SAMPLES, POWER_LOGGED, \
    power_logged, Record, TIME, VALUE_RANGES
from tca_ros.records.record import MAX_TEMPERATURE_DEGC  # noqa: F401
from tca_ros.records.stamps import sampled_on_clock

REQUIRED_COLUMNS = ('time', 'power', 'load', 'displacement')
OPTIONAL_COLUMNS = ('temperature', 'resistance', 'force')
#: a record with '# rig: isometric' needs only these: the clamp holds the length (the
#: displacement is 0 when absent) and the load is the pretension ('# pretension_n: N',
#: else the first force)
ISOMETRIC_COLUMNS = ('time', 'power', 'force')
REQUIRED_HEADER = ('tca', 'mass_kg', 'sample_rate_hz')
JITTER_TOLERANCE = 0.01  # relative spread of sample intervals accepted as uniform
RATE_TOLERANCE = 0.05  # relative mismatch allowed between sample_rate_hz and the time column
MAX_SAMPLES = 1_000_000  # default bound on a record's samples: about 50 MB of arrays
MAX_LINE_BYTES = 4096  # a line of six numbers needs < 200 bytes; longer is not a record
ECHO_CHARS = 40  # characters of a bad value quoted in an error message
# plain ASCII decimal numbers only: float() also takes '1_000' and non-ASCII digits
NUMBER = re.compile(r'[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?', re.ASCII)
NON_FINITE = re.compile(r'[+-]?(?:nan|inf|infinity)', re.ASCII | re.IGNORECASE)
MIN_MASS_KG = 1e-6  # a moving mass below a milligram: 0 (quasi-static) is meant
MAX_MASS_KG = SPECS['dynamics.mass'].high  # the params schema's dynamics.mass range (kg)


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
    from tca_ros.params.config_search import shipped_configs
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
            _check_columns(columns, path, number, meta.get('rig'))
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
    if 'displacement' not in data:  # an isometric rig: the clamp holds the length
        data['displacement'] = np.zeros_like(data['time'])
    if 'load' not in data:  # the isometric rig's load is its pretension
        data['load'] = np.full_like(data['time'], _pretension(meta, meta_rows, path,
                                                              data['force'][0]))
    record = Record(time=data['time'] - data['time'][0], power=data['power'],
                    load=data['load'], displacement=data['displacement'],
                    temperature=data.get('temperature'), resistance=data.get('resistance'),
                    meta=meta, source=str(path), meta_rows=meta_rows, force=data.get('force'))
    _check_rate(record, path, header_row)
    return uniform_record(record)


#: header keys of an isometric rig's pretension, with their factor to N
PRETENSION_KEYS = (('pretension_n', 1.0), ('pretension', 1.0), ('pretension_kg', 9.81),
                   ('pretension_g', 9.81e-3))


def _pretension(meta, meta_rows, path, first_force):
    """Return an isometric record's pretension (N): its header, else the first force."""
    for key, factor in PRETENSION_KEYS:
        if key in meta:
            return factor * parse_number(str(meta[key]), path, meta_rows.get(key, 1), key)
    return float(first_force)


def _check_columns(columns, path, row, rig=None):
    known = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
    required = ISOMETRIC_COLUMNS if str(rig).strip().lower() == 'isometric' \
        else REQUIRED_COLUMNS
    for c in columns:
        if c not in known:
            raise DataError(f'{path}: row {row}, column {clip(c)!r}: unknown column (known: '
                            f'{", ".join(known)})')
    if len(set(columns)) != len(columns):
        dup = next(c for c in columns if columns.count(c) > 1)
        raise DataError(f'{path}: row {row}, column {dup!r}: column appears twice')
    for c in required:
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
    logged = power_logged(meta)
    if logged not in POWER_LOGGED:
        raise DataError(f"{path}: row {meta_rows['power_logged']}, column 'power_logged': "
                        f"{clip(logged)!r}; allowed {', '.join(POWER_LOGGED)}")
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

    Inputs (power, load) are each sample's value held to the next sample,
    averaged over each grid interval (record.held_average: the simulator holds
    sample k over [t_k, t_k+1)); outputs are interpolated linearly. A record
    already uniform within JITTER_TOLERANCE is returned unchanged. Jittered
    stamps around a steady clock on which the outputs read smoother are
    replaced by the clock's ticks first (stamps.sampled_on_clock; its note is
    added to ``Record.reading``).
    """
    rate = float(rate or record.meta.get('sample_rate_hz') or record.sample_rate)
    steps = np.diff(record.time)
    if np.ptp(steps) <= JITTER_TOLERANCE / rate:
        return record
    ticks, note = sampled_on_clock(record, rate)
    if note:
        record = replace(record, reading=(*record.reading, note))
    if ticks is not None:
        record = replace(record, time=ticks - ticks[0])
        if np.ptp(np.diff(record.time)) <= JITTER_TOLERANCE / rate:
            return record
    grid = np.arange(0.0, record.time[-1] + 0.5 / rate, 1.0 / rate)
    grid = grid[grid <= record.time[-1]]

    def interp(y):
        return None if y is None else np.interp(grid, record.time, y)

    def held(u):  # before the first sample the input is the first sample's
        return held_average(record.time, u, grid, rate, before=float(u[0]))

    return replace(record, time=grid, power=held(record.power), load=held(record.load),
                   displacement=interp(record.displacement),
                   temperature=interp(record.temperature),
                   resistance=interp(record.resistance), force=interp(record.force))


def write_csv_record(record, path, comments=()):
    """Write ``record`` as a diagnosis CSV (header lines first, then columns).

    ``comments`` are extra ``# text`` lines placed after the key lines; the
    record's header entries beyond the required ones follow those (a ``key:``
    line in ``comments`` takes the place of the entry of that key).
    """
    columns = ['time', 'power', 'load', 'displacement']
    arrays = [record.time, record.power, record.load, record.displacement]
    for name in OPTIONAL_COLUMNS:
        value = getattr(record, name)
        if value is not None:
            columns.append(name)
            arrays.append(value)
    # displacement to 10 significant digits: '%.4e' rounded a 50 mm stroke to 0.5 um,
    # coarser than a laser sensor resolves (docs/decisions.md G30: a change of that
    # size moved a real record's calibration)
    formats = {'time': '%.4f', 'power': '%.5f', 'load': '%.5f', 'displacement': '%.9e',
               'temperature': '%.3f', 'resistance': '%.4f', 'force': '%.6f'}
    with open(path, 'w', encoding='utf-8') as fh:
        for key in REQUIRED_HEADER:
            fh.write(f'# {key}: {record.meta[key]}\n')
        # the record's other header entries (its rig, environment, pretension, ...) are
        # conditions of the run: written back, not lost
        given = {str(line).split(':', 1)[0].strip() for line in comments}
        for key, value in record.meta.items():
            if key not in REQUIRED_HEADER and key not in given \
                    and isinstance(value, (str, int, float)) and '\n' not in str(value):
                fh.write(f'# {key}: {value}\n')
        for line in comments:
            fh.write(f'# {line}\n')
        fh.write(','.join(columns) + '\n')
        table = np.column_stack(arrays)
        fmt = ','.join(formats[c] for c in columns)
        np.savetxt(fh, table, fmt=fmt)
