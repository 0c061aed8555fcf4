"""The rows of a conical rod table, built off the node's executor.

The conical TCA's rod table (tca_ros.model.conical_table) builds a temperature row
(10 K) the first time a query needs it, in 1 to 2 s of rod solves (kept on disk for
the next start by tca_ros.params.row_cache). Built inside a physics step, that stops
the node's outputs and services for as long. ``TableRows`` builds them on a worker
thread instead, nearest the muscle's temperature first, until the table is complete;
the node asks ``missing(temperatures)`` before each step and holds the physics
(outputs and services go on) while a row it would use is not ready. A helical TCA's
tables are built whole when the model is made: nothing to do then. No rclpy here.
"""
import math
import sys
import threading

from tca_ros.model.conical_table import cached_conical_model

MARGIN_ROWS = 1  # rows beyond those the temperatures use now (~10 K of headroom)
#: s, Python's thread switch interval while the worker runs (default 5 ms): the executor
#: thread then waits at most this long for the GIL at each of its wake-ups.
SWITCH_INTERVAL = 5e-4


def muscle_temperatures(sim):
    """Return the temperatures (degC) the kinetostatics of ``sim`` reads now.

    The fiber and the actuation temperature (a lagging or hysteretic untwist) of each
    muscle: one for a single TCA, two muscles for the antagonistic pair.
    """
    muscles = [getattr(sim, n) for n in ('agonist', 'antagonist') if hasattr(sim, n)] or [sim]
    return [getattr(m.state, name) for m in muscles
            for name in ('temperature', 'actuation_temperature') if hasattr(m.state, name)]


def table_rows(params):
    """Return the TableRows of a TCA: its conical rod table's, or a no-op for a helix."""
    conical = params.coil.shape == 'conical'
    return TableRows(cached_conical_model(params).table if conical else None)


class TableRows:
    """Build the rows of a lazily built rod table on a worker thread.

    Parameters
    ----------
    table : ConicalTable or None
        The table (its ``temp0`` and ``temp_step`` in degC, ``n_temp`` rows and
        ``row(i)``, which builds row i on first use); None: nothing to build.
    """

    def __init__(self, table):
        self._table = table
        self._ready = set()  # row indices in memory (written by one thread at a time)
        self._around = None  # row index the worker builds around
        self._wake = threading.Condition()
        self._stopped = False
        self._thread = None
        self.error = None  # the worker's exception (one line), if a row failed

    def _index_range(self, temperatures):
        """Return the (first, last) row indices used near ``temperatures`` (degC)."""
        table = self._table
        finite = [t for t in temperatures if math.isfinite(t)]
        if not finite:
            return 0, -1
        lo = (min(finite) - table.temp0) / table.temp_step
        hi = (max(finite) - table.temp0) / table.temp_step
        first = max(int(math.floor(lo)) - MARGIN_ROWS, 0)
        last = min(int(math.floor(hi)) + 1 + MARGIN_ROWS, table.n_temp - 1)
        return first, last

    def missing(self, temperatures):
        """Return the temperature (degC) of a row still being built near these, or None.

        ``temperatures`` (degC) are the muscle's (muscle_temperatures); the worker is
        told to build around them next.
        """
        if self._table is None or self.error is not None:
            return None  # after a worker failure the step builds the row and reports it
        first, last = self._index_range(temperatures)
        absent = [i for i in range(first, last + 1) if i not in self._ready]
        if not absent:
            return None
        with self._wake:
            self._around = absent[0]
            self._wake.notify()
        return self._table.temp0 + absent[0] * self._table.temp_step

    def start(self, temperatures):
        """Build the rows near ``temperatures`` (degC) now, the others on a worker thread.

        Called before the node is ready: its first steps then never wait.
        """
        if self._table is None:
            return
        first, last = self._index_range(temperatures)
        for i in range(first, last + 1):
            self._table.row(i)
            self._ready.add(i)
        self._around = first
        if not self.complete:
            sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL))
        self._thread = threading.Thread(target=self._run, name='tca_table_rows', daemon=True)
        self._thread.start()

    def stop(self):
        """Stop the worker after the row it is building (it is a daemon thread)."""
        with self._wake:
            self._stopped = True
            self._wake.notify()

    @property
    def complete(self):
        """Return True when every row is in memory (or there is no lazy table)."""
        return self._table is None or len(self._ready) == self._table.n_temp

    def _next_row(self):
        """Return the absent row nearest the wanted one (above first on a tie), or None."""
        absent = [i for i in range(self._table.n_temp) if i not in self._ready]
        if not absent:
            return None
        around = self._around or 0
        return min(absent, key=lambda i: (abs(i - around), i < around))

    def _run(self):
        while True:
            with self._wake:
                if self._stopped:
                    return
                i = self._next_row()
            if i is None:
                return
            try:
                self._table.row(i)
            except Exception as exc:  # noqa: B902  the physics reports it when it gets there
                self.error = f'{type(exc).__name__}: {exc}'.splitlines()[0]
                return
            self._ready.add(i)
