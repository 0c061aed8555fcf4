"""The diagnosis on records the project's generator did not make.

A random muscle (geometry +-30 %, unmeasurable parameters drawn independently),
simulated with the full central-difference dynamics at 500 Hz, logged at 5 Hz as
a bench logs it (nominal on/off power, AR(1) + white noise, encoder
quantisation, no temperature): the diagnosis calibrates the nominal parameters
on the training part first, so a record with no effect in it names none.
"""
import json

import numpy as np
import pytest

from tca_ros.diagnosis import diagnose, format_summary
from tca_ros.diagnosis.verdict import needs_explaining, ONE_LOAD_NOTE
from tca_ros.model.params_schema import GRAVITY
from tca_ros.model.simulation import simulate
from tca_ros.params.files import dump_params
from tca_ros.records.data import write_csv_record
from tca_ros.synthetic.realistic import bench_record, realistic_case, realistic_loads, \
    realistic_set

from conftest import once_per_worker  # noqa: I100


def _null_record(tmp_path, seed):
    s = realistic_set(seed, drift=0.0)
    rng = np.random.default_rng(seed + 100)
    # one longer record with two steps, so the held-out part has a heating of its own
    r = bench_record(s.truth, max(r.power.max() for r in s.records), 0.02, rng,
                     duration=120.0, on=(10.0, 40.0), drift=0.0)
    second = (r.time >= 70.0) & (r.time < 100.0)
    r.power = np.where(second, 0.6 * r.power.max(), r.power)
    start = tmp_path / 'start.yaml'
    dump_params(s.start, str(start))
    path = tmp_path / f'null_{seed}.csv'
    # re-simulate with the two-step profile
    truth = s.truth.with_values(**{'dynamics.mass': 0.02, 'dynamics.load': 0.02 * GRAVITY})
    sim = simulate(truth, r.time, r.power, r.load, model='cst', physics_rate=500.0)
    noise = 20e-6 * rng.standard_normal(r.time.size)
    r.displacement = np.round((sim.displacement + noise) / 8.4e-6) * 8.4e-6
    r.meta['tca'] = str(start)
    write_csv_record(r, str(path))
    return str(path), str(start)


@pytest.mark.slow
def test_null_record_of_a_perturbed_muscle_names_no_effect(tmp_path):
    path, start = _null_record(tmp_path, 11)
    result = diagnose(path, start, progress=False, model='cst',
                      report_dir=str(tmp_path / 'rep'))
    print(format_summary(result))
    assert result.calibration is not None
    assert result.calibration.derived()['thermal_time_constant'].determined
    assert result.effects == []
    doc = json.loads((tmp_path / 'rep' / 'diagnosis.json').read_text())
    assert doc['effects'] == [] and doc['model'] == 'cst'
    assert doc['calibrated']['thermal_time_constant']['determined'] is True


@pytest.mark.slow
def test_without_calibration_the_same_record_blames_effects(tmp_path):
    # the control: against the uncalibrated start, the perturbed muscle looks like effects
    path, start = _null_record(tmp_path, 11)
    result = diagnose(path, start, progress=False, model='cst', calibrate_first=False)
    print(format_summary(result))
    assert result.effects or result.helpful or result.verdict == 'unexplained'


# Records as bench_diagnosis_real.py makes them (realistic_case): a random muscle, the
# rod model as the plant and cst in the fits, AR(1) + white noise, 2 um quantisation,
# a drift, power logged as the nominal command (the plant got +-3 % slow variation),
# 160 s at 5 Hz or 2 Hz, no temperature. The diagnosis calibrates first.
REALISTIC = dict(duration=160.0, plant='rod', temperature=False, nominal_power=True,
                 drift=True)


def test_realistic_null_record_names_nothing(tmp_path):
    path, start = realistic_case(31, [], str(tmp_path), rate=5.0, **REALISTIC)
    result = diagnose(path, start, progress=False)
    print(format_summary(result))
    assert result.effects == [] and result.helpful == []
    # the cst fit of this rod plant leaves about 65 um (1 % of the stroke) that the inputs
    # predict: the verdict may say so (unexplained), but never that an effect explains it
    assert result.verdict in ('adequate', 'unexplained'), result.explanation


@pytest.fixture(scope='module')
def friction_case(tmp_path_factory):
    """Return the DiagnosisResult of a realistic record with friction hidden in it.

    The plant's kinetostatics is the fit's (cst) and the power column is what the
    plant got: with the nominal command logged instead (REALISTIC's
    nominal_power), the plant's +-3 % unlogged power variation leaves 652 um that
    the inputs predict even for the true model and its true parameters (measured
    on this seed), so no diagnosis could call that record explained.
    """
    def compute():
        directory = str(tmp_path_factory.mktemp('friction'))
        options = dict(REALISTIC, plant='cst', nominal_power=False)
        path, start = realistic_case(33, ['friction'], directory, rate=5.0, **options)
        return diagnose(path, start, progress=False)
    return once_per_worker('test_diagnosis_real.friction_case', compute)


def test_realistic_hidden_friction_is_found_first_at_its_magnitude(friction_case):
    result = friction_case
    print(format_summary(result))
    first = result.rounds[0].scores[0]
    assert first.name == 'friction'
    # drawn at 0.0388 N in the plant (realistic_case, seed 33): the search's first round,
    # beside its narrow refit of the nominal parameters, finds it at its magnitude
    assert first.values['effects.friction_force'] == pytest.approx(0.0388, rel=0.1)
    assert result.gain_percent > 80.0


def test_realistic_hidden_friction_is_named(friction_case):
    # seed 33 has jittered stamps, read on the steady clock they scatter around (z = 3.1,
    # decisions G81): friction leaves nothing the inputs predict on the held-out part
    # (F-test p = 0.0014) and is named without the whole-record confirmation it needed
    # when steps were held a sample late (G56; the confirmation is tested on seed 9123
    # in test_diagnosis_findings.py)
    result = friction_case
    assert result.effects == ['friction'], result.explanation
    assert result.verdict == 'explained'
    # jointly calibrated on the training part the force trades against the gain and
    # the damping: 0.030 N for 0.0388 N
    assert result.extended_values['effects.friction_force'] == pytest.approx(0.0388, rel=0.3)


def test_realistic_fatigue_outside_the_catalogue_is_unexplained(tmp_path):
    path, start = realistic_case(35, ['fatigue'], str(tmp_path), rate=2.0, **REALISTIC)
    result = diagnose(path, start, progress=False)
    print(format_summary(result))
    assert result.effects == [], result.explanation
    assert result.verdict == 'unexplained', result.explanation


def test_several_records_of_one_muscle_are_diagnosed_together(tmp_path, capsys):
    # three step records of one random muscle (1-3 powers), one calibration, no effect
    from tca_ros.cli.main import main
    s = realistic_set(41, drift=0.0)
    start = tmp_path / 'start.yaml'
    dump_params(s.start, str(start))
    paths = []
    for i, r in enumerate(s.records):
        r.meta['tca'] = 'start.yaml'  # a params file next to the record
        paths.append(str(tmp_path / f'step_{i}.csv'))
        write_csv_record(r, paths[-1])
    code = main(['diagnose', *paths, '--quiet', '--report', str(tmp_path / 'rep')])
    out = capsys.readouterr().out
    assert code == 0, out
    assert 'with 2 more record(s) of the same muscle' in out
    doc = json.loads((tmp_path / 'rep' / 'diagnosis.json').read_text())
    assert doc['records'] == paths
    assert doc['calibrated']['thermal_time_constant']['determined'] is True
    assert doc['effects'] == [], out


@pytest.mark.slow
def test_a_calibration_the_model_cannot_run_falls_back_to_the_description(
        tmp_path, monkeypatch):
    # a real record (salp 2 W, encoder_2) calibrated on its training part alone gave a
    # nominal model whose held-out part went beyond the rod table's 260 degC: the whole
    # diagnosis failed with exit 1. Now it says so in a note and goes on uncalibrated.
    from tca_ros.diagnosis import identification
    path, start = realistic_case(31, [], str(tmp_path), rate=1.0,
                                 **dict(REALISTIC, duration=100.0))
    real = identification.calibrate_training_part

    def overheating(records, params_of, *args):
        cal, _, note = real(records, params_of, *args)
        hot = [p.with_values(**{'thermal.convection_coefficient':
                                p.thermal.convection_coefficient / 50.0}) for p in params_of]
        return cal, hot, note

    monkeypatch.setattr(identification, 'calibrate_training_part', overheating)
    result = diagnose(path, start, progress=False)
    assert result.calibration is None
    # a heat loss 50x too small: the thread breaks (cst) or melts (rod) on the way
    assert any(n.startswith('calibration not used: its nominal model cannot simulate')
               for n in result.notes), result.notes
    assert result.verdict in ('adequate', 'unexplained', 'explained')


def test_an_extension_worse_than_the_calibrated_nominal_is_not_kept(tmp_path, monkeypatch):
    # each effect is accepted against its round's base (the nominal with its
    # calibration refitted), which can be worse on the held-out part than the calibrated
    # nominal itself (the real 3 W records together: an ambient offset at its bound,
    # held-out RMSE 7.14 -> 9.86 mm, listed as helpful). The whole extension must beat
    # the calibrated nominal; here a search that returns a 15 K ambient offset on a
    # record without one is made to run, and its result is not kept.
    from tca_ros.diagnosis import extension, identification
    path, start = realistic_case(31, [], str(tmp_path), rate=1.0,
                                 **dict(REALISTIC, duration=100.0))

    def bad_search(problem, candidates):
        values = dict(problem.base_values)
        values['effects.ambient_offset'] = 15.0
        return ['ambient_offset'], values, []

    monkeypatch.setattr(extension, 'search_effects', bad_search)
    for module in (extension, identification):
        monkeypatch.setattr(module, 'needs_explaining', lambda *stats: ['displacement'])
    result = diagnose(path, start, progress=False)
    assert result.effects == [] and result.helpful == []
    assert any('ambient_offset fitted, but not kept' in n for n in result.notes), result.notes
    assert result.extended_rmse == result.nominal_rmse


def test_an_extension_must_also_gain_held_out_rms_over_the_nominal(tmp_path, monkeypatch):
    # the penalised deviance (AR-prewhitened, drift removed) can favour a candidate that
    # leaves a larger but smoother held-out residual (the real 2 W group: a sensor lag
    # at 4.45 -> 4.82 mm was listed as helpful); as in the search, the held-out RMS
    # must fall by MIN_GAIN_PERCENT too
    from tca_ros.diagnosis import extension, identification, joint
    path, start = realistic_case(31, [], str(tmp_path), rate=1.0,
                                 **dict(REALISTIC, duration=100.0))

    def bad_search(problem, candidates):
        return ['ambient_offset'], dict(problem.base_values,
                                        **{'effects.ambient_offset': 15.0}), []

    monkeypatch.setattr(extension, 'search_effects', bad_search)
    for module in (extension, identification):
        monkeypatch.setattr(module, 'needs_explaining', lambda *stats: ['displacement'])
    monkeypatch.setattr(joint, 'heldout_gain_over', lambda *args: 100.0)
    result = diagnose(path, start, progress=False)
    assert result.effects == [] and result.helpful == []
    assert any('held-out RMS gain below 1 %' in n for n in result.notes), result.notes


@pytest.mark.slow
def test_a_hidden_friction_is_fitted_at_its_force_without_spoiling_the_temperature(tmp_path):
    # seed 9044 of bench_diagnosis_real: a cst plant, 20 Hz, temperature logged with 0.2 K
    # noise, 20 um AR(1) displacement noise, noisy power. Before the fit scales and the
    # refitted damping (docs/decisions.md G12, G13) friction came out at 13.1 mN (truth
    # 15.1 mN; 7.3 mN with the fit scales alone) and the extended model's held-out
    # temperature error at 1.43 K (nominal 0.24 K).
    from tca_ros.params.files import load_params
    from tca_ros.synthetic.realistic import truth_path
    path, start = realistic_case(9044, ['friction'], str(tmp_path))
    truth = load_params(truth_path(str(tmp_path), 9044)).effects.friction_force
    result = diagnose(path, start, progress=False)
    print(format_summary(result))
    # named alone: before the search stopped at an unstructured residual, an ambient
    # offset of -0.17 K followed it (the logged power's noise, clipped at zero)
    assert result.effects == ['friction'], result.explanation
    assert result.verdict == 'explained'
    assert result.extended_values['effects.friction_force'] == pytest.approx(truth, rel=0.1)
    assert result.extended_rmse['temperature'] < 1.1 * result.nominal_rmse['temperature']
    assert result.gain_percent > 80.0


@pytest.mark.slow
def test_a_second_thermal_lag_the_calibration_took_as_damping_is_fitted_at_its_time(tmp_path):
    # seed 1040 of bench_diagnosis.py: calibrate-first takes the 3.8 s lag up as a damping
    # of 20.5 N s/m; before the hand-over (docs/decisions.md G13, G14) the refit raised
    # that to 61.6 N s/m and the second lag was fitted at 0.39 s
    from tca_ros.synthetic.generator import make_synthetic_record
    synth = make_synthetic_record(1040, effects=['second_thermal_lag'], n_effects=1,
                                  duration=240.0, sample_rate=100.0)
    path = str(tmp_path / 'record_1040.csv')
    write_csv_record(synth.record, path)
    result = diagnose(path, 'free_stroke', model='cst', progress=False)
    print(format_summary(result))
    truth = synth.values['effects.second_thermal_lag']
    assert 'second_thermal_lag' in result.effects + result.helpful, result.explanation
    assert result.extended_values['effects.second_thermal_lag'] == pytest.approx(truth,
                                                                                 rel=0.15)
    assert result.extended_values['dynamics.damping'] < 5.0


@pytest.mark.slow
def test_a_creep_the_calibration_took_as_softness_is_found_by_a_joint_calibration(tmp_path):
    # seed 9014 of bench_diagnosis_real: a cst plant, 20 Hz, no temperature, AR(1) noise,
    # drift and quantisation; creep of 8.96 mm/N over 50.5 s. With start-centred priors
    # (x/÷ 2 on the stiffness) calibrate-first took the creep up as a coil seven times too
    # soft (stiffness scale 0.14) and only a joint calibration found it; with the physical
    # prior (x/÷ 1.5) the stiffness stays plausible and the search names creep itself.
    from tca_ros.params.files import load_params
    from tca_ros.synthetic.realistic import truth_path
    path, start = realistic_case(9014, ['creep'], str(tmp_path))
    truth = load_params(truth_path(str(tmp_path), 9014)).effects
    result = diagnose(path, start, progress=False)
    print(format_summary(result))
    assert result.verdict == 'explained' and result.effects == ['creep'], result.explanation
    assert result.calibration.report.values['stiffness_scale'] > 1.0 / 3.0
    values = result.extended_values
    assert values['effects.creep_compliance'] == pytest.approx(truth.creep_compliance,
                                                               rel=0.1)
    assert values['effects.creep_time_constant'] == pytest.approx(
        truth.creep_time_constant, rel=0.2)
    assert result.channel_gain('displacement') > 50.0


@pytest.mark.slow
def test_two_effects_no_single_one_explains_are_found_by_a_joint_pair(tmp_path, monkeypatch):
    # seed 9200 of the realistic generator with its plant on the rod model (the fits run
    # cst), 100 Hz, coloured noise and quantisation, a drawn muscle: an ambient offset of
    # 5.2 K and a second thermal lag of 1.33 s. Each effect calibrated jointly alone helps
    # but leaves structure; the pair, calibrated jointly, explains it (docs/diagnosis_method.md).
    # Without the pair stage the same record is not explained.
    from tca_ros.diagnosis import joint
    from tca_ros.params.files import load_params
    from tca_ros.synthetic.realistic import truth_path
    hidden = ['ambient_offset', 'second_thermal_lag']
    path, start = realistic_case(9200, hidden, str(tmp_path), plant='rod')
    truth = load_params(truth_path(str(tmp_path), 9200)).effects
    result = diagnose(path, start, progress=False)
    print(format_summary(result))
    assert result.verdict == 'explained', result.explanation
    assert sorted(result.effects) == sorted(hidden)
    assert any('"Joint calibration": pairs' in n for n in result.notes), result.notes
    values = result.extended_values
    assert values['effects.ambient_offset'] == pytest.approx(truth.ambient_offset, rel=0.25)
    assert values['effects.second_thermal_lag'] == pytest.approx(truth.second_thermal_lag,
                                                                 rel=0.25)
    monkeypatch.setattr(joint, 'pair_order', lambda *args: [])
    single = diagnose(path, start, progress=False)
    assert single.verdict != 'explained' or sorted(single.effects) != sorted(hidden)


@pytest.mark.slow
def test_a_sensor_nonlinearity_one_load_hides_is_exposed_by_two_loads_together(tmp_path):
    # seed 9059 of the realistic generator (rod plant, the fits run cst, 20 Hz, noisy
    # power, a warm start): the displacement is read through x + 8 x^2, 0.8 mm extra at
    # 10 mm. On one load, the calibration absorbs it (the stroke is a static function of
    # the temperature and the steady rise and gain rescale it: docs/diagnosis_method.md):
    # no structure is left, only a stiffness moved beyond the description's stated
    # uncertainty that no catalogue effect explains (a finding: unexplained, nothing
    # named). Two loads of the same muscle diagnosed together cannot share one such
    # rescaling: the structure stays and nothing is named. The same two records without
    # the defect are adequate, so the verdict comes from the defect.
    def records(hidden, masses):
        directory = tmp_path / ('defect' if hidden else 'twin')
        directory.mkdir(exist_ok=True)
        return realistic_loads(9059, hidden, str(directory), masses)

    one, start = records(['sensor_nonlinearity'], [0.025])
    alone = diagnose(one[0], start, progress=False)
    assert alone.effects == [] and not needs_explaining(alone.extended_stats)
    assert [name for name, _, _ in alone.calibration.findings()] == ['stiffness_scale']
    assert alone.verdict == 'unexplained', alone.explanation
    assert ONE_LOAD_NOTE in alone.notes  # the report says what one load cannot test
    paths, start = records(['sensor_nonlinearity'], [0.015, 0.04])
    together = diagnose(paths, start, progress=False)
    print(format_summary(together))
    assert together.effects == [], together.explanation
    assert together.verdict == 'unexplained', together.explanation
    paths, start = records([], [0.015, 0.04])
    twin = diagnose(paths, start, progress=False)
    assert twin.effects == [] and twin.verdict == 'adequate', twin.explanation
    assert ONE_LOAD_NOTE not in twin.notes
