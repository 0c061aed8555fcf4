"""Effects one record hides: a softening the gain absorbs on one load, lags below the floor."""
from types import SimpleNamespace

import numpy as np
import pytest

from tca_ros.diagnosis import diagnose
from tca_ros.diagnosis.detectability import detectability_note, lag_detection_limit
from tca_ros.params.files import dump_params, load_params
from tca_ros.synthetic.descriptions import describe
from tca_ros.synthetic.realistic import realistic_case, truth_path


def _exact(tmp_path, seed, hidden):
    """Return (record path, exact description path) of the bench's realistic case ``seed``."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    record, start = realistic_case(seed, hidden, str(tmp_path))
    truth = load_params(truth_path(str(tmp_path), seed))
    description = str(tmp_path / 'exact.yaml')
    dump_params(describe(truth, load_params(start), 'exact', np.random.default_rng(seed)),
                description)
    return record, description


@pytest.mark.slow
def test_a_softening_the_gain_hides_on_one_load_is_named_with_the_load_that_separates(tmp_path):
    # Confusion benchmark muscle 9111: a rod plant at 5 Hz with a drifting sensor, one
    # load, its modulus softening 7.2 MPa/K. Calibrated from an exact description the
    # gain moves -1.4 spreads (no finding) and the nominal model leaves 43 um predictable
    # against an 83 um floor: adequate, nothing searched. Calibrated jointly, the
    # softening predicts the held-out part decisively better: named, and a step at
    # another load is the experiment that tells it from the gain.
    record, description = _exact(tmp_path / 'soft', 9111, ['modulus_softening'])
    soft = diagnose(record, description, progress=False)
    assert soft.effects == ['modulus_softening'] and soft.verdict == 'explained', soft.notes
    assert soft.extended_values['effects.extra_softening'] > 1e6
    assert any(n.startswith('next experiment for modulus_softening') and 'x the load '
               'separates them' in n for n in soft.notes), soft.notes
    # the same muscle and record conditions without the softening: nothing named
    record, description = _exact(tmp_path / 'null', 9111, [])
    null = diagnose(record, description, progress=False)
    assert null.effects == [] and null.verdict == 'adequate', null.notes
    assert not any('modulus_softening' in n for n in null.notes), null.notes


def _lag_case(floor, slope_amplitude, rate=10.0):
    """Return (problems, sims, stats, whole stats) of one sine-like prediction and a floor."""
    time_s = np.arange(0.0, 100.0, 1.0 / rate)
    x = slope_amplitude / (2 * np.pi * 0.05) * np.sin(2 * np.pi * 0.05 * time_s)
    problem = SimpleNamespace(record=SimpleNamespace(time=time_s), sample_rate=rate,
                              full_heldout_index=np.arange(time_s.size // 2, time_s.size))
    sim = SimpleNamespace(displacement=x)
    stats = {'displacement': SimpleNamespace(structure=SimpleNamespace(floor=floor))}
    return [problem], [sim], stats, stats


def test_the_shortest_visible_lag_is_the_floor_over_the_rms_rate_of_change():
    # x = A sin(w t) has rate A w cos(w t), of RMS A w / sqrt 2 over whole periods: a lag
    # tau leaves about tau times that, visible only above the structure floor
    problems, sims, stats, whole = _lag_case(floor=50e-6, slope_amplitude=1e-3)
    tau, channel, floor = lag_detection_limit(problems, sims, stats, whole)
    assert channel == 'displacement' and floor == 50e-6
    assert tau == pytest.approx(50e-6 / (1e-3 / np.sqrt(2)), rel=0.02)
    # a floor twice as high hides lags twice as long
    assert lag_detection_limit(*_lag_case(100e-6, 1e-3))[0] == pytest.approx(2 * tau, rel=1e-6)
    note, = detectability_note(problems, sims, stats, whole, [])
    assert note.startswith(f'a lag shorter than {tau:.2g} s')
    # a lag named: nothing to say about what the record cannot see
    assert detectability_note(problems, sims, stats, whole, ['sensor_lag']) == []


def test_the_heldout_rms_without_the_drift_ignores_a_sensor_drift_from_the_record_zero():
    # a residual that is a sensor's drift from the record's zero (the verdict's nuisance)
    # plus a step the inputs made: detrended, the step's RMS is left, the drift's is not
    from tca_ros.diagnosis.verdict import pooled_heldout_rmse
    time_s = np.arange(0.0, 200.0, 0.5)
    step = np.where((time_s > 175.0) & (time_s < 185.0), 30e-6, 0.0)
    drift = 400e-6 * time_s / time_s[-1]
    runs = [(200, 260), (340, 400)]
    problem = SimpleNamespace(record=SimpleNamespace(time=time_s, displacement=drift + step),
                              sample_rate=2.0, full_runs=runs,
                              full_heldout_index=np.concatenate([np.arange(a, b)
                                                                 for a, b in runs]))
    sim = SimpleNamespace(displacement=np.zeros_like(time_s))
    raw = pooled_heldout_rmse([problem], [sim], ['displacement'])['displacement']
    kept = pooled_heldout_rmse([problem], [sim], ['displacement'], detrend=True)['displacement']
    held = np.concatenate([(drift + step)[a:b] for a, b in runs])
    assert raw == pytest.approx(np.sqrt(np.mean(held ** 2)))
    assert kept < 0.2 * raw
    # without the drift the step stays (less what a drift line through it takes)
    problem.record.displacement = step
    alone = pooled_heldout_rmse([problem], [sim], ['displacement'], detrend=True)
    assert alone['displacement'] > 0.5 * np.sqrt(np.mean(step[problem.full_heldout_index] ** 2))


def _bench_exact(tmp_path, seed, hidden):
    """Return (record path, description path) as bench_diagnosis_confusion.py writes them."""
    from tca_ros.synthetic.descriptions import TIGHTNESS
    tmp_path.mkdir(parents=True, exist_ok=True)
    record, start = realistic_case(seed, hidden, str(tmp_path))
    truth = load_params(truth_path(str(tmp_path), seed))
    description = str(tmp_path / 'exact.yaml')
    dump_params(describe(truth, load_params(start), 'exact',
                         np.random.default_rng([seed, TIGHTNESS.index('exact')])), description)
    return record, description, truth


@pytest.mark.slow
def test_a_softening_the_screen_cannot_see_is_calibrated_jointly_when_structure_is_left(tmp_path):
    # Seed 9122 of the confusion benchmark with four muscles per effect: a cst plant at
    # 2 Hz, no thermometer, one load, a softening of 8.9 MPa/K. The calibrated gain took
    # it up (-1.3 spreads) and the nominal model leaves structure; the search screens a
    # softening added on that gain (81 % worse) and finds nothing that helps:
    # 'unexplained'. On one load the joint stage calibrates the softening with the
    # nominal parameters as well (G55), and it explains the record.
    record, description, truth = _bench_exact(tmp_path / 'soft', 9122, ['modulus_softening'])
    soft = diagnose(record, description, progress=False)
    assert soft.effects == ['modulus_softening'] and soft.verdict == 'explained', soft.notes
    assert soft.extended_values['effects.extra_softening'] == pytest.approx(
        truth.effects.extra_softening, rel=0.5)
    # the same muscle and record conditions without it: no softening named
    record, description, _ = _bench_exact(tmp_path / 'null', 9122, [])
    null = diagnose(record, description, progress=False)
    assert 'modulus_softening' not in null.effects, null.notes


def test_a_reading_that_grows_with_the_stroke_is_not_named_a_softening_on_one_load(tmp_path):
    # Seed 9149 of the four-per-effect benchmark: one load, 20 Hz, a displacement sensor
    # reading 8 /m x^2 high (outside the catalogue). Calibrated jointly, a softening
    # predicts the held-out part decisively better (penalised gain 55.8), but the
    # calibrated gain moved up (+1.0 spreads), where a softening moves it down: a coil
    # that softens as it heats stretches under its load and loses stroke (G58). The
    # calibrated nominal model, though within the practical floor, is beaten on the
    # held-out part by a fit no catalogue effect accounts for: unexplained (G97)
    record, description, _ = _bench_exact(tmp_path, 9149, ['sensor_nonlinearity'])
    result = diagnose(record, description, progress=False)
    assert result.effects == [] and result.verdict == 'unexplained', result.notes
    assert any('did not move down as a softening would move it' in n
               for n in result.notes), result.notes
    assert 'predicts the held-out part decisively better' in result.explanation
    assert 'not down by over 1 as a softening moves it' in result.explanation
    assert 'a shift a softening makes the other way' in result.explanation


def test_a_modulus_that_softens_as_it_heats_leaves_less_stroke_under_a_load(tmp_path):
    # the premise of GAIN_DOWN_Z: at the same power and load the softening coil
    # stretches more when hot, so its contraction falls short of the nominal one's (the
    # calibration takes that up with a lower actuation gain)
    from tca_ros.model.simulation import simulate
    _, _, truth = _bench_exact(tmp_path, 9122, ['modulus_softening'])
    time_s = np.arange(0.0, 60.0, 0.1)
    power = np.where(time_s > 5.0, 0.6, 0.0)
    load = np.full_like(time_s, truth.dynamics.load)
    strokes = [simulate(truth.with_values(**{'effects.extra_softening': s}), time_s, power,
                        load, model='cst').displacement[-1] for s in (0.0, 8e6)]
    assert strokes[1] < 0.95 * strokes[0], strokes


@pytest.mark.parametrize('moved, undone, outcome', [
    (-1.4, [], 'named'),  # the gain took it up, nothing against it: a softening (G58)
    (-1.4, [('actuation_gain', 2.6, ('modulus_softening',))], 'unexplained'),
    (+1.3, [], 'unexplained'),  # the gain moved up: what a softening does not do
    (+0.3, [], 'rival'),  # no evidence for a softening, none against it: the gain's rival
    (+0.3, [('actuation_gain', 2.6, ('modulus_softening',))], 'unexplained'),
])
def test_a_decisive_softening_the_records_speak_against_makes_the_verdict_unexplained(
        monkeypatch, moved, undone, outcome):
    # the one-load rule's outcomes for a softening that beats the calibrated nominal
    # model decisively on the held-out part (G58, G97), by the calibrated gain's move
    # and the joint fit's own values; the fits and their scores are stand-ins
    import tca_ros.diagnosis.one_load as one_load
    from tca_ros.diagnosis.joint import JointFit
    fit = JointFit(name='modulus_softening', values={'effects.extra_softening': 7e6},
                   n_params=1, sims=[], criterion=55.8, explained=True, pinned=[],
                   undone=undone)
    candidate = SimpleNamespace(starts=[1.0])
    cal = SimpleNamespace(
        plausibility=lambda: [SimpleNamespace(name='actuation_gain', z=moved)],
        report=SimpleNamespace(values={'actuation_gain': 0.91}))
    monkeypatch.setattr(one_load, 'calibratable', lambda c: {one_load.RIVAL: candidate})
    monkeypatch.setattr(one_load, 'joint_calibrations', lambda *a, **k: [fit])
    monkeypatch.setattr(one_load, 'weigh_finding_effect',
                        lambda *a: SimpleNamespace(fall=113.4))
    monkeypatch.setattr(one_load, 'pooled_heldout_rmse',
                        lambda *a, **k: {'displacement': 30e-6})
    monkeypatch.setattr(one_load, 'lowers_heldout_rms', lambda *a: True)
    monkeypatch.setattr(one_load, 'below_floor', lambda *a: [])
    monkeypatch.setattr(one_load, '_experiment', lambda *a: None)
    problems = [SimpleNamespace(channels=['displacement'])]
    taken, notes, refuted = one_load.softening_on_one_load(None, problems, [], cal, [], {})
    got = 'named' if taken is not None else 'unexplained' if refuted else 'rival'
    assert got == outcome, (notes, refuted)
    if refuted:
        assert refuted.startswith('the calibrated nominal model leaves less than the '
                                  'practical floor, but modulus_softening')
        assert ('a shift a softening makes the other way' in refuted) == bool(undone)
        assert notes[0].endswith('the records speak against a softening, and the verdict '
                                 'says why (decisions G97)'), notes
    # below the decisive margin nothing is said against the nominal model, whatever moved
    fit.criterion = 9.0
    taken, _, refuted = one_load.softening_on_one_load(None, problems, [], cal, [], {})
    assert taken is None and refuted is None
