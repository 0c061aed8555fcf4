"""The diagnosis' 1 % held-out RMS rule is judged with the sensor's drift removed (G46)."""
from types import SimpleNamespace

import numpy as np

from tca_ros.diagnosis.joint import lowers_heldout_rms
from tca_ros.diagnosis.verdict import drift_free_heldout_score, pooled_heldout_rmse

RATE = 10.0  # Hz
SIGMA = 1e-5  # m


def _problem(measured):
    time = np.arange(measured.size) / RATE
    record = SimpleNamespace(time=time, displacement=measured)
    half = measured.size // 2
    return SimpleNamespace(record=record, full_runs=[(half, measured.size)], sample_rate=RATE,
                           sigma={'displacement': SIGMA}, channels=['displacement'])


def _sim(displacement):
    return SimpleNamespace(displacement=displacement)


def test_a_fitted_drift_is_not_a_gain_but_a_fitted_signal_is():
    rng = np.random.default_rng(3)
    n = 2000
    t = np.arange(n) / RATE
    signal = 1e-3 * np.sin(2.0 * np.pi * t / 40.0)
    drift = 2e-4 * t / t[-1]  # a sensor drift from the record's zero: 20 sigma at the end
    measured = signal + drift + SIGMA * rng.standard_normal(n)
    problem = _problem(measured)
    nominal = _sim(signal)
    reference = pooled_heldout_rmse([problem], [nominal], ['displacement'], detrend=True)
    raw = pooled_heldout_rmse([problem], [nominal], ['displacement'])
    assert raw['displacement'] > 10.0 * reference['displacement']  # the drift dominates
    # an extension that only follows the drift cuts the raw RMS but not the drift-free RMS
    assert not lowers_heldout_rms([problem], [_sim(signal + drift)], reference)
    # an extension that follows a real missed signal is a gain
    missed = 3e-5 * np.sin(2.0 * np.pi * t / 7.0)
    problem = _problem(measured + missed)
    reference = pooled_heldout_rmse([problem], [nominal], ['displacement'], detrend=True)
    assert lowers_heldout_rms([problem], [_sim(signal + missed)], reference)


class _CoarseProblem:
    """The coarse-grid interface drift_free_heldout_score reads (FitProblem's)."""

    channels = ['displacement']
    sigma = {'displacement': SIGMA}

    def __init__(self, starts):
        self.coarse_rates = [RATE] * len(starts)
        self.heldout_starts = list(starts)
        self.heldout_groups = [1] * len(starts)


def test_the_search_score_removes_one_drift_shared_by_a_records_runs():
    rng = np.random.default_rng(5)
    starts, size = [30.0, 90.0], 300
    problem = _CoarseProblem(starts)
    noise = [SIGMA * rng.standard_normal(size) for _ in starts]
    times = [s + (np.arange(size) + 0.5) / RATE for s in starts]
    white = [{'displacement': e} for e in noise]
    drifted = [{'displacement': e + 5e-7 * t} for e, t in zip(noise, times)]
    stepped = [{'displacement': e + (3e-5 if i else 0.0)} for i, e in enumerate(noise)]
    score = drift_free_heldout_score(problem, white)
    assert 0.9 < score < 1.1  # white noise of one sigma
    assert abs(drift_free_heldout_score(problem, drifted) - score) < 0.02
    # a step between the runs is no drift from the record's zero: it stays in the score
    assert drift_free_heldout_score(problem, stepped) > 1.2 * score
    assert drift_free_heldout_score(problem, None) == float('inf')
