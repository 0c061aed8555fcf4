"""Input profiles of `tca_sim simulate`: a CSV of time, power and load, checked row by row."""
import csv

import numpy as np

from tca_ros.cli.common import InputError
from tca_ros.records.data import clip, MAX_LOAD_N, MAX_POWER_W, parse_number, \
    read_text_lines

# -- input profiles -------------------------------------------------------------------
PROFILE_COLUMNS = ('time', 'power', 'load')  # the dead-weight rig's input columns
# a record's measured columns (docs/records.md): read and checked as numbers, not used
MEASURED_COLUMNS = ('displacement', 'temperature', 'resistance', 'force')


def read_profile(path, max_rows=None):
    """Return (time (s), power (W), load (N) or None) from a CSV with a header row.

    Columns: ``time,power`` and optionally ``load``, each once. Power is
    0..MAX_POWER_W, load 0..MAX_LOAD_N (tensile), times finite and increasing.
    ``max_rows`` bounds the rows read. Raises InputError or DataError naming the
    row (1-based, header = row 1) and column of the first bad value.
    """
    data = read_profile_columns(path, max_rows)
    return data['time'], data['power'], data.get('load')


def read_profile_columns(path, max_rows=None, allowed=PROFILE_COLUMNS):
    """Return {column: array} of a profile CSV whose columns are among ``allowed``.

    ``time`` and ``power`` are required; ``power_2`` (W, the antagonist's power)
    is checked as ``power``. Errors as in read_profile.
    """
    header, data, header_row = None, {}, 0
    for row, line in read_text_lines(path, max_rows):
        if not line.strip() or line.lstrip().startswith('#'):
            continue
        try:
            cells = next(csv.reader([line]))
        except csv.Error as exc:
            raise InputError(f'{path}: row {row}: not CSV ({exc})') from None
        if header is None:
            header, header_row = [h.strip() for h in cells], row
            _check_profile_header(header, path, row, allowed)
            data = {name: [] for name in header}
            continue
        if len(cells) != len(header):
            raise InputError(f'{path}: row {row}: {len(cells)} fields, expected {len(header)}')
        for name, text in zip(header, cells):
            data[name].append(parse_number(text, path, row, name))
            _check_profile_value(name, data[name][-1], path, row)
    if header is None:
        raise InputError(f'{path}: empty file; expected a header row time,power[,load]')
    if len(data['time']) < 2:
        raise InputError(f'{path}: needs at least 2 data rows, found {len(data["time"])}')
    t = np.array(data['time'])
    bad = np.nonzero(np.diff(t) <= 0.0)[0]
    if bad.size:
        i = int(bad[0]) + 1
        raise InputError(f"{path}: row {header_row + i + 1}, column 'time': {t[i]:g} s is "
                         f'not after {t[i - 1]:g} s (time must increase)')
    return {name: np.array(values) for name, values in data.items()
            if name not in MEASURED_COLUMNS}


def _check_profile_header(header, path, row, allowed=PROFILE_COLUMNS):
    names = ','.join(allowed)
    for name in ('time', 'power'):
        if name not in header:
            raise InputError(f"{path}: row {row}: missing column '{name}' "
                             f"(found {clip(','.join(header))}; allowed {names})")
    unknown = [h for h in header if h not in allowed and h not in MEASURED_COLUMNS]
    if unknown:
        raise InputError(f'{path}: row {row}: unknown column {clip(unknown[0])!r} '
                         f'(allowed {names})')
    dup = [h for h in header if header.count(h) > 1]
    if dup:
        raise InputError(f"{path}: row {row}: column '{dup[0]}' appears twice "
                         f'(each of {names} at most once)')


def _check_profile_value(name, value, path, row):
    if name == 'load' and value < 0.0:
        raise InputError(f"{path}: row {row}, column 'load': {value:g} N is compressive; "
                         'allowed >= 0 (tensile)')
    if name in ('power', 'power_2') and not 0.0 <= value <= MAX_POWER_W:
        raise InputError(f'{path}: row {row}, column {name!r}: {value:g} W is out of range; '
                         f'allowed 0 to {MAX_POWER_W:g} W (Joule heating)')
    if name == 'load' and value > MAX_LOAD_N:
        raise InputError(f"{path}: row {row}, column 'load': {value:g} N is out of range; "
                         f'allowed 0 to {MAX_LOAD_N:g} N (dynamics.load range)')


def resample_hold(t_in, values, t_out):
    """Return ``values`` (sampled at t_in) held constant onto t_out (zero-order hold)."""
    idx = np.clip(np.searchsorted(t_in, t_out, side='right') - 1, 0, len(t_in) - 1)
    return np.asarray(values)[idx]
