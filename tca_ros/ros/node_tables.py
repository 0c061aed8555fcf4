"""The rows of a conical rod table, built off the node's executor and out of its process.

The conical TCA's rod table (tca_ros.model.conical_table) builds a temperature row
(10 K) the first time a query needs it, in 1 to 2 s of rod solves (kept on disk for
the next start by tca_ros.params.row_cache). Built inside a physics step, that stops
the node's outputs and services for as long. ``TableRows`` has them built on a worker
thread instead, nearest the muscle's temperature first, until the table is complete; the node asks
``missing(temperatures)`` before each step and holds the physics (outputs and services
go on) while a row it would use is not ready. The worker thread only waits: the rod
solves run in a child process (``RowProcess``, ``python -m tca_ros.ros.node_tables``),
so they take neither the node's interpreter lock nor its CPU time slice (solved in a
thread of the node, they stretched the gaps between its outputs to 50-70 ms on a loaded
machine, docs/node.md). A helical TCA's tables are built whole when the model is made:
nothing to do then. No rclpy here.
"""
import atexit
import math
import os
import pickle
import subprocess
import sys
import threading

from tca_ros.model.conical_table import cached_conical_model

MARGIN_ROWS = 1  # rows beyond those the temperatures use now (~10 K of headroom)
PACKAGE_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


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
    if params.coil.shape != 'conical':
        return TableRows(None)
    return TableRows(cached_conical_model(params).table, lambda: RowProcess(params))


class RowProcess:
    """A child process that solves the rows of one conical TCA's rod table.

    It reads the params, then row indices, from its stdin and answers each with
    ('row', ConicalRow) or ('error', one line), writing the disk cache as
    ``ConicalTable.row`` does. It runs in a session of its own (a terminal's Ctrl-C
    goes to the node, which stops it) and ends when its stdin closes.
    """

    def __init__(self, params):
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            [PACKAGE_ROOT] + [p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep)
                              if p]))
        self._proc = subprocess.Popen(
            [sys.executable, '-m', 'tca_ros.ros.node_tables'], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, env=env, start_new_session=True)
        atexit.register(self.close)
        self._send(params)

    def _send(self, value):
        pickle.dump(value, self._proc.stdin)
        self._proc.stdin.flush()

    def build(self, i):
        """Return ConicalRow i, solved in the child; raise RuntimeError on its failure."""
        try:
            self._send(i)
            kind, value = pickle.load(self._proc.stdout)
        except (OSError, EOFError, pickle.UnpicklingError) as exc:
            raise RuntimeError(f'the row process ended ({type(exc).__name__})') from None
        if kind == 'error':
            raise RuntimeError(value)
        return value

    def close(self):
        """End the child now (a row it is solving is dropped)."""
        if self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait()
        for pipe in (self._proc.stdin, self._proc.stdout):
            pipe.close()


def serve_rows(stdin, stdout):
    """Answer row indices from ``stdin`` until it closes (the child of RowProcess)."""
    import tca_ros.params  # noqa: F401  (installs the disk cache: rows kept for the next start)
    try:
        table = cached_conical_model(pickle.load(stdin)).table
        while True:
            i = pickle.load(stdin)
            try:
                reply = ('row', table.row(i))
            except Exception as exc:  # noqa: B902  the node reports it in one line
                reply = ('error', f'{type(exc).__name__}: {exc}'.splitlines()[0])
            pickle.dump(reply, stdout)
            stdout.flush()
    except (EOFError, OSError, KeyboardInterrupt):
        return  # the node closed the pipes or ended


class TableRows:
    """Build the rows of a lazily built rod table on a worker thread.

    Parameters
    ----------
    table : ConicalTable or None
        The table (its ``temp0`` and ``temp_step`` in degC, ``n_temp`` rows and
        ``row(i)``, which builds row i on first use); None: nothing to build.
    builder : callable or None
        Returns an object whose ``build(i)`` solves row i elsewhere and ``close()``
        ends it (RowProcess); the worker then takes rows from the table's cache
        (``cached_row``) or the builder and hands them to ``insert``. None: the worker
        calls ``table.row(i)`` itself.
    """

    def __init__(self, table, builder=None):
        self._table = table
        self._new_builder = builder
        self._builder = None
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
        self._thread = threading.Thread(target=self._run, name='tca_table_rows', daemon=True)
        self._thread.start()

    def stop(self):
        """Stop the worker (a daemon thread) and end the builder's process."""
        with self._wake:
            self._stopped = True
            self._wake.notify()
            builder, self._builder = self._builder, None
        if builder is not None:
            builder.close()

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
                self.stop()  # the table is complete: its process is no longer needed
                return
            try:
                self._build(i)
            except Exception as exc:  # noqa: B902  the physics reports it when it gets there
                if not self._stopped:
                    self.error = f'{type(exc).__name__}: {exc}'.splitlines()[0]
                return
            self._ready.add(i)

    def _build(self, i):
        """Bring row i into the table: from its cache, the builder's process, or here."""
        if self._new_builder is None:
            self._table.row(i)
            return
        if self._table.cached_row(i) is not None:
            return
        with self._wake:
            if self._stopped:
                raise RuntimeError('stopped')
            if self._builder is None:
                self._builder = self._new_builder()
            builder = self._builder
        self._table.insert(i, builder.build(i))


if __name__ == '__main__':
    answers = os.fdopen(os.dup(sys.stdout.fileno()), 'wb')
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())  # a stray print goes to stderr
    serve_rows(sys.stdin.buffer, answers)
