"""The steppers and the linearisation against their recorded golden outputs.

test/golden/steppers.npz was written by bench/make_golden.py from the code before
the right-hand sides of eqs. (1) and (18) were given one home (model/rhs.py):
every case (the dead weight with each model and with the effects on, each rig
with each model, batch steps, small-signal plants) must give the same numbers.
Tolerance: 1e-12 relative to the largest magnitude of each recorded array (the
refactor was bit for bit when it was made; the margin is for other CPUs).
"""
import importlib.util
import os

import numpy as np
import pytest

HERE = os.path.dirname(__file__)
GOLDEN = os.path.join(HERE, 'golden', 'steppers.npz')
SCRIPT = os.path.join(HERE, '..', 'bench', 'make_golden.py')
RELATIVE = 1e-12  # of each array's largest magnitude

_spec = importlib.util.spec_from_file_location('make_golden', SCRIPT)
make_golden = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make_golden)


@pytest.fixture(scope='module')
def golden():
    with np.load(GOLDEN) as data:
        return {name: data[name] for name in data.files}


def groups():
    return ('dynamics_cases', 'rig_cases', 'batch_cases', 'plant_cases')


@pytest.mark.parametrize('group', groups())
def test_outputs_match_the_golden_record(golden, group):
    cases = getattr(make_golden, group)()
    prefix = cases and next(iter(cases)).split('/')[0]
    recorded = {k for k in golden if k.startswith(prefix + '/')}
    computed = {f'{case}/{column}' for case, columns in cases.items() for column in columns}
    assert computed == recorded  # no case lost or added without a new record
    for case, columns in cases.items():
        for column, values in columns.items():
            name = f'{case}/{column}'
            want = golden[name]
            got = np.asarray(values, dtype=float)
            assert got.shape == want.shape, name
            scale = float(np.max(np.abs(want))) if want.size else 0.0
            np.testing.assert_allclose(got, want, rtol=0.0, atol=RELATIVE * scale,
                                       err_msg=name)


def test_the_record_is_small_and_moves(golden):
    assert os.path.getsize(GOLDEN) < 1_000_000
    # the runs stroke, heat and turn: a record of rest would prove nothing
    assert np.max(golden['dynamics/cst/displacement']) > 1e-3  # m
    assert np.max(golden['dynamics/cst_friction/displacement']) > 1e-3  # m
    assert np.max(golden['rig/antagonistic/rod/angle']) > 0.01  # rad
    assert np.ptp(golden['rig/isometric/cst_effects/force']) > 0.01  # N
    assert np.min(golden['dynamics/cst_creep_lags/displacement']) < -1e-4  # m, creep
