"""A measured TCA record, its error type and the physical bounds of its values.

``Record`` is what both readers return: ``data.py`` (CSV files, and the choice of
reader by file type) and ``data_bag.py`` (rosbag2 recordings). ``DataError`` is
what they raise: one line naming the file, the row and the column. ``VALUE_RANGES``
holds the allowed range (low, high, unit) of each column, checked by both readers.
Units SI, temperatures in degC.
"""
from dataclasses import dataclass, field

import numpy as np

from tca_ros.model.params_schema import SPECS

MIN_SAMPLES = 20  # fewer samples cannot be split into train and held-out parts
MAX_POWER_W = 1e3  # power bound: 200x the node's default driver limit (max_power 5 W)
MAX_LOAD_N = SPECS['dynamics.load'].high  # the params schema's dynamics.load range (N)
ABSOLUTE_ZERO_DEGC = -273.15
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
TIME, DISPLACEMENT = 'time', 'displacement'  # column names quoted in errors


POWER_LOGGED = ('measured', 'command')  # header power_logged: what the power column is


def power_logged(meta):
    """Return the header ``power_logged`` of a record's ``meta`` (default ``measured``)."""
    return str(meta.get('power_logged', POWER_LOGGED[0])).strip()


def power_is_command(record):
    """Return True when ``record``'s power column is the command, not the power delivered.

    Header ``power_logged: command``: the supply was told the power but it was
    not measured, so the delivered power may wander unlogged (a few %).
    Default ``measured``.
    """
    return power_logged(record.meta) == POWER_LOGGED[1]


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
    reading : tuple of str
        What reading the file decided that the file does not say (which times a
        jittered record's samples were taken at: stamps.py), one sentence each.
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
    reading: tuple = ()  # notes of what reading decided (stamps.sampled_on_clock)

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


def clip(text, limit=40):
    """Return ``text`` cut to ``limit`` characters (an ellipsis marks the cut)."""
    text = str(text)
    return text if len(text) <= limit else text[:limit] + '...'


def held_average(times, values, grid, rate, before=0.0):
    """Return an input (W or N) as its time average over each grid interval [t_k, t_k + 1/rate).

    ``values[i]`` is held from ``times[i]`` (s) to the next time (a command acts
    until the next one); before ``times[0]`` the input is ``before``. A change
    that falls inside an interval acts for the rest of it, so irregular stamps
    shift the energy a record delivers by no more than they shift the stamps,
    where holding the last sample at each grid time would delay a step by up to
    a whole sample. ``grid`` (s) is uniform at ``rate`` (Hz). An interval no
    change falls in keeps the held value exactly.
    """
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    previous = np.concatenate(([float(before)], values[:-1]))
    changes = values != previous  # a sample repeating the held value changes nothing
    times, values = times[changes], values[changes]
    held = np.concatenate(([float(before)], values))
    edges = np.append(grid, grid[-1] + 1.0 / rate)
    j = np.searchsorted(times, edges, side='right')  # held[j] acts at each edge
    out = held[j[:-1]]
    moved = np.flatnonzero(np.searchsorted(times, edges[1:], side='left') > j[:-1])
    if moved.size:  # the intervals a change falls in: the held signal's integral over each
        rel = values - before
        at_times = np.concatenate(([0.0], np.cumsum(rel[:-1] * np.diff(times))))

        def integral(t, k):  # of (held - before) from the first change to t; k changes before t
            return np.where(k > 0, at_times[k - 1] + rel[k - 1] * (t - times[k - 1]), 0.0)

        lo, hi = edges[moved], edges[moved + 1]
        spans = integral(hi, np.searchsorted(times, hi, side='right')) - integral(lo, j[moved])
        out[moved] = before + spans * rate
    return out
