"""The held-out layouts (holdout.py) and the drift the held-out blocks of a record share."""
import numpy as np
import pytest

from tca_ros.diagnosis.holdout import choose_validation, coolings, make_holdout, mask_runs
from tca_ros.diagnosis.noise import heldout_deviance_gain, structure_test
from tca_ros.diagnosis.regressors import input_terms_in_runs
from tca_ros.synthetic.realistic import ar1

RATE = 5.0  # Hz


def test_blocks_hold_out_three_tenths_spread_over_the_record_and_its_end():
    time = np.arange(0.0, 76.0, 0.2)
    h = make_holdout(0.7)
    held = h.heldout_mask(time)
    runs = h.runs(time)
    assert len(runs) == 3
    assert held.mean() == pytest.approx(0.3, abs=0.01)
    assert not held[time < 7.6].any()  # the first block (the initial rest) trains
    assert held[time >= 68.4].all()  # the last block is predicted beyond the training data
    # a one-step record (power 25-55 s) has held-out samples in heating and in cooling
    assert held[(time > 25) & (time < 55)].any() and held[time > 55].any()
    # the same parts on a coarser copy of the record (the calibration's grid)
    coarse = time[::5]
    assert np.array_equal(h.heldout_mask(coarse, 75.8), held[::5])


def test_the_tail_layout_holds_out_the_end_and_bad_layouts_are_named():
    time = np.linspace(0.0, 100.0, 1001)
    held = make_holdout(0.7, 'tail').heldout_mask(time)
    assert not held[time < 69.9].any() and held[time >= 70.0].all()
    with pytest.raises(ValueError, match="validation = 'random'"):
        make_holdout(0.7, 'random')
    with pytest.raises(ValueError, match='train_fraction = 1.5'):
        make_holdout(1.5)


def test_auto_keeps_the_tail_when_its_training_part_has_seen_two_coolings():
    from tca_ros.records.record import Record
    time = np.arange(0.0, 80.0, 0.2)

    def record(power):
        return Record(time=time, power=power, load=np.full(time.size, 0.1),
                      displacement=np.zeros(time.size))
    one_step = np.where((time >= 25.0) & (time < 55.0), 2.0, 0.0)
    # a bench's one-step record: its only cooling starts at 55 s, past the tail's 56 s
    # split by nothing it could train on
    assert coolings(time, one_step, 56.0) == 1
    assert choose_validation([record(one_step)], 0.7) == 'blocks'
    steps = np.where((time % 20.0) < 10.0, 1.5, 0.0)  # four on/off cycles
    assert choose_validation([record(steps)], 0.7) == 'tail'
    # a set takes blocks when one of its records needs them; a layout given is kept
    assert choose_validation([record(steps), record(one_step)], 0.7) == 'blocks'
    assert choose_validation([record(one_step)], 0.7, 'tail') == 'tail'
    with pytest.raises(ValueError, match="validation = 'folds'"):
        choose_validation([record(steps)], 0.7, 'folds')


def test_mask_runs_are_the_contiguous_true_ranges():
    assert mask_runs(np.array([0, 1, 1, 0, 0, 1, 0, 1, 1], bool)) == [(1, 3), (5, 6), (7, 9)]
    assert mask_runs(np.zeros(4, bool)) == []


def _blocks(rng, n_runs=3, size=200, gap=300):
    """Return (starts in s, AR noise per run) of held-out runs of one record."""
    starts = [50.0 + i * (size + gap) / RATE for i in range(n_runs)]
    return starts, [ar1(rng, size, RATE, 2e-5, 1.0) + 3e-6 * rng.standard_normal(size)
                    for _ in range(n_runs)]


def test_a_sensor_drift_through_the_held_out_blocks_of_a_record_is_one_nuisance():
    # one drift from the record's zero runs through all its held-out blocks: removing
    # it is not a gain, and it is no structure
    rng = np.random.default_rng(3)
    starts, noise = _blocks(rng)
    drift = [5e-6 * (t0 + np.arange(e.size) / RATE) for t0, e in zip(starts, noise)]
    base = [e + d for e, d in zip(noise, drift)]
    pairs = [[(b, e, RATE, t0, 'record') for b, e, t0 in zip(base, noise, starts)]]
    gain, n = heldout_deviance_gain(pairs)
    assert n > 0 and abs(gain) < np.log(n)  # below one parameter's penalty


def test_a_level_error_in_one_held_out_block_is_model_error_when_blocks_share_a_drift():
    # friction holding the end up in the cooling block only: the shared drift cannot
    # take it, so a candidate that removes it gains; with a drift of its own per block
    # (no group) the block's drift took most of it
    rng = np.random.default_rng(4)
    starts, noise = _blocks(rng)
    base = [e + (6e-4 if i == 2 else 0.0) for i, e in enumerate(noise)]
    shared, _ = heldout_deviance_gain(
        [[(b, e, RATE, t0, 'record') for b, e, t0 in zip(base, noise, starts)]])
    own, _ = heldout_deviance_gain([[(b, e, RATE, t0) for b, e, t0 in zip(base, noise, starts)]])
    assert shared > 50.0
    assert shared > 3.0 * own


def test_input_terms_of_runs_carry_the_power_history_and_the_same_columns():
    power = np.zeros(1000)
    power[200:500] = 1.0
    predicted = np.cumsum(power) * 1e-5
    runs = [(100, 200), (450, 550), (800, 900)]
    terms = input_terms_in_runs(predicted, predicted * 1e4, power, RATE, 10.0, runs)
    assert [t.shape for t in terms] == [(100, 7)] * 3  # six signals and the last direction
    # the slow power lag is still decaying in the last run, 60 s after the power went off
    assert np.ptp(terms[2][:, 5]) > 0.0
    # a flat block has constant, not dropped, columns: the test still runs on all runs
    residual = [np.random.default_rng(5).standard_normal(100) * 1e-6 for _ in runs]
    segments = [(r, t, RATE, a / RATE, 'x') for r, t, (a, _) in zip(residual, terms, runs)]
    test = structure_test(segments, 1e-2)
    assert not test.structured


@pytest.mark.slow
def test_friction_in_a_one_step_record_of_another_plant_is_named_at_its_size(tmp_path):
    # one heating step and its cooling, logged as a bench logs it (5 Hz, nominal on/off
    # power, AR(1) + white noise, 8.4 um encoder, a drift): a perturbed muscle with 15 mN
    # of Coulomb friction in its load path, simulated by the CST model at 500 Hz and
    # fitted with the rod model. Friction shows first in the cooling (the end held up);
    # the held-out blocks let the calibration see a cooling and judge another
    from tca_ros.diagnosis import diagnose
    from tca_ros.params.files import dump_params
    from tca_ros.records.data import write_csv_record
    from tca_ros.synthetic.realistic import bench_record, realistic_set
    s = realistic_set(15, drift=0.0)
    rng = np.random.default_rng(115)
    truth = s.truth.with_values(**{'effects.friction_force': 0.015})
    record = bench_record(truth, max(r.power.max() for r in s.records), 0.02, rng,
                          duration=80.0, on=(20.0, 50.0), model='cst')
    start = tmp_path / 'start.yaml'
    dump_params(s.start.with_values(model='rod'), str(start))
    record.meta['tca'] = str(start)
    path = tmp_path / 'friction.csv'
    write_csv_record(record, str(path))
    result = diagnose(str(path), str(start), progress=False)
    assert result.model == 'rod' and result.validation == 'blocks'
    assert result.effects == ['friction'] and result.verdict == 'explained'
    assert result.extended_values['effects.friction_force'] == pytest.approx(0.015, rel=0.25)
    assert result.gain_percent > 50.0
