"""Shared fixtures of the tca_ros test suite."""
import numpy as np
import pytest

from tca_ros.params.files import dump_params, load_params


@pytest.fixture(scope='session')
def free_stroke():
    """Return the free-stroke TCA parameters (config/free_stroke.yaml)."""
    return load_params('free_stroke')


@pytest.fixture(scope='session')
def self_coiled():
    """Return the self-coiled TCA parameters (config/self_coiled.yaml)."""
    return load_params('self_coiled')


_ONCE = {}


def once_per_worker(key, compute):
    """Return compute() computed once per test process (xdist worker) for ``key``.

    pytest-xdist tears a module fixture down whenever a worker does not yet know its
    next test, so an expensive module fixture could run several times on one worker
    (seen with --dist loadgroup: the calibration and lockstep fixtures twice each).
    ``make test`` sends each file to one worker (--dist loadfile); this keeps such a
    fixture to one computation even if a file's tests are split.
    """
    if key not in _ONCE:
        _ONCE[key] = compute()
    return _ONCE[key]


def benchmark_case(tmp_path, seed, hidden, masses=()):
    """Return (diagnosis, truth) of a confusion benchmark case, described exactly.

    bench_diagnosis_confusion.py's layout: realistic_case's record of ``seed`` with
    the ``hidden`` effects, or with ``masses`` (kg) realistic_loads' records of that
    muscle at each mass diagnosed together; the description 'exact' drawn as there.
    """
    from tca_ros.diagnosis import diagnose
    from tca_ros.synthetic.descriptions import describe, TIGHTNESS
    from tca_ros.synthetic.realistic import realistic_case, realistic_loads, truth_path
    if masses:
        records, start = realistic_loads(seed, hidden, str(tmp_path), masses)
    else:
        records, start = realistic_case(seed, hidden, str(tmp_path))
    truth = load_params(truth_path(str(tmp_path), seed))
    description = str(tmp_path / 'exact.yaml')
    dump_params(describe(truth, load_params(start), 'exact',
                         np.random.default_rng([seed, TIGHTNESS.index('exact')])), description)
    return diagnose(records, description, progress=False), truth
