"""The noise model of the verdict: coloured noise, drift and quantisation are not structure."""
import math

import numpy as np
import pytest

from tca_ros.diagnosis.noise import (
    ar_fit, ar_order, heldout_deviance_gain, quantisation_sigma, quantisation_step,
    structure_test)
from tca_ros.diagnosis.regressors import first_order_lag, input_terms, last_direction, \
    remove_nuisance
from tca_ros.synthetic.realistic import ar1

RATE = 20.0  # Hz
N = 2400  # 120 s


def plant(rng):
    """Return (power W, predicted displacement m, temperature rise K) of a toy TCA."""
    power = np.repeat(rng.choice([0.0, 0.4, 0.8, 1.2], size=N // 100), 100)
    rise = first_order_lag(power, RATE, 4.0) * 80.0
    return power, 1e-4 * rise, rise


def test_quantisation_step_is_found_on_a_lattice_only():
    rng = np.random.default_rng(1)
    x = np.cumsum(rng.standard_normal(500)) * 1e-5
    q = 8.4e-6
    assert quantisation_step(np.round(x / q) * q) == pytest.approx(q, rel=1e-6)
    assert quantisation_sigma(np.round(x / q) * q) == pytest.approx(q / math.sqrt(12.0))
    assert quantisation_step(x) == 0.0


def test_ar_order_and_coefficient_are_recovered():
    rng = np.random.default_rng(2)
    e = ar1(rng, 4000, RATE, 1.0, 2.0)
    assert ar_order(e) >= 1
    phi, _ = ar_fit(e, 1)
    assert phi[0] == pytest.approx(math.exp(-1.0 / (RATE * 2.0)), abs=0.01)
    assert ar_order(rng.standard_normal(4000)) == 0


@pytest.mark.parametrize('seed', range(12))
def test_coloured_noise_drift_and_quantisation_are_not_structure(seed):
    # what a real sensor adds, with no model error at all: the verdict must not see
    # structure (the white-noise RMS test called these 5-32 sigma of "structure")
    rng = np.random.default_rng(100 + seed)
    power, predicted, rise = plant(rng)
    noise = (ar1(rng, N, RATE, 20e-6, 2.0) + 3e-6 * rng.standard_normal(N)
             + rng.uniform(-2e-4, 2e-4) * np.linspace(0.0, 1.0, N))
    residual = np.round(noise / 2e-6) * 2e-6
    terms = input_terms(predicted, rise, power, RATE, 4.0)
    test = structure_test([(residual, terms, RATE)], swing=float(np.ptp(predicted)))
    assert not test.structured, test


def test_a_missing_slow_thermal_mode_is_structure_despite_coloured_noise():
    rng = np.random.default_rng(7)
    power, predicted, rise = plant(rng)
    # 10 % of the response arrives through a 40 s lag the model does not have
    missing = 0.1 * 1e-4 * 80.0 * (first_order_lag(power, RATE, 40.0)
                                   - first_order_lag(power, RATE, 4.0))
    residual = missing + ar1(rng, N, RATE, 20e-6, 2.0) + 3e-6 * rng.standard_normal(N)
    terms = input_terms(predicted, rise, power, RATE, 4.0)
    test = structure_test([(residual, terms, RATE)], swing=float(np.ptp(predicted)))
    assert test.structured, test
    assert test.predictable_rms == pytest.approx(np.std(missing), rel=0.3)


def test_records_are_pooled_each_with_its_own_offset_and_drift():
    rng = np.random.default_rng(9)
    segments = []
    for k in range(3):
        power, predicted, rise = plant(rng)
        noise = ar1(rng, N, RATE, 20e-6, 2.0) + 1e-3 * k + 3e-4 * k * np.linspace(0, 1, N)
        segments.append((noise, input_terms(predicted, rise, power, RATE, 4.0), RATE))
    test = structure_test(segments, swing=0.01)
    assert not test.structured, test
    assert test.n == 3 * N // 10  # block means at 2 Hz


def _penalised(pairs, k=1):
    deviance, n = heldout_deviance_gain(pairs)
    return deviance - k * math.log(n)


def test_remove_nuisance_without_a_start_removes_offset_and_drift_only():
    t = np.linspace(0.0, 1.0, 200)
    wave = np.sin(12.0 * t)
    out = remove_nuisance(3.0 + 2.0 * t + wave, RATE)
    assert abs(out.mean()) < 1e-12
    assert np.allclose(out, remove_nuisance(wave, RATE))


@pytest.mark.parametrize('seed', range(4))
def test_a_candidate_that_moves_offset_and_drift_gains_nothing(seed):
    # the base's held-out residual is coloured noise plus an offset and a drift: a
    # candidate that removes the offset and the drift explains noise, not the record
    rng = np.random.default_rng(seed)
    noise = ar1(rng, N, RATE, 20e-6) + 3e-6 * rng.standard_normal(N)
    t = np.arange(N) / RATE
    base = noise + 0.3e-3 + 0.4e-3 * t / t[-1]
    raw_gain = 1.0 - np.sqrt(np.mean(noise ** 2) / np.mean(base ** 2))
    assert raw_gain > 0.8  # the raw RMS would call it a huge gain
    assert _penalised([[(base, noise, RATE)]]) < 0.0


def test_a_candidate_that_removes_input_driven_structure_gains():
    rng = np.random.default_rng(5)
    power, predicted, rise = plant(rng)
    noise = ar1(rng, N, RATE, 20e-6)
    missing = 0.01 * (predicted - first_order_lag(predicted, RATE, 12.0))  # a slow mode
    assert np.sqrt(np.mean(missing ** 2)) < 2.0 * np.sqrt(np.mean(noise ** 2))
    assert _penalised([[(noise + missing, noise, RATE)]]) > 0.0
    # two records and two channels: the gains add
    other = ar1(rng, N, RATE, 0.1)
    one = _penalised([[(noise + missing, noise, RATE)]])
    both = _penalised([[(noise + missing, noise, RATE), (noise + missing, noise, RATE)],
                       [(other, other, RATE)]])
    assert both > one


def test_an_offset_does_not_hide_the_structure_beside_it():
    # a fading actuation gain: the held-out residual is mostly an offset (noise by
    # assumption), beside an input-driven part well above the sensor noise
    rng = np.random.default_rng(11)
    power, predicted, rise = plant(rng)
    structure = -0.03 * (predicted - predicted.mean())
    residual = 2e-3 + structure + ar1(rng, N, RATE, 20e-6, 2.0)
    terms = input_terms(predicted, rise, power, RATE, 4.0)
    test = structure_test([(residual, terms, RATE)], swing=float(np.ptp(predicted)))
    assert test.structured, test
    assert test.noise_rms < 3.0 * 20e-6  # the offset is not counted as noise
    # the same structure below 0.5 % of the swing is no practical model error
    small = 2e-3 + 0.1 * structure + ar1(rng, N, RATE, 2e-6, 2.0)
    assert not structure_test([(small, terms, RATE)], swing=float(np.ptp(predicted))).structured


def test_a_record_that_starts_at_its_zero_has_a_drift_but_no_offset():
    # a held-out part 160 s into a record zeroed at its start: a sensor drift from that
    # zero is noise; an offset held since the training part (friction holding the end
    # up after cooling) is model error, and a candidate that removes it gains. A drift
    # through the zero can still take part of a late offset (t / t_end runs 0.57-1 over
    # this part), so the gain is partial; with a free offset it was none.
    rng = np.random.default_rng(11)
    power, predicted, rise = plant(rng)
    start = 160.0  # s since the record's zero
    t = start + np.arange(N) / RATE
    drift = 3e-4 * t / t[-1]
    noise = ar1(rng, N, RATE, 20e-6, 2.0) + 3e-6 * rng.standard_normal(N)
    terms = input_terms(predicted, rise, power, RATE, 4.0)
    swing = float(np.ptp(predicted))
    assert not structure_test([(noise + drift, terms, RATE, start)], swing).structured
    base, cand = noise + drift + 1e-3, noise + drift
    anchored, _ = heldout_deviance_gain([[(base, cand, RATE, start)]])
    free, _ = heldout_deviance_gain([[(base, cand, RATE)]])
    assert abs(free) < 1e-6  # the free offset took it all
    assert _penalised([[(base, cand, RATE, start)]]) > 10.0 and anchored > 10.0


def test_the_last_direction_holds_through_a_pause():
    rate = np.array([0.0, 0.0, 1.0, 0.001, 0.0, -2.0, -0.01, 0.0, 3.0])
    assert last_direction(rate).tolist() == [0, 0, 1, 1, 1, -1, -1, -1, 1]
    assert not last_direction(np.zeros(5)).any()


def test_a_play_of_the_stroke_is_structure_the_other_signals_leave_at_the_floor():
    # a 0.1 mm play (friction holding the end: the reading lags the prediction by up to
    # half the band, on the side it came from) under coloured noise: the residual is
    # +-50 um by the direction of the last motion, which no signal linear in the
    # prediction, its rate or the power's lags follows
    rng = np.random.default_rng(30)
    power, predicted, rise = plant(rng)
    held, y = np.empty(N), predicted[0]
    for i, x in enumerate(predicted):
        y = min(max(y, x - 5e-5), x + 5e-5)
        held[i] = y
    residual = (held - predicted) + ar1(rng, N, RATE, 20e-6, 2.0) \
        + 3e-6 * rng.standard_normal(N)
    terms = input_terms(predicted, rise, power, RATE, 4.0)
    test = structure_test([(residual, terms, RATE)], swing=float(np.ptp(predicted)))
    without = structure_test([(residual, terms[:, :-1], RATE)],
                             swing=float(np.ptp(predicted)))
    assert test.structured and not without.structured, (test, without)
    assert test.predictable_rms > without.predictable_rms
