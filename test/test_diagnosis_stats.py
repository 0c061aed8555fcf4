"""Tests of the residual statistics and the model-selection penalty."""
import math

import numpy as np
import pytest

from tca_ros.calibration.candidates import ParameterSpace
from tca_ros.calibration.residuals import cross_correlation_lag, effective_samples, \
    ljung_box, noise_sigma, spectral_flatness


def test_noise_sigma_ignores_smooth_signal_and_steps():
    rng = np.random.default_rng(0)
    t = np.arange(20000) / 100.0
    signal = 1e-3 * np.sin(2 * np.pi * t / 30.0) + 2e-3 * (t > 50.0)  # thermal-scale + step
    sigma = 7e-6
    est = noise_sigma(signal + sigma * rng.standard_normal(t.size))
    assert est == pytest.approx(sigma, rel=0.03)  # MAD sampling error ~1 % at n = 2e4


def test_ljung_box_accepts_white_and_rejects_ar1():
    rng = np.random.default_rng(1)
    white = rng.standard_normal(500)
    ar = np.empty(500)
    ar[0] = 0.0
    for i in range(1, 500):
        ar[i] = 0.7 * ar[i - 1] + white[i]
    assert ljung_box(white)[1] > 0.01  # seeded: p = 0.5ish; a 1 % test
    assert ljung_box(ar)[1] < 1e-6
    assert spectral_flatness(white) > spectral_flatness(ar)


def test_cross_correlation_finds_a_known_lag():
    rng = np.random.default_rng(2)
    x = np.cumsum(rng.standard_normal(3000))
    delay = 25  # samples = 0.25 s at 100 Hz
    measured = np.r_[np.full(delay, x[0]), x[:-delay]]
    _, _, best = cross_correlation_lag(measured, x, 100.0)
    assert best == pytest.approx(0.25)


def test_effective_samples_of_autocorrelated_residuals():
    n = 1000
    assert effective_samples(n, 0.0) == n and effective_samples(n, 0.5) == pytest.approx(n / 3)


@pytest.mark.parametrize('space', [ParameterSpace('effects.sensor_lag', 0.0, 3.0),
                                   ParameterSpace('effects.creep_time_constant', 2.0, 400.0,
                                                  log=True)])
def test_parameter_space_round_trip(space):
    for value in (space.low, 0.5 * (space.low + space.high), space.high):
        assert space.from_unit(space.to_unit(value)) == pytest.approx(value, rel=1e-12)
    assert space.from_unit(-1.0) == space.low and space.from_unit(2.0) == space.high
    assert math.isfinite(space.to_unit(space.high * 10))


def test_power_loss_is_not_searched_beside_a_refitted_delivered_power_ratio():
    from tca_ros.calibration.candidates import absorbed_candidates, build_candidates, \
        recalibration_spaces
    from tca_ros.params.files import load_params
    params = load_params('free_stroke', model='cst')
    candidates = build_candidates(params, 'cst', 0.29, 5e-3)
    kept, absorbed = absorbed_candidates(candidates, recalibration_spaces(params)[0])
    assert absorbed == ['power_loss']
    assert [c.name for c in kept] == [c.name for c in candidates if c.name != 'power_loss']
    kept, absorbed = absorbed_candidates(candidates, ())  # no calibration: searched
    assert absorbed == [] and len(kept) == len(candidates)


def test_the_damping_is_refitted_around_its_value_and_left_fixed_at_zero():
    from tca_ros.calibration.candidates import recalibration_spaces
    from tca_ros.params.files import load_params
    params = load_params('free_stroke', model='cst')
    spaces, values = recalibration_spaces(params)
    damping = {s.name: s for s in spaces}['dynamics.damping']
    assert (damping.low, damping.high) == pytest.approx((0.025, 0.5))  # x0.05-1 of 0.5
    assert values['dynamics.damping'] == 0.5
    # a params file without damping: no log scale around 0, the damping stays fixed
    spaces, values = recalibration_spaces(params.with_values(**{'dynamics.damping': 0.0}))
    assert 'dynamics.damping' not in values
    assert [s.name for s in spaces] == ['fiber.untwist_gain', 'thermal.delivered_power_ratio',
                                        'fiber.specific_heat']
    assert all(0.0 <= s.to_unit(values[s.name]) <= 1.0 for s in spaces)


@pytest.mark.slow
def test_a_calibrated_params_file_without_damping_is_diagnosed(tmp_path, capsys):
    # before the guard of recalibration_spaces: "the effect search failed ... (float
    # division by zero)", exit status 1
    import pathlib
    import tca_ros
    from tca_ros.cli.main import main
    from tca_ros.params.files import dump_params, load_params
    params = tmp_path / 'no_damping.yaml'
    dump_params(load_params('free_stroke').with_values(**{'dynamics.damping': 0.0}),
                str(params))
    record = pathlib.Path(tca_ros.__file__).parent / 'data' / 'example_recording.csv'
    code = main(['diagnose', str(record), '--calibrated', str(params), '--quiet'])
    out = capsys.readouterr()
    assert code == 0, out.err
    assert 'verdict:' in out.out


def test_a_base_the_full_dynamics_cannot_run_is_refused_and_the_old_base_kept():
    # seed 9050 with model=rod: an accepted candidate, scored on the fit grid, drove the
    # record-rate rod model past the table's 260 degC melt, and the whole diagnosis
    # failed with exit 1; now the candidate is set aside and the base is unchanged
    from tca_ros.diagnosis.search import rebase
    from tca_ros.model.rod_table import RodTableError

    class Problem:
        def __init__(self):
            self.base_values, self.bases = {'a': 1.0}, []

        def set_base(self, values):
            self.base_values = dict(values)
            if values.get('a', 0.0) > 5.0:
                raise RodTableError('temperature 260.008 degC beyond the rod table')
            self.bases.append(dict(values))

    problem = Problem()
    assert rebase(problem, {'a': 2.0}) and problem.base_values == {'a': 2.0}
    assert not rebase(problem, {'a': 9.0})
    assert problem.base_values == {'a': 2.0} and problem.bases[-1] == {'a': 2.0}


def test_adequate_needs_no_structure_on_the_whole_record_either():
    # the real record 1W_encoder_3: the held-out test did not resolve the end held up
    # 1.5 mm after cooling (a drift from the record's zero takes part of a late
    # offset), the whole record was structured, the search ran and kept nothing: that
    # is 'unexplained', not 'adequate'
    from types import SimpleNamespace
    from tca_ros.diagnosis.verdict import decide_verdict

    def stats(structured):
        return {'displacement': SimpleNamespace(channel='displacement', structured=structured,
                                                structure=None, ratio=1.0, unit='m')}
    assert decide_verdict([], stats(False), stats(False), stats(True))[0] == 'unexplained'
    assert decide_verdict([], stats(False), stats(False), stats(False))[0] == 'adequate'
    assert decide_verdict([], stats(False), stats(False))[0] == 'adequate'
    # with effects added the verdict is the extended model's, on the held-out part
    assert decide_verdict(['friction'], stats(True), stats(False), stats(True))[0] == \
        'explained'


def test_a_lag_effect_is_also_screened_with_the_dampings_lag_handed_over():
    # the calibration takes a non-viscous lag up as damping (b_t / k, s): a lag effect is
    # also screened with a tenth of the damping and the lag that removes as its start
    from tca_ros.calibration.calibration import coil_stiffness
    from tca_ros.calibration.candidates import recalibration_spaces
    from tca_ros.diagnosis.fitting import FitProblem
    from tca_ros.diagnosis.search import _lag_exchange, EXCHANGE_FACTOR
    from tca_ros.params.files import load_params
    from tca_ros.synthetic.generator import make_synthetic_record
    record = make_synthetic_record(5, effects=None, duration=60.0, sample_rate=10.0).record
    params = load_params('free_stroke', model='cst').with_values(**{'dynamics.damping': 20.0})
    problem = FitProblem(record, params, model='cst')
    assert _lag_exchange(problem, {}) == ((), None)  # the damping not refitted: nothing
    problem.recalibration, values = recalibration_spaces(params)
    (base,), lag = _lag_exchange(problem, values)
    assert base == {'dynamics.damping': pytest.approx(EXCHANGE_FACTOR * 20.0)}
    k = coil_stiffness(params, 'cst')
    assert k > 0.0
    assert lag == pytest.approx((1.0 - EXCHANGE_FACTOR) * 20.0 / k)


def _screened(name, refined=False, criterion=-1.0, size=None):
    """Return a stand-in first-round CandidateScore of effect ``name``.

    Screened (not refined) at half its largest size unless ``size`` is given.
    """
    from types import SimpleNamespace
    from tca_ros.calibration.candidates import _SPACES
    from tca_ros.model.effects import CATALOGUE
    first = CATALOGUE.get(name, ('effects.none',))[0]
    space = _SPACES.get(first, (None,))[0]
    if size is None:
        size = 0.5 * space.high if space is not None else 1.0
    return SimpleNamespace(name=name, refined=refined, criterion=criterion,
                           fit=SimpleNamespace(params={first: size}))


def test_a_candidate_that_had_its_chance_in_the_first_round_goes_after_the_rest():
    # seed 9130 (a 7.2 K ambient offset at 100 Hz, no thermometer): two lags refined to
    # 0 s with no penalised gain and a dead time screened at 0 s ranked first by the
    # refit's held-out score; the offset, screened without the refit, seventh. Those that
    # had their chance go last, so the joint stage calibrates the offset (decisions G66).
    from tca_ros.calibration.candidates import build_candidates
    from tca_ros.diagnosis.joint_groups import had_its_chance, joint_order, JOINT_TOP
    from tca_ros.diagnosis.search import SearchRound
    from tca_ros.params.files import load_params
    params = load_params('free_stroke', model='cst')
    candidates = build_candidates(params, 'cst', 0.2, 5e-3)
    by_name = {c.name: c for c in candidates}
    scores = [_screened('sensor_lag', refined=True, criterion=-5.0, size=1e-9),
              _screened('dead_time', size=2.8e-8),
              _screened('second_thermal_lag', refined=True, criterion=-5.0, size=1e-9),
              _screened('coil_contact'), _screened('friction'), _screened('hysteresis'),
              _screened('ambient_offset', size=2.0), _screened('nonlinear_convection')]
    assert [had_its_chance(s, by_name[s.name]) for s in scores[:3]] == [True] * 3
    order = [c.name for c in joint_order([SearchRound([], 1.0, {}, scores)], candidates)]
    assert order[:JOINT_TOP] == ['friction', 'hysteresis', 'ambient_offset']
    assert 'nonlinear_convection' in order and 'sensor_lag' not in order
    # refined with a gain, it keeps its place: it has not shown that it does not help
    scores[0] = _screened('sensor_lag', refined=True, criterion=12.0, size=0.2)
    order = [c.name for c in joint_order([SearchRound([], 1.0, {}, scores)], candidates)]
    assert order[0] == 'sensor_lag' and 'second_thermal_lag' in order


def test_the_joint_calibration_takes_the_first_rounds_best_and_the_lag_siblings():
    # the first round's best JOINT_TOP calibratable candidates (coil contact's stop is
    # geometry, not calibrated); with a member of a family among them (the lags, the play
    # operators) the rest of its family follows
    from tca_ros.calibration.candidates import build_candidates
    from tca_ros.diagnosis.joint_groups import joint_order, JOINT_TOP
    from tca_ros.diagnosis.search import SearchRound
    from tca_ros.params.files import load_params
    params = load_params('free_stroke', model='cst')
    candidates = build_candidates(params, 'cst', 0.2, 5e-3)
    ranking = ['coil_contact', 'dead_time', 'creep', 'hysteresis', 'radiation',
               'second_thermal_lag', 'sensor_lag', 'friction', 'creep_x']
    scores = [_screened(n) for n in ranking]
    order = [c.name for c in joint_order([None, SearchRound([], 1.0, {}, scores)],
                                         candidates)]
    assert order[:JOINT_TOP] == ['dead_time', 'creep', 'hysteresis']
    assert order[JOINT_TOP:] == ['second_thermal_lag', 'sensor_lag', 'friction']
    without_lag = [_screened(n) for n in ['creep', 'hysteresis', 'radiation', 'dead_time']]
    assert [c.name for c in joint_order([SearchRound([], 1.0, {}, without_lag)],
                                        candidates)] == ['creep', 'hysteresis', 'radiation']
    assert joint_order([], candidates) == []
    # the effects a calibration's findings name come after them, once
    ranked = [_screened(n) for n in ['creep', 'hysteresis', 'ambient_offset', 'dead_time']]
    order = [c.name for c in joint_order([SearchRound([], 1.0, {}, ranked)], candidates,
                                         extra=('power_loss', 'creep'))]
    assert order == ['creep', 'hysteresis', 'ambient_offset', 'power_loss']


def test_pairs_start_from_single_joint_fits_that_help_and_take_partners_outside_their_family():
    # joint_groups.pair_order: leads are the single fits with a positive gain (best first); a
    # lead the search added takes its partners from the round based on it, another
    # from the first round; never its own family or coil contact; no lead, no pair
    from types import SimpleNamespace
    from tca_ros.calibration.candidates import build_candidates
    from tca_ros.diagnosis.joint import JointFit
    from tca_ros.diagnosis.joint_groups import MAX_PAIRS, pair_order
    from tca_ros.diagnosis.search import SearchRound
    from tca_ros.params.files import load_params
    candidates = build_candidates(load_params('free_stroke', model='cst'), 'cst', 0.2, 5e-3)

    def fit(name, criterion):
        return JointFit(name=name, values={}, n_params=1, sims=[], criterion=criterion,
                        explained=False, pinned=[])

    def scores(*names):
        return [SimpleNamespace(name=n) for n in names]

    first = SearchRound([], 1.0, {}, scores('dead_time', 'second_thermal_lag', 'sensor_lag',
                                            'coil_contact', 'friction', 'ambient_offset'))
    second = SearchRound(['dead_time'], 1.0, {},
                         scores('second_thermal_lag', 'coil_contact', 'ambient_offset',
                                'creep', 'friction'))
    fits = [fit('dead_time', 1417.0), fit('sensor_lag', 36.0), fit('hysteresis', -5.0)]
    pairs = [tuple(c.name for c in p) for p in pair_order([first, second], candidates, fits)]
    assert pairs == [('dead_time', 'ambient_offset'), ('dead_time', 'creep'),
                     ('sensor_lag', 'friction'), ('sensor_lag', 'ambient_offset')]
    assert len(pairs) <= MAX_PAIRS
    # the effects a calibration finding stands for partner each lead too, beyond the cap,
    # but never within the lead's family and never twice (G47)
    found = [tuple(c.name for c in p) for p in pair_order(
        [first, second], candidates, fits, extra=('modulus_softening', 'creep', 'dead_time'))]
    assert found == pairs + [('dead_time', 'modulus_softening'),
                             ('sensor_lag', 'modulus_softening'), ('sensor_lag', 'creep')]
    # two leads that are each other's finding effect make one pair, not two orders of it
    both = [tuple(c.name for c in p) for p in pair_order(
        [SearchRound([], 1.0, {}, scores('dead_time', 'friction'))], candidates,
        [fit('power_loss', 545.0), fit('radiation', 423.0)],
        extra=('radiation', 'power_loss'))]
    assert both.count(('power_loss', 'radiation')) == 1
    assert ('radiation', 'power_loss') not in both
    assert pair_order([first, second], candidates, [fit('dead_time', -1.0)]) == []
    assert pair_order([], candidates, fits) == []
    pair = JointFit(name='dead_time + ambient_offset', values={}, n_params=2, sims=[],
                    criterion=1.0, explained=True, pinned=[],
                    effects=('dead_time', 'ambient_offset'))
    assert pair.effects == ('dead_time', 'ambient_offset')
    assert fit('creep', 1.0).effects == ('creep',)


def test_a_pair_is_taken_only_when_its_partner_pays_beyond_its_member_single():
    # G64: the criterion is D - k ln(n); a pair below the single it contains names a
    # partner whose held-out gain does not pay for its parameter (the dead time 9136
    # took nonlinear convection at 1219 against 1255 alone)
    from tca_ros.diagnosis.joint import JointFit, pays_beyond_its_members

    def single(name, criterion):
        return JointFit(name=name, values={}, n_params=1, sims=[], criterion=criterion,
                        explained=False, pinned=[])

    singles = [single('dead_time', 1254.8), single('sensor_lag', 143.5)]
    assert not pays_beyond_its_members(('dead_time', 'nonlinear_convection'), 1219.2, singles)
    assert pays_beyond_its_members(('dead_time', 'ambient_offset'), 1276.5, singles)
    # a member never calibrated alone sets no bar; both members' bars hold
    assert pays_beyond_its_members(('creep', 'hysteresis'), -3.0, singles)
    assert not pays_beyond_its_members(('sensor_lag', 'dead_time'), 1000.0, singles)
    assert pays_beyond_its_members(('dead_time',), 1.0, ())


def test_a_power_loss_the_described_delivered_power_admits_is_not_an_effect():
    # G64: a power loss eta heats as a delivered power ratio r (1 - eta); within SHIFT_Z
    # prior spreads of the described r it is the muscle as described (candidates.twin_shift)
    import math
    from tca_ros.calibration.candidates import twin_shift
    from tca_ros.calibration.physical_priors import prior_spreads, SHIFT_Z
    from tca_ros.diagnosis.described import admitted_effects
    from tca_ros.params.files import load_params
    described = load_params('free_stroke').with_values(
        **{'uncertainty.delivered_power_ratio': 0.046})
    spreads = prior_spreads(described)
    small = described.with_values(**{'effects.power_loss_fraction': 0.029})
    assert twin_shift('power_loss', small, described, spreads) == pytest.approx(
        -math.log(1.0 - 0.029) / math.log1p(0.046))
    assert admitted_effects(('power_loss',), small, described, spreads) == ('power_loss',)
    # an 8.4 % loss where the delivered power is stated to 4 % is 2.2 spreads: named
    large = described.with_values(**{'effects.power_loss_fraction': 0.084,
                                     'uncertainty.delivered_power_ratio': 0.04})
    assert twin_shift('power_loss', large, large, prior_spreads(large)) > SHIFT_Z
    assert admitted_effects(('power_loss',), large, large, prior_spreads(large)) == ()
    # a delivered ratio the calibration moved up takes a loss back: 0.9 x 1.08 = 0.972
    moved = large.with_values(**{'thermal.delivered_power_ratio': 1.08,
                                 'effects.power_loss_fraction': 0.1})
    assert twin_shift('power_loss', moved, large, prior_spreads(large)) == pytest.approx(
        -math.log(0.972) / math.log1p(0.04))
    # effects without a twin, and a description that states no spread, give none
    assert twin_shift('creep', small, described, spreads) is None
    assert twin_shift('power_loss', small, described, {}) is None
    assert admitted_effects(('creep', 'dead_time'), small, described, spreads) == ()


def test_a_rival_pays_for_the_described_value_it_moves():
    # G84: an ambient offset is the stated room moved; its cost is z^2 in the room's
    # spread (with T_z's beside it when no thermometer reads the room), on the scale of
    # the penalised held-out gain; an effect with no described twin costs nothing
    import math
    from types import SimpleNamespace
    from tca_ros.calibration.physical_priors import prior_spreads
    from tca_ros.diagnosis.described import description_cost
    from tca_ros.diagnosis.joint import best_joint, JointFit
    from tca_ros.params.files import load_params
    described = load_params('free_stroke').with_values(
        **{'uncertainty.ambient_temperature': 1.0,
           'uncertainty.expansion_zero_temperature': 2.0})
    spreads = prior_spreads(described)
    off = described.with_values(**{'effects.ambient_offset': -3.0})
    assert description_cost(('ambient_offset',), off, described, spreads) == pytest.approx(9.0)
    assert description_cost(('ambient_offset',), off, described, spreads,
                            thermometer=False) == pytest.approx(9.0 / 5.0)
    assert description_cost(('ambient_offset', 'creep'), off, described, spreads) == \
        pytest.approx(9.0)
    assert description_cost(('modulus_softening',), off, described, spreads) == 0.0
    # best_joint ranks by the gain less that cost: the larger gain loses when it moves the room
    fits = [JointFit(name='ambient_offset', values={}, n_params=1, sims=[], criterion=84.3,
                     explained=True, pinned=[], cost=13.5),
            JointFit(name='modulus_softening', values={}, n_params=1, sims=[],
                     criterion=81.9, explained=True, pinned=[])]
    problems = [SimpleNamespace(channels=('displacement',))]
    import tca_ros.diagnosis.joint as joint
    saved = joint.lowers_heldout_rms
    joint.lowers_heldout_rms = lambda *args: True
    try:
        taken, rivals = best_joint(fits, problems, [], {})
    finally:
        joint.lowers_heldout_rms = saved
    assert taken.name == 'modulus_softening' and [f.name for f in rivals] == ['ambient_offset']
    assert math.isclose(rivals[0].weighed, 84.3 - 13.5)


def test_a_search_member_within_the_stated_room_is_not_named_beside_another():
    # G69: the search's pair ambient_offset + nonlinear_convection with an offset of
    # 0.65 K where the room is stated to 1 K (fresh bench seed 9420) names the
    # convection alone; the offset stays in the model as the description's slack
    from types import SimpleNamespace
    from tca_ros.diagnosis.extension import described_members
    from tca_ros.params.files import load_params
    # measured as the bench's exact description is: a convection exponent of 0.14 is then
    # 3.3 spreads of the stated heat loss, no slack of it (G74)
    described = load_params('free_stroke').with_values(
        **{'uncertainty.ambient_temperature': 1.0, 'uncertainty.heat_loss': 0.03})

    def nominal(offset, cal=True, channels=('displacement', 'temperature')):
        moved = described.with_values(**{'effects.ambient_offset': offset,
                                         'effects.convection_exponent': 0.14})
        return SimpleNamespace(
            cal=SimpleNamespace(start=described) if cal else None,
            problems=[SimpleNamespace(parameters=lambda values: moved)],
            problem=SimpleNamespace(channels=channels))

    pair = ['ambient_offset', 'nonlinear_convection']
    effects, notes = described_members(nominal(0.65), pair, {})
    assert effects == ['nonlinear_convection']
    assert len(notes) == 1 and notes[0].startswith('ambient_offset of the search')
    # 3 K is 3 spreads of the stated room: a finding, named
    assert described_members(nominal(3.0), pair, {}) == (pair, [])
    # without a thermometer the room's spread adds T_z's (20 K stated): admitted again
    assert described_members(nominal(3.0, channels=('displacement',)), pair, {})[0] == \
        ['nonlinear_convection']
    # alone it keeps its name; without a description there is nothing to admit by
    assert described_members(nominal(0.65), ['ambient_offset'], {}) == (['ambient_offset'], [])
    assert described_members(nominal(0.65, cal=False), pair, {}) == (pair, [])


def test_changed_values_lists_what_a_joint_calibration_moved():
    from tca_ros.diagnosis.joint import changed_values
    from tca_ros.params.files import load_params
    params = load_params('free_stroke')
    moved = params.with_values(**{'effects.creep_compliance': 0.01,
                                  'moduli.youngs_modulus': 2.0e9})
    assert changed_values(moved, params) == {'effects.creep_compliance': 0.01,
                                             'moduli.youngs_modulus': 2.0e9}
    assert changed_values(params, params) == {}


def test_a_calibration_fits_a_catalogue_effect_parameter_named_in_fit(tmp_path):
    # the joint calibration's building block: a creep compliance calibrated with the
    # nominal parameters on a record of a creeping muscle simulated by the rod model
    # (the fit runs cst) from a perturbed description
    from tca_ros.calibration.calibration import calibrate, CalibrationError
    from tca_ros.model.params_schema import GRAVITY
    from tca_ros.params.files import load_params
    from tca_ros.model.simulation import simulate
    from tca_ros.records.record import Record
    base = load_params('free_stroke')
    truth = base.with_values(**{'effects.creep_compliance': 0.006,
                                'effects.creep_time_constant': 30.0,
                                'fiber.untwist_gain': 1.2 * base.fiber.untwist_gain,
                                'dynamics.mass': 0.02, 'dynamics.load': 0.02 * GRAVITY})
    t = np.arange(0.0, 200.0, 0.2)
    power = np.where((t % 50.0) < 20.0, 0.25, 0.0)
    load = np.full_like(t, 0.02 * GRAVITY)
    sim = simulate(truth, t, power, load, model='rod', physics_rate=200.0)
    rng = np.random.default_rng(3)
    x = sim.displacement + 10e-6 * rng.standard_normal(t.size)
    record = Record(time=t, power=power, load=load, displacement=x - x[0],
                    meta={'mass_kg': 0.02})
    start = base.with_values(model='cst')
    fit = ['heat_capacity', 'heat_loss', 'actuation_gain', 'stiffness_scale',
           'damping']
    plain = calibrate([record], start, fit=fit, check=False)
    joint = calibrate([record], start, fit=fit + ['effects.creep_compliance',
                                                  'effects.creep_time_constant'], check=False)
    assert joint.params.effects.creep_compliance == pytest.approx(0.006, rel=0.25)
    assert joint.params.effects.creep_time_constant == pytest.approx(30.0, rel=0.3)
    rms = [c.report.record_rmse[0]['displacement'] for c in (plain, joint)]
    assert rms[1] < 0.5 * rms[0]
    with pytest.raises(CalibrationError, match='effects.creep_compliance'):
        calibrate([record], start, fit=['effects.no_such_thing'], check=False)
    with pytest.raises(CalibrationError, match='name it once'):
        calibrate([record], start, fit=['friction_force', 'effects.friction_force'],
                  check=False)


def test_a_joint_fit_is_taken_only_when_it_explains_and_beats_the_nominal(monkeypatch):
    # rules of joint.best_joint: no structure left, no parameter at a bound, a positive
    # penalised gain and the search's RMS rule against the nominal; the best gain wins
    # and the others that pass are returned as rivals (the report names them)
    from tca_ros.diagnosis import joint
    from tca_ros.diagnosis.joint import best_joint, JointFit

    def fit(name, criterion, explained=True, pinned=()):
        return JointFit(name=name, values={}, n_params=1, sims=[], criterion=criterion,
                        explained=explained, pinned=list(pinned))

    fits = [fit('creep', 40.0), fit('friction', 90.0, explained=False),
            fit('hysteresis', 60.0), fit('sensor_lag', 120.0, pinned=[('x', 3.0, 3.0)]),
            fit('radiation', -1.0), fit('dead_time', 10.0)]
    monkeypatch.setattr(joint, 'lowers_heldout_rms', lambda *args: True)
    best, rivals = best_joint(fits, [], [], {})
    assert best.name == 'hysteresis'
    assert [f.name for f in rivals] == ['creep', 'dead_time']
    monkeypatch.setattr(joint, 'lowers_heldout_rms', lambda problems, sims, rmse: False)
    assert best_joint(fits, [], [], {}) == (None, [])


def test_one_load_is_a_single_load_level_over_all_records():
    from tca_ros.diagnosis.verdict import holds_one_load
    from tca_ros.records.record import Record

    def record(load):
        n = len(load)
        return Record(time=np.arange(n) * 0.1, power=np.zeros(n), load=np.asarray(load),
                      displacement=np.zeros(n))

    assert holds_one_load([record([0.2] * 5)])
    assert holds_one_load([record([0.2, 0.2, 0.205]), record([0.201] * 3)])  # 2.5 %
    assert holds_one_load([record([0.0] * 4)])
    assert not holds_one_load([record([0.2, 0.2, 0.4, 0.4])])  # a load step
    assert not holds_one_load([record([0.15] * 3), record([0.39] * 3)])  # two records


def test_a_rival_left_structured_is_named_only_when_decisively_the_better_predictor():
    # family_rivals.decisive_despite_structure: the best of the rivals only the structure test
    # set apart replaces the fit taken when its penalised held-out gain beats that fit's
    # and every other passing fit's by more than DECISIVE_DEVIANCE (decisions G66); the
    # verdict then says structure remains beside it
    from tca_ros.diagnosis.family_rivals import decisive_despite_structure
    from tca_ros.diagnosis.joint import JointFit
    from tca_ros.diagnosis.rivals import DECISIVE_DEVIANCE

    def fit(name, criterion, explained=True):
        return JointFit(name=name, values={}, n_params=1, sims=[], criterion=criterion,
                        explained=explained, pinned=[])

    named, other = fit('sensor_lag', 164.2), fit('second_thermal_lag', 150.5)
    truth = fit('dead_time', 282.5, explained=False)
    lead = decisive_despite_structure(named, [other], [truth])
    assert lead is truth and 'sensor_lag' in lead.despite and '282.5' in lead.despite
    close = fit('dead_time', 164.2 + 0.9 * DECISIVE_DEVIANCE, explained=False)
    assert decisive_despite_structure(named, [other], [close]) is None
    # the bar is the best passing fit, not only the one taken
    assert decisive_despite_structure(named, [fit('friction', 280.0)], [truth]) is None
    assert decisive_despite_structure(None, [], [truth]) is None
    assert decisive_despite_structure(named, [other], []) is None


def test_what_the_description_admits_and_explains_best_names_nothing():
    # joint.described_lead: a fit whose effects the description all admits (an ambient
    # offset within the stated room and T_z) that explains the records decisively better
    # than the fit taken means the muscle is as described: nothing is named (seed 9059 at
    # two loads, a sensor nonlinearity: a -7.1 K offset at 274 against a friction at 17)
    from tca_ros.diagnosis.joint import described_lead, JointFit

    def fit(name, criterion, admitted=(), explained=True, effects=()):
        return JointFit(name=name, values={}, n_params=1, sims=[], criterion=criterion,
                        explained=explained, pinned=[], admitted=tuple(admitted),
                        effects=tuple(effects))

    offset = fit('ambient_offset', 274.4, admitted=['ambient_offset'])
    friction = fit('friction', 17.3)
    always = lambda f: True  # noqa: E731
    assert described_lead([offset, friction], friction, always) is offset
    assert described_lead([offset, friction], None, always) is offset
    assert described_lead([offset, friction], fit('friction', 270.0), always) is None
    # a pair with one member admitted claims the other: not the description
    pair = fit('ambient_offset + sensor_lag', 292.2, admitted=['ambient_offset'],
               effects=['ambient_offset', 'sensor_lag'])
    assert described_lead([pair, friction], friction, always) is None
    structured = fit('ambient_offset', 274.4, admitted=['ambient_offset'], explained=False)
    assert described_lead([structured, friction], friction, always) is None
    assert described_lead([offset, friction], friction, lambda f: False) is None


def test_the_muscle_as_described_says_the_values_its_fit_still_moves():
    # joint_text.described_note: a fit the description admits may still move other values
    # beyond their stated spreads (seed 9435 at two loads: a 2.92 K offset left three
    # values 6-7 spreads out); the note says so instead of calling it all the description
    from tca_ros.diagnosis.joint import JointFit
    from tca_ros.diagnosis.joint_text import described_note

    class Moved:
        def __init__(self, findings):
            self._findings = findings

        def findings(self):
            return self._findings

    def note(findings):
        return described_note(JointFit(
            name='ambient_offset', values={'effects.ambient_offset': 2.92}, n_params=1,
            sims=[], criterion=138.3, explained=True, pinned=[], admitted=('ambient_offset',),
            calibration=Moved(findings)))
    clean = note([])
    assert 'ambient_offset = 2.92' in clean and 'still moves' not in clean
    moved = note([('heat_loss', 7.1, ('radiation',)), ('actuation_gain', -6.2, ())])
    assert 'still moves heat_loss +7.1 prior spreads, actuation_gain -6.2 prior spreads' \
        in moved


def test_a_pair_with_a_member_the_description_admits_names_the_other(monkeypatch):
    # joint.best_joint and JointFit.claimed: seed 9135 at two loads (a dead time, no
    # thermometer) explained by a dead time and an ambient offset within the stated room
    # and T_z (gain 1976.5); before, the pair was dropped whole and a sensor lag +
    # hysteresis at 655.3 was named (decisions G66)
    from tca_ros.diagnosis import joint
    from tca_ros.diagnosis.joint import best_joint, JointFit
    monkeypatch.setattr(joint, 'lowers_heldout_rms', lambda *args: True)

    def fit(effects, criterion, admitted=()):
        return JointFit(name=' + '.join(effects), values={}, n_params=len(effects), sims=[],
                        criterion=criterion, explained=True, pinned=[],
                        admitted=tuple(admitted), effects=tuple(effects))

    pair = fit(['dead_time', 'ambient_offset'], 1976.5, admitted=['ambient_offset'])
    other = fit(['sensor_lag', 'hysteresis'], 655.3)
    best, rivals = best_joint([other, pair], [], [], {})
    assert best is pair and best.claimed == ('dead_time',) and rivals == [other]
    alone = fit(['ambient_offset'], 2000.0, admitted=['ambient_offset'])
    assert alone.claimed == () and best_joint([alone, other], [], [], {})[0] is other


def test_an_ambient_offset_is_admitted_within_the_stated_room_and_without_a_thermometer_t_z():
    # candidates.twin_shift: |offset| over the stated room uncertainty (K); without a
    # temperature channel the stroke sees T - T_z only, so T_z's uncertainty adds in
    # quadrature (decisions G66)
    from tca_ros.calibration.candidates import twin_shift
    from tca_ros.calibration.physical_priors import prior_spreads
    from tca_ros.params.files import load_params
    described = load_params('free_stroke').with_values(**{
        'uncertainty.ambient_temperature': 1.0,
        'uncertainty.expansion_zero_temperature': 2.0})
    spreads = prior_spreads(described)
    assert spreads['ambient_temperature'] == 1.0
    warm = described.with_values(**{'effects.ambient_offset': -3.0})
    assert twin_shift('ambient_offset', warm, described, spreads) == pytest.approx(3.0)
    assert twin_shift('ambient_offset', warm, described, spreads, thermometer=False) == \
        pytest.approx(3.0 / np.hypot(1.0, 2.0))
    assert twin_shift('creep', warm, described, spreads) is None
    # the default a new params file states: a thermostat's 2 K, T_z the paper's law's 20 K
    default = load_params('free_stroke')
    assert twin_shift('ambient_offset', warm, default, prior_spreads(default),
                      thermometer=False) == pytest.approx(3.0 / np.hypot(2.0, 20.0))


def test_radiation_is_admitted_as_the_stated_heat_loss_it_adds_to():
    # candidates.twin_shift: radiation of emissivity eps is the described h c_s A_0 plus
    # 4 eps sigma T_m^3 A_0, T_m midway to REFERENCE_RISE_K above the true ambient; the
    # shift of the sum in heat-loss prior spreads (decisions G67)
    import math
    from tca_ros.calibration.candidates import loss_with_radiation, twin_shift
    from tca_ros.calibration.physical_priors import prior_spreads
    from tca_ros.model.effects import STEFAN_BOLTZMANN
    from tca_ros.model.thermal import surface_area, thermal_conductance
    from tca_ros.params.files import load_params
    described = load_params('free_stroke').with_values(**{'uncertainty.heat_loss': 0.04})
    spreads = prior_spreads(described)
    grey = described.with_values(**{'effects.emissivity': 0.6})
    g = thermal_conductance(described.fiber, described.thermal)
    t_m = described.thermal.ambient_temperature + 25.0 + 273.15  # K
    g_rad = 4.0 * 0.6 * STEFAN_BOLTZMANN * t_m ** 3 * surface_area(described.fiber)
    assert loss_with_radiation(grey) == pytest.approx(g + g_rad)
    assert loss_with_radiation(described) == pytest.approx(g)
    shift = twin_shift('radiation', grey, described, spreads)
    assert shift == pytest.approx(math.log1p(g_rad / g) / math.log1p(0.04))
    # a warmer room radiates more; a heat loss described lower by the radiation admits it
    warm = grey.with_values(**{'effects.ambient_offset': 10.0})
    assert twin_shift('radiation', warm, described, spreads) > shift
    lower = described.with_values(**{'thermal.convection_coefficient':
                                     described.thermal.convection_coefficient * (g - g_rad) / g})
    assert twin_shift('radiation', grey, lower, spreads) == pytest.approx(
        math.log((g + g_rad) / (g - g_rad)) / math.log1p(0.04))
    assert twin_shift('radiation', lower.with_values(**{'effects.emissivity': 0.6}),
                      described, spreads) == pytest.approx(0.0, abs=1e-9)


def test_a_convection_exponent_is_admitted_while_the_loss_stays_within_its_stated_spread():
    # candidates.twin_shift: nonlinear convection scales h by (dT / dT_ref)^n, so the
    # loss leaves the stated one away from dT_ref; its shift is the largest over half and
    # twice the quoted rise (candidates.LOSS_RISES), ln(2) n for n > 0 (decisions G74).
    # Seed 9435: a 23.5 % power loss on a rod plant was named with an exponent of 0.034
    # beside it, 0.81 spreads of a heat loss stated to 2.9 %
    import math
    from tca_ros.calibration.candidates import heat_loss_at, twin_shift
    from tca_ros.calibration.physical_priors import prior_spreads
    from tca_ros.model.thermal import thermal_conductance
    from tca_ros.params.files import load_params
    described = load_params('free_stroke').with_values(**{'uncertainty.heat_loss': 0.029})
    spreads, g = prior_spreads(described), thermal_conductance(described.fiber,
                                                               described.thermal)
    assert heat_loss_at(described, 17.0) == pytest.approx(g)  # linear: every rise alike
    for n, admitted in ((0.034, True), (0.15, False), (0.09, False)):
        bent = described.with_values(**{'effects.convection_exponent': n})
        assert heat_loss_at(bent, 100.0) == pytest.approx(g * 2.0 ** n)
        shift = twin_shift('nonlinear_convection', bent, described, spreads)
        assert shift == pytest.approx(abs(n) * math.log(2.0) / math.log1p(0.029))
        assert (shift <= 2.0) == admitted, (n, shift)
    # with h 2 % above the stated one, each rise is read against the stated loss
    lower = described.with_values(**{'thermal.convection_coefficient':
                                     described.thermal.convection_coefficient * 1.02})
    bent = lower.with_values(**{'effects.convection_exponent': 0.034})
    assert twin_shift('nonlinear_convection', bent, described, spreads) == pytest.approx(
        max(abs(math.log(1.02 * 2.0 ** (k * 0.034))) for k in (-1, 0, 1))
        / math.log1p(0.029))


def test_a_partner_beside_the_description_s_own_slack_claims_nothing():
    # joint.stands_alone: a pair with an admitted member names the other only when that
    # one helped alone (a lead). Seed 9059 at two loads: a 0.031 s sensor lag, paired with
    # a -7.1 K offset the guessed description admits, failed alone; seed 9135: the dead
    # time paired with an admitted offset was the lead (decisions G66)
    from tca_ros.diagnosis.joint import JointFit, stands_alone

    def fit(effects, criterion, admitted=()):
        return JointFit(name=' + '.join(effects), values={}, n_params=len(effects), sims=[],
                        criterion=criterion, explained=True, pinned=[],
                        admitted=tuple(admitted), effects=tuple(effects))

    singles = [fit(['ambient_offset'], 274.4, admitted=['ambient_offset']),
               fit(['friction'], 17.3), fit(['dead_time'], -4.0)]
    assert not stands_alone(fit(['ambient_offset', 'sensor_lag'], 292.2,
                                admitted=['ambient_offset']), singles)
    assert not stands_alone(fit(['dead_time', 'ambient_offset'], 300.0,
                                admitted=['ambient_offset']), singles)  # no gain alone
    singles.append(fit(['dead_time'], 1500.0))
    assert stands_alone(fit(['dead_time', 'ambient_offset'], 1976.5,
                            admitted=['ambient_offset']), singles)
    assert stands_alone(fit(['friction', 'sensor_lag'], 21.4), singles)  # nothing admitted
