"""The node's table rows built off the executor (tca_ros.ros.node_tables); no ROS needed."""
import os
import pathlib
import threading
import time

import numpy as np
import pytest

from tca_ros.model.conical_table import build_row, cached_conical_model
from tca_ros.params.files import load_params
from tca_ros.ros.node_tables import muscle_temperatures, RowProcess, table_rows, TableRows

CONICAL = pathlib.Path(__file__).resolve().parents[1] / 'config' / 'conical.yaml'


class SlowTable:
    """A lazily built table: rows every 10 K from 5 degC, each built once, on request."""

    temp0, temp_step, n_temp = 5.0, 10.0, 26

    def __init__(self, gate=None):
        self.built = []
        self.begun = []  # rows whose build began off the main thread
        self.threads = set()
        self._gate = gate  # an Event each build off the main thread waits for

    def row(self, i):
        if i not in self.built:
            if self._gate is not None and threading.current_thread() is not \
                    threading.main_thread():
                self.begun.append(i)
                assert self._gate.wait(10.0)
            self.built.append(i)
            self.threads.add(threading.current_thread().name)
        return i


def _wait(predicate, timeout=10.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not predicate():
        time.sleep(0.01)
    return predicate()


def test_start_builds_the_rows_near_the_temperature_before_returning():
    table = SlowTable()
    rows = TableRows(table)
    rows.start([25.0])  # row 2 (25 degC) and 3 used, one row of margin each side
    try:
        assert table.built[:4] == [1, 2, 3, 4]
        assert rows.missing([25.0, 28.0]) is None
    finally:
        rows.stop()


def test_a_row_far_away_is_missing_until_the_worker_built_it():
    gate = threading.Event()
    table = SlowTable(gate)  # the worker's builds wait for the gate
    rows = TableRows(table)
    rows.start([25.0])
    try:
        assert rows.missing([150.0]) == 135.0  # rows 13-16: the first absent is 135 degC
        gate.set()
        assert _wait(lambda: rows.missing([150.0]) is None)
        assert 'tca_table_rows' in table.threads  # built on the worker, not here
        assert _wait(lambda: rows.complete)  # then the rest of the table
        assert sorted(table.built) == list(range(SlowTable.n_temp))
    finally:
        rows.stop()


def test_the_worker_builds_nearest_the_wanted_row_first():
    gate = threading.Event()
    table = SlowTable(gate)
    rows = TableRows(table)
    rows.start([25.0])
    try:
        assert _wait(lambda: table.begun == [0])  # the worker began row 0, nearest row 1
        assert rows.missing([200.0]) == 185.0  # rows 18-21 used there; 18 wanted first
        gate.set()
        assert _wait(lambda: len(table.built) >= 8)
        # start rows 1-4, the row the worker had begun (0, nearest row 1), then 18 and
        # its neighbours nearest first, above first on a tie
        assert table.built[:8] == [1, 2, 3, 4, 0, 18, 19, 17], table.built
    finally:
        rows.stop()


def test_a_helix_has_no_rows_to_build(free_stroke):
    rows = table_rows(free_stroke)
    rows.start([25.0])
    assert rows.complete and rows.missing([200.0]) is None


def test_a_failed_row_leaves_the_physics_to_report_it():
    class Broken(SlowTable):
        def row(self, i):
            if i > 4:
                raise RuntimeError('no branch\nmore')
            return super().row(i)
    rows = TableRows(Broken())
    rows.start([25.0])
    assert _wait(lambda: rows.error is not None)
    assert rows.error == 'RuntimeError: no branch'
    assert rows.missing([150.0]) is None  # the step then builds it and fails in one line


def test_muscle_temperatures_of_a_tca_and_of_the_pair(free_stroke):
    from dataclasses import replace
    from tca_ros.model.rigs import make_rig
    sim = make_rig(replace(free_stroke, model='cst'), dt=1e-3)
    sim.reset()
    assert muscle_temperatures(sim) == [pytest.approx(25.0)] * 2
    pair = make_rig(replace(load_params('free_stroke'), model='cst',
                            rig=replace(free_stroke.rig, mode='antagonistic')), dt=1e-3)
    pair.reset()
    assert len(muscle_temperatures(pair)) == 4


def test_a_conical_row_is_solved_in_a_child_process_as_it_would_be_here(
        tmp_path, monkeypatch):
    """RowProcess: the rod solves of a row run out of the node's process, same result."""
    params = load_params(CONICAL)
    monkeypatch.setenv('TCA_ROS_CACHE', str(tmp_path / 'child'))
    child = RowProcess(params)
    try:
        row = child.build(3)
        pid = child._proc.pid
        assert pid != os.getpid() and child._proc.poll() is None
    finally:
        child.close()
    assert child._proc.poll() is not None  # close() ended it
    assert list((tmp_path / 'child').glob('conical_*_003.npz'))  # it wrote the cache
    monkeypatch.setenv('TCA_ROS_CACHE', str(tmp_path / 'here'))
    here = build_row(params, row.temperature,
                     cached_conical_model(params).table.natural_drop)
    for name, value in here.__dict__.items():
        assert np.array_equal(getattr(row, name), value), name


def test_the_worker_takes_rows_from_the_builder_and_ends_it_when_complete():
    class Builder:
        closed = False

        def build(self, i):
            return ('row', i)

        def close(self):
            Builder.closed = True

    class Table(SlowTable):
        def __init__(self):
            super().__init__()
            self.inserted = {}

        def cached_row(self, i):
            return self.inserted.get(i)

        def insert(self, i, row):
            self.inserted[i] = row

    table = Table()
    rows = TableRows(table, Builder)
    rows.start([25.0])  # rows 1-4 here, the other 22 from the builder
    assert _wait(lambda: rows.complete)
    assert sorted(table.inserted) == [i for i in range(26) if i not in (1, 2, 3, 4)]
    assert table.inserted[20] == ('row', 20)
    assert _wait(lambda: Builder.closed)
