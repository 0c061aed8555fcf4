"""The description is evidence: what a tight prior reveals, a loose one absorbs (issue 25)."""
from types import SimpleNamespace

import numpy as np
import pytest

from tca_ros.calibration.candidates import absorbed_candidates, build_candidates, \
    RECALIBRATION, recalibration_spaces
from tca_ros.calibration.physical_priors import prior_spreads, SHIFT_Z
from tca_ros.diagnosis import diagnose
from tca_ros.diagnosis.findings import FindingTest, found_despite_structure
from tca_ros.diagnosis.joint import JointFit
from tca_ros.params.files import dump_params, load_params
from tca_ros.synthetic.descriptions import describe, EXACT_SPREAD, LOOSE
from tca_ros.synthetic.realistic import realistic_case, truth_path

from conftest import benchmark_case  # noqa: I100

#: one 120 s record at 5 Hz of a cst plant, nothing but the hidden effect and sensor noise
QUIET = {'rate': 5.0, 'plant': 'cst', 'temperature': False, 'drift': False,
         'nominal_power': False, 'noisy_power': False, 'jitter': False, 'not_at_rest': False}


def _described(tmp_path, seed, hidden, tightnesses, **conditions):
    """Return (record path, {tightness: description path}, truth) of a quiet realistic case."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    record, start = realistic_case(seed, hidden, str(tmp_path), duration=120.0,
                                   **{**QUIET, **conditions})
    truth = load_params(truth_path(str(tmp_path), seed))
    paths = {}
    for tightness in tightnesses:
        paths[tightness] = str(tmp_path / f'{tightness}.yaml')
        dump_params(describe(truth, load_params(start), tightness,
                             np.random.default_rng(seed)), paths[tightness])
    return record, paths, truth


def test_a_measured_description_names_the_power_loss_a_guessed_one_absorbs(tmp_path):
    # 14 % of the logged power never heats the thread, no thermometer. Described as
    # measured (2-5 %), the calibration must move the heat capacity, loss and gain
    # beyond their stated uncertainty to take it up: findings, which the power loss,
    # calibrated jointly, returns within the description. Described as guessed
    # (x/÷ 2), the same record is fitted by the nominal parameters: nothing to name.
    record, described, truth = _described(tmp_path, 1, ['power_loss'], ('exact', 'guessed'))
    tight = diagnose(record, described['exact'], progress=False)
    loose = diagnose(record, described['guessed'], progress=False)
    assert tight.calibration.findings(), 'the measured description shows no finding'
    assert tight.effects == ['power_loss'] and tight.verdict == 'explained', tight.notes
    fraction = tight.extended_values['effects.power_loss_fraction']
    assert fraction == pytest.approx(truth.effects.power_loss_fraction, abs=0.05)
    assert any('power_loss, calibrated jointly' in n for n in tight.notes), tight.notes
    assert not loose.calibration.findings() and loose.effects == [], loose.notes


def test_a_tight_description_narrows_the_refit_beside_each_candidate():
    # the search refits the gain, delivered power, specific heat and damping beside
    # every candidate: within their fixed factors for a loosely described muscle, within
    # two stated spreads of the description for a measured one
    params = load_params('free_stroke', model='cst')
    loose = {s.name: s for s in recalibration_spaces(params)[0]}
    assert set(loose) == set(RECALIBRATION)
    assert loose['fiber.untwist_gain'].low == pytest.approx(RECALIBRATION['fiber.untwist_gain'][0])
    measured = params.with_values(**{f'uncertainty.{k}': EXACT_SPREAD[1] for k in LOOSE})
    spaces, values = recalibration_spaces(measured, measured, prior_spreads(measured))
    gain = {s.name: s for s in spaces}['fiber.untwist_gain']
    assert (gain.low, gain.high) == pytest.approx((1.05 ** -2, 1.05 ** 2))
    damping = {s.name: s for s in spaces}['dynamics.damping']
    assert damping.high == pytest.approx(0.5) and damping.low == pytest.approx(0.5 / 1.05 ** 2)
    # a calibrated value beyond the description's band keeps itself and the band in range
    moved = measured.with_values(**{'fiber.untwist_gain': 1.3})
    spaces, _ = recalibration_spaces(moved, measured, prior_spreads(measured))
    gain = {s.name: s for s in spaces}['fiber.untwist_gain']
    assert gain.low == pytest.approx(1.05 ** -2) and gain.high == pytest.approx(1.3)
    # the power loss is searched where the delivered power ratio is stated tightly
    candidates = build_candidates(params, 'cst', 0.29, 5e-3)
    assert absorbed_candidates(candidates, recalibration_spaces(params)[0])[1] == \
        ['power_loss']
    tight = recalibration_spaces(measured, measured, prior_spreads(measured))[0]
    assert absorbed_candidates(candidates, tight)[1] == []


@pytest.mark.slow
def test_a_decisive_power_loss_is_found_beside_structure_a_null_leaves(tmp_path):
    # The power is logged as the command while the thread gets +-3 % more or less: no
    # model of the logged inputs leaves the residual unstructured, the plant's own
    # neither. Described as measured, the calibration moves the heat loss, heat capacity
    # and gain 3-7 spreads; the power loss, calibrated jointly, returns them, lowers the
    # objective far more than any other effect they stand for, and predicts the
    # held-out part better than the nominal model held at the description: it is
    # named, and the verdict says that structure remains beside it.
    record, described, truth = _described(tmp_path / 'loss', 8, ['power_loss'], ('exact',),
                                          nominal_power=True)
    found = diagnose(record, described['exact'], progress=False)
    assert found.verdict == 'unexplained' and found.effects == ['power_loss'], found.notes
    assert found.helpful == []
    fraction = found.extended_values['effects.power_loss_fraction']
    assert fraction == pytest.approx(truth.effects.power_loss_fraction, abs=0.05)
    assert found.explanation.startswith('power_loss found: ')
    assert 'unexplained structure remains beside it' in found.explanation
    # the same muscle and record conditions without the loss: no finding, nothing named
    record, described, _ = _described(tmp_path / 'null', 8, [], ('exact',), nominal_power=True)
    null = diagnose(record, described['exact'], progress=False)
    assert not null.calibration.findings() and null.effects == [], null.notes


def _finding_test(name, fall, returned=True, holds=False):
    """Return a FindingTest of ``name`` with objective fall ``fall`` (returning its values)."""
    fit = JointFit(name=name, values={}, n_params=1, sims=[], criterion=0.0, explained=False,
                   pinned=[])
    return FindingTest(fit=fit, fall=fall, deviance=-20.0, returned=returned, passes=False,
                       names=('heat_loss',), holds=holds)


def test_a_finding_effect_is_not_found_beside_structure_without_a_decisive_margin():
    # measured on a 14 % power loss logged at the command: power loss lowered the
    # objective by 24.4, radiation by 19.5. Within 10 of each other the description
    # does not tell them apart, and neither is named (no calibration is even run).
    def calibrate_with(*_):
        raise AssertionError('no nominal model held at the description is needed')
    tests = [_finding_test('power_loss', 24.4), _finding_test('radiation', 19.5)]
    assert found_despite_structure(calibrate_with, [], None, tests) is None
    # nor below the margin alone
    assert found_despite_structure(calibrate_with, [], None,
                                   [_finding_test('power_loss', 9.5)]) is None


class _PastTheMargin(Exception):
    """Raised where found_despite_structure calibrates the nominal model described."""


def test_only_a_rival_that_returns_the_values_keeps_a_lead_from_its_margin():
    # seed 9837 (a power loss, rod plant at 2 Hz): the power loss returned the values with
    # an objective fall of 10.3; friction fell it by 34.5 but left the values beyond the
    # description and predicted the held-out part worse by 107 (its stick-slip fits the
    # training part): it does not explain the findings, so it does not stand in the way
    # (G94); nor does an offset that predicts the held-out part as the shifted nominal
    # does (seed 9637). A rival that returns the values does
    cal = SimpleNamespace(report=SimpleNamespace(estimates={}, values={}))

    def calibrate_with(*_):
        raise _PastTheMargin
    lead = _finding_test('power_loss', 10.3 + 0.5)
    for rival in (_finding_test('friction', 34.5, returned=False),
                  _finding_test('ambient_offset', 4.7, returned=False, holds=True)):
        with pytest.raises(_PastTheMargin):
            found_despite_structure(calibrate_with, [], cal, [lead, rival])
    assert found_despite_structure(calibrate_with, [], cal, [
        lead, _finding_test('radiation', 9.0)]) is None


@pytest.mark.slow
def test_a_sensor_lag_the_heat_capacity_took_up_without_a_thermometer_is_found(tmp_path):
    # seed 9126 of the confusion benchmark (a 240 s record at 5 Hz, cst plant, power
    # logged as the command, no thermometer) hides a sensor lag and a hysteresis: the
    # exact description's calibration moves the heat capacity +2.7 spreads, which a
    # sensor lag explains as well as a second thermal lag (decisions G48). Before, only
    # the thermal lags were tested and the second thermal lag was named alone; with the
    # direction of the last motion among the structure test's signals (G77) the sensor
    # lag alone leaves the hysteresis's structure, and the hidden pair is named
    result, _ = benchmark_case(tmp_path, 9126, ['sensor_lag', 'hysteresis'])
    assert [n for n, z, _ in result.calibration.findings()] == ['heat_capacity']
    assert sorted(result.effects) == ['hysteresis', 'sensor_lag'], result.notes


@pytest.mark.slow
def test_a_friction_in_a_drifting_record_is_confirmed_on_the_whole_record_less_the_drift(
        tmp_path):
    # seed 9123 of the confusion benchmark (a 240 s record at 1 Hz, rod plant, noisy
    # power log, no thermometer, a sensor drift) hides a 24 mN friction. Calibrated
    # jointly on the training part, friction predicts the held-out part decisively
    # better (gain > 300) but leaves structure; calibrated on the whole record it left
    # structure too while the fit bent its values to the drift that the verdict's test
    # then removes (decisions G52). Fitted less that drift it is confirmed and named.
    result, truth = benchmark_case(tmp_path, 9123, ['friction'])
    assert result.effects == ['friction']
    assert result.verdict == 'explained'
    assert 'calibrated jointly on the whole record' in result.explanation
    assert result.extended_values['effects.friction_force'] == pytest.approx(
        truth.effects.friction_force, rel=0.15)


@pytest.mark.slow
def test_a_hysteresis_the_heat_capacity_took_up_is_tested_as_its_cause(tmp_path):
    # seed 9107 of the confusion benchmark run with four muscles per effect (a 240 s
    # record at 2 Hz, rod plant, no thermometer) hides a hysteresis: the exact
    # description's calibration moves the heat capacity up, a slower response. Only the
    # lags were tested as its cause and a sensor lag was named; the play (and friction)
    # are tested too now, and the hysteresis explains it (G54)
    result, truth = benchmark_case(tmp_path, 9107, ['hysteresis'])
    assert 'heat_capacity' in [n for n, z, _ in result.calibration.findings()]
    assert result.effects == ['hysteresis']
    assert result.extended_values['effects.hysteresis_width'] == pytest.approx(
        truth.effects.hysteresis_width, rel=0.3)


@pytest.mark.slow
def test_a_search_explanation_faces_the_effect_the_findings_stand_for(tmp_path):
    # seed 9818 of the confusion benchmark's fourth sample (1 Hz, cst plant, a
    # thermometer) hides a nonlinear convection; two loads together. The calibration
    # moves the heat loss +4.4 spreads; the search's refit stays near the description
    # and an ambient offset explains the records (penalised held-out gain 50.9). The
    # nonlinear convection the finding stands for, calibrated jointly, predicts the
    # held-out part decisively better (302.0) and replaces it (G57)
    result, truth = benchmark_case(tmp_path, 9818, ['nonlinear_convection'], (0.015, 0.04))
    assert 'heat_loss' in {n for n, z, _ in result.calibration.findings()}
    assert result.effects == ['nonlinear_convection'] and result.verdict == 'explained'
    (note,) = [n for n in result.notes if 'replaces it (decisions G57)' in n]
    assert note.startswith('ambient_offset explains the records'), note
    assert result.extended_values['effects.convection_exponent'] == pytest.approx(
        truth.effects.convection_exponent, rel=0.3)


@pytest.mark.slow
def test_an_ambient_offset_the_first_round_ranked_behind_idle_lags_is_named(tmp_path):
    # seed 9130 of the confusion benchmark (a 240 s record at 100 Hz, cst plant, power
    # logged as the command, no thermometer) hides a 7.2 K ambient offset. The first
    # round ranked two lags refined to 0 s and a dead time screened at 0 s first, by the
    # refit's own held-out score; they had their chance and go last (decisions G66), so
    # the offset is calibrated jointly and named. The exact description states the room
    # to 1 K and T_z to 2 K: 7.2 K is beyond what it admits
    result, truth = benchmark_case(tmp_path, 9130, ['ambient_offset'])
    assert result.effects == ['ambient_offset'], result.notes
    assert result.extended_values['effects.ambient_offset'] == pytest.approx(
        truth.effects.ambient_offset, abs=1.0)


@pytest.mark.slow
def test_a_lag_that_predicts_decisively_better_is_named_though_structure_remains(tmp_path):
    # seed 9142 of the confusion benchmark (a 240 s record at 2 Hz, cst plant, power
    # logged as the command, no thermometer) hides a second thermal lag. Calibrated
    # jointly, a sensor lag leaves no structure (gain 653.5) and the second lag leaves
    # some (822.1): the held-out deviance says which explains the records, the structure
    # test only that the second lag is not all of the cause (decisions G66)
    result, _ = benchmark_case(tmp_path, 9142, ['second_thermal_lag'])
    assert result.effects == ['second_thermal_lag'], result.notes
    assert result.verdict == 'unexplained'
    assert 'unexplained structure remains beside it' in result.explanation
    assert any('second_thermal_lag is named instead of sensor_lag' in n for n in result.notes)


def test_a_value_a_sensor_drift_bent_is_not_a_finding(tmp_path):
    # seed 9804 of the confusion benchmark's fourth sample: no effect hidden, a cst plant
    # at 20 Hz with a thermometer, described exactly, its encoder drifting. Calibrated as
    # the residual is, the stiffness scale moves -3.8 spreads and a modulus softening
    # was named for it; calibrated again less each record's drift it moves -0.2: the
    # drift's, set aside, and nothing is named (decisions G78)
    result, _ = benchmark_case(tmp_path, 9804, [])
    assert result.effects == [] and result.verdict == 'adequate', result.notes
    assert 'stiffness_scale' in result.calibration.drift_shifts
    assert 'stiffness_scale' not in [name for name, _, _ in result.calibration.findings()]
    (note,) = [n for n in result.notes if n.startswith('not findings:')]
    assert 'stiffness_scale (-3.8 -> ' in note
    assert abs(result.calibration.drift_shifts['stiffness_scale']) <= SHIFT_Z


def test_a_defect_free_muscle_at_20_hz_with_a_thermometer_leaves_no_finding(tmp_path):
    # seed 10004 of the confusion benchmark's fifth sample: no effect hidden, a cst plant
    # at 20 Hz with a thermometer, described exactly. The calibration reads the record
    # at 10 Hz; with each coarse sample the mean of its own fine one and the one before,
    # the channels read 25 ms late, the thermometer pinned the heat, and the calibration
    # slowed the mechanical response instead: stiffness -2.9, damping +2.6 spreads, and
    # a friction was named. Read centred, both stay within the description (G79)
    result, _ = benchmark_case(tmp_path, 10004, [])
    assert result.effects == [] and result.verdict == 'adequate', result.notes
    z = {r.name: r.z for r in result.calibration.plausibility()}
    assert abs(z['stiffness_scale']) < SHIFT_Z and abs(z['damping']) < SHIFT_Z, z


def test_a_finding_a_drift_moves_by_a_hair_stays_a_finding(tmp_path):
    # seed 9131 of the tuned sample: an 8.4 % power loss on a rod plant at 5 Hz, no
    # drift. The heat loss moves +2.004 spreads, +1.998 calibrated less a drift: within
    # 2 spreads, but the drift took back a hair of the shift, not most of it
    # (nominal.DRIFT_LEAVES), so the finding stands and names the power loss (G78)
    result, truth = benchmark_case(tmp_path, 9131, ['power_loss'])
    assert truth.effects.power_loss_fraction > 0.05
    assert result.effects == ['power_loss'], result.notes
    assert not result.calibration.drift_shifts
    assert not [n for n in result.notes if n.startswith('not findings:')]


@pytest.mark.slow
def test_two_values_within_their_spreads_but_unlikely_together_name_a_power_loss(tmp_path):
    # seed 10034 of the confusion benchmark's fifth sample: a 9 % power loss at 20 Hz
    # with no thermometer, described exactly. The calibration moves the heat capacity,
    # the heat loss and the gain about +1.9, +1.8 and -1.6 spreads: none alone is a
    # finding (2), together they are as unlikely as one beyond it (decisions G80), and
    # the power loss, calibrated jointly, brings them back
    from tca_ros.calibration.physical_priors import JOINT_Z
    result, truth = benchmark_case(tmp_path, 10034, ['power_loss'])
    assert truth.effects.power_loss_fraction > 0.05
    z = {r.name: r.z for r in result.calibration.plausibility()}
    assert JOINT_Z < z['heat_capacity'] <= SHIFT_Z and JOINT_Z < z['heat_loss'] <= SHIFT_Z, z
    assert {n for n, _, _ in result.calibration.findings()} >= {'heat_capacity', 'heat_loss'}
    assert result.effects == ['power_loss'], result.notes


def test_a_value_moved_the_way_no_effect_moves_it_names_nothing_and_is_said(tmp_path):
    # seed 9401 of the confusion benchmark's second sample: no effect hidden, a rod plant
    # at 5 Hz with a thermometer, described exactly; the cst fit takes the stiffness
    # about +2.2 spreads up (the rod's form, decisions G68). Every catalogue effect that
    # moves a stiffness lowers it (a softening, creep), so the finding stands for none
    # and nothing is calibrated for it: `unexplained`, with the reason said (G82)
    result, _ = benchmark_case(tmp_path, 9401, [])
    assert result.effects == [] and result.verdict == 'unexplained', result.notes
    (finding,) = result.calibration.findings()
    assert finding[0] == 'stiffness_scale' and finding[1] > SHIFT_Z and finding[2] == ()
    assert 'no catalogue effect moves them that way' in result.explanation
    assert not [n for n in result.notes if 'calibrated jointly' in n], result.notes


@pytest.mark.slow
def test_a_joint_fit_that_undoes_its_own_effect_is_not_named(tmp_path):
    # seed 9852 of the fourth sample: a sensor nonlinearity (outside the catalogue) on one
    # load, cst plant at 2 Hz. The search leaves structure; a softening calibrated jointly
    # explains the record only with the actuation gain +6.4 spreads up, where a softening
    # lowers it: fitted larger than the record asks, its excess taken back by the gain. It
    # was named; it is set aside and said, and the record is `unexplained` (G83)
    result, _ = benchmark_case(tmp_path, 9852, ['sensor_nonlinearity'])
    assert result.effects == [] and result.verdict == 'unexplained', result.notes
    (note,) = [n for n in result.notes if 'makes the other way' in n]
    assert note.startswith('modulus_softening, calibrated jointly') and 'actuation_gain +' in note
    assert 'is not named' in note


@pytest.mark.slow
def test_a_rival_that_moves_the_stated_room_far_loses_to_one_that_moves_nothing(tmp_path):
    # seed 9423 of the second sample: a softening of 10.8 MPa/K on one load, rod plant at
    # 1 Hz, no thermometer. Calibrated jointly, an ambient offset of -8.2 K (the room is
    # stated to 1 K and T_z to 2 K: 3.7 spreads) and the softening both explain the record,
    # at penalised held-out gains of 84.3 and 81.9; the offset was named. Weighed with the
    # prior cost of the room it moves (z^2), the softening is named and the offset is its
    # rival, with both figures (G84)
    result, _ = benchmark_case(tmp_path, 9423, ['modulus_softening'])
    assert result.effects == ['modulus_softening'] and result.verdict == 'explained', \
        result.notes
    (note,) = [n for n in result.notes if n.startswith('also explained')]
    assert note.split(': ', 1)[1].startswith('ambient_offset (penalised held-out gain')
    assert 'for the described values it moves' in note


@pytest.mark.slow
def test_an_effect_that_leaves_a_finding_it_cannot_make_standing_explains_nothing(tmp_path):
    # seed 9456 of the second sample: a sensor nonlinearity (outside the catalogue) on
    # one load, a cst plant at 5 Hz with a thermometer. The calibration takes the gain
    # +2.4 spreads up and the stiffness -6.6 down. A softening calibrated jointly returns
    # the stiffness, which it lowers, but leaves the gain, which it cannot raise: it
    # explains one finding, not the record, and is not named (G82)
    result, _ = benchmark_case(tmp_path, 9456, ['sensor_nonlinearity'])
    assert result.effects == [] and result.verdict == 'unexplained', result.notes
    found = {name: (z, effects) for name, z, effects in result.calibration.findings()}
    assert found['actuation_gain'][0] > SHIFT_Z and found['stiffness_scale'][0] < -SHIFT_Z
    assert 'modulus_softening' not in found['actuation_gain'][1]
    (note,) = [n for n in result.notes if n.startswith('findings ')]
    assert 'modulus_softening (objective fall' in note and 'values not returned' in note


@pytest.mark.slow
def test_a_heat_loss_the_thermometer_reads_worse_does_not_explain_a_fading_gain(tmp_path):
    # Seed 9653 (outside the catalogue: the actuation gain fades by 25 % over a 240 s
    # record at 1 Hz, rod plant, with a thermometer). Nonlinear convection calibrated
    # jointly predicted the held-out stroke better (penalised gain 13.9) and was named,
    # but it did so by bending the heat balance: the held-out temperature, drift
    # removed, came out 33 % worse than the nominal model's. An effect that moves the
    # stroke only through the temperature is refuted by a thermometer that reads its
    # temperature worse (decisions G86): the record is unexplained, nothing named, and
    # the report says what was set aside and why
    result, _ = benchmark_case(tmp_path, 9653, ['fatigue'])
    assert result.effects == [] and result.verdict == 'unexplained', result.notes
    aside = [n for n in result.notes if n.startswith('nonlinear_convection, calibrated jointly')]
    assert len(aside) == 1 and 'refuted by the thermometer' in aside[0]


@pytest.mark.slow
def test_a_finding_s_power_loss_is_not_judged_by_the_temperature_its_nominal_bent_to(
        tmp_path):
    # Seed 9437 (a power loss, rod plant at 2 Hz, with a thermometer): the calibration
    # took the loss up by moving the heat capacity and the heat loss about 12 spreads,
    # and with them it fits the measured temperature. The power loss, calibrated
    # jointly, returns them to the description and predicts the held-out temperature
    # 15 % worse than that bent nominal; its evidence is the description (a finding),
    # so the thermometer rule of G86 does not refute it, and it is named
    result, truth = benchmark_case(tmp_path, 9437, ['power_loss'])
    assert result.effects == ['power_loss'], result.notes
    assert result.extended_values['effects.power_loss_fraction'] == pytest.approx(
        truth.effects.power_loss_fraction, abs=0.05)
