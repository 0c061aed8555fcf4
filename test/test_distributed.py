"""Batch work on a local Dask cluster of processes (tca_ros.toolkit.distributed)."""
from dataclasses import replace
import math

import numpy as np
import pytest

from tca_ros.model.simulation import static_displacement
from tca_ros.toolkit import distributed
from tca_ros.toolkit.batch import simulate_batch

TEMPS = np.arange(25.0, 160.1, 5.0)  # degC


def designs(base):
    """Three free-stroke variants: pitch angles 20, 22.42 and 25 deg."""
    return [replace(base, coil=replace(base.coil, pitch_angle=math.radians(a)))
            for a in (20.0, 22.42, 25.0)]


def fail_on_two(x):
    if x == 2:
        raise ValueError('two is refused')
    return x


@pytest.fixture(scope='module')
def client():
    """A local cluster of 2 worker processes: the default of dask_client."""
    with distributed.dask_client(n_workers=2) as c:
        yield c


def test_statics_sweep_equals_the_serial_loop(free_stroke, client, capfd):
    group = designs(free_stroke)
    # rod: one design (its table, built by the serial reference, costs ~1 s per design)
    for model, subset in (('cst', group), ('rod', group[1:2])):
        got = distributed.statics_sweep(subset, 0.2943, TEMPS, model=model, client=client)
        assert '100% Completed' in capfd.readouterr().out  # the progress bar
        for row, p in zip(got, subset):
            want = static_displacement(p, 0.2943, TEMPS, model=model)
            np.testing.assert_allclose(row, want, rtol=0.0, atol=1e-12)  # m
    assert got.shape == (1, TEMPS.size) and np.max(got) > 0.01


def test_chunked_batch_simulation_equals_one_batch(free_stroke, client):
    """Through the scheduler's address: the one-line change to a real cluster."""
    group = [replace(free_stroke, dynamics=replace(free_stroke.dynamics, load=f))
             for f in (0.1, 0.2, 0.3, 0.4, 0.5)]
    time = np.arange(0.0, 1.0001, 0.01)
    power = np.where(time < 0.5, 1.5, 0.0)
    got = distributed.simulate_batch_distributed(
        group, time, power, model='cst', chunk=2, scheduler=client.scheduler.address,
        progress=False)
    want = simulate_batch(group, time, power, model='cst')
    for key in ('displacement', 'temperature', 'resistance', 'tension'):
        np.testing.assert_array_equal(got[key], want[key])


def test_a_failing_item_names_its_index(client):
    with pytest.raises(RuntimeError, match='item 2: ValueError: two is refused'):
        distributed.run_many(fail_on_two, range(4), client=client, progress=False)
