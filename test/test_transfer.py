"""`tca_sim validate`: a calibrated muscle predicting records it was not fitted on.

The plant is the full dynamics (18) of a muscle with an actuation lag and a flatter
stroke-temperature characteristic than the description's (not the calibration's
quasi-static reduction), logged at 5 Hz with coloured noise and quantisation.
"""
import io
import re

import numpy as np
import pytest

from tca_ros.calibration.transfer import read_trained_range
from tca_ros.calibration.validation import format_table, HeldOut, repeat_floor
from tca_ros.cli.main import main
from tca_ros.model.muscle import describe_muscle, MuscleSpec
from tca_ros.params.files import dump_params
from tca_ros.params.thread_presets import load_thread_presets
from tca_ros.records.data import write_csv_record
from tca_ros.synthetic.realistic import bench_record

SPEC = MuscleSpec(thread='nylon66_silver', thread_diameter=0.45e-3, coil='mandrel',
                  mandrel_diameter=0.8e-3, pitch_angle_deg=22.5, natural_length=0.05,
                  resistance=13.3, mass=0.02, model='cst')


def run(argv):
    out = io.StringIO()
    return main(argv, out=out), out.getvalue()


@pytest.fixture(scope='module')
def files(tmp_path_factory):
    """Return (dir, start config, train paths, test paths) of a lagging muscle."""
    root = tmp_path_factory.mktemp('transfer')
    start = describe_muscle(SPEC, load_thread_presets()).params
    c2, _, c0 = start.fiber.gamma_coefficients
    truth = start.with_values(**{'effects.second_thermal_lag': 4.0,
                                 'fiber.gamma_coefficients': [c2, 40.0 * c2, c0]})
    rng = np.random.default_rng(5)
    config = root / 'muscle.yaml'
    dump_params(start, str(config))
    paths = {}
    for name, power, mass in (('a', 0.3, 0.02), ('b', 0.45, 0.02), ('c', 0.6, 0.02),
                              ('hot1', 0.8, 0.02), ('hot2', 0.8, 0.02), ('heavy', 0.45, 0.05)):
        path = root / f'{name}.csv'
        write_csv_record(bench_record(truth, power, mass, rng, drift=0.0), str(path))
        paths[name] = str(path)
    return root, str(config), paths


def test_validate_predicts_an_extrapolated_power_and_says_it_extrapolates(files):
    root, config, paths = files
    cal = str(root / 'cal.yaml')
    code, _ = run(['calibrate', paths['a'], paths['b'], paths['c'], '--config', config,
                   '--out', cal, '--model', 'cst', '--quiet'])
    assert code == 0
    trained = read_trained_range(cal)
    assert trained['power_w'] == pytest.approx([0.3, 0.45, 0.6])
    assert trained['rig'] == ['dead_weight'] and trained['lumped']['tau'] > 0.0
    code, text = run(['validate', paths['hot1'], paths['hot2'], paths['heavy'], '--config',
                      cal, '--model', 'cst'])
    assert code == 0, text
    rows = {line.split()[0]: line.split() for line in text.splitlines()
            if line.startswith(('hot', 'heavy'))}
    physics = {k: float(v[3].rstrip('%')) for k, v in rows.items()}
    lumped = {k: float(v[4].rstrip('%')) for k, v in rows.items()}
    # the physics carries the load and the power it was not fitted on; the lumped
    # model, which ignores load and is linear in power, does not
    assert physics['hot1.csv'] < lumped['hot1.csv'] and physics['heavy.csv'] < lumped[
        'heavy.csv'], text
    assert physics['hot1.csv'] < 6.0, text
    assert 'power 0.8 W above the calibrated 0.6 W' in text
    assert 'load 0.49 N outside the calibrated 0.196-0.196 N' in text
    # hot1 and hot2 repeat one condition: each has a floor
    assert rows['hot1.csv'][5] != '-' and rows['heavy.csv'][5] == '-'


def test_a_params_file_not_from_calibrate_is_said_to_be_an_optimistic_baseline(files):
    _, config, paths = files
    code, text = run(['validate', paths['a'], '--config', config, '--model', 'cst'])
    assert code == 0 and 'no calibrated_on header' in text and 'lumped*' in text


def test_the_repeat_floor_is_the_mean_of_the_other_repeats():
    class R:
        def __init__(self, x, power=1.0):
            self.time = np.arange(10.0)
            self.displacement = np.asarray(x, float)
            self.power = np.full(10, power)
            self.load = np.full(10, 0.1)
    a, b, c = R(np.linspace(0, 1, 10)), R(np.linspace(0, 1, 10)), R(np.linspace(0, 2, 10))
    alone = R(np.ones(10), power=2.0)
    floors = repeat_floor([a, b, c, alone])
    assert floors[0] == pytest.approx(np.sqrt(np.mean((a.displacement - 1.5 * a.displacement)
                                                      ** 2)) / np.percentile(a.displacement,
                                                                             99.5))
    assert np.isnan(floors[3])


def test_loco_medians_name_power_and_load_so_one_power_at_two_loads_gives_two_rows():
    rows = [HeldOut('d/rec_1W_light.csv', (1.0, 0.2), 0.05, 0.20, 0.10),
            HeldOut('d/rec_1W_heavy.csv', (1.0, 0.5), 0.09, 0.30, 0.12),
            HeldOut('d/rec_2W.csv', (2.0, 0.2), 0.04, 0.25, 0.11)]
    medians = [line for line in format_table(rows).splitlines() if line.startswith('median')]
    labels = [line[:53].strip() for line in medians]
    assert labels == ['median P=1 W, F=0.2 N', 'median P=1 W, F=0.5 N',
                      'median P=2 W, F=0.2 N', 'median']
    assert medians[1].split()[-3:] == ['9.0%', '30.0%', '12.0%']  # the heavy load's own row


def test_an_air_flow_is_a_condition_with_its_own_heat_loss_scale():
    # a filmed muscle's time constant fell 2.8x with a fan: the same muscle at 0.4 and
    # 0.6 W in still air and at 0.8 W with 2.8x the heat loss, calibrated together
    from tca_ros.calibration.calibration import calibrate
    start = describe_muscle(SPEC, load_thread_presets()).params
    fan = start.with_values(**{'thermal.convection_coefficient':
                               2.8 * start.thermal.convection_coefficient})
    rng = np.random.default_rng(8)
    records = [bench_record(start, w, 0.02, rng, drift=0.0) for w in (0.4, 0.6)]
    forced = bench_record(fan, 0.8, 0.02, rng, drift=0.0)
    forced.meta['environment'] = 'forced_air'
    cal = calibrate(records + [forced], start, model='cst', check=False)
    est = cal.report.estimates['heat_loss_scale.forced_air']
    assert est.determined and abs(est.value - 2.8) <= max(2.0 * est.stderr, 0.1 * 2.8), est
    assert cal.environments == {'forced_air': est.value}
    # the muscle's own heat loss stays the still-air one
    assert cal.report.values['heat_loss'] == pytest.approx(cal.priors['heat_loss'].prior,
                                                           rel=0.25)


@pytest.mark.slow
def test_a_diagnosis_against_a_still_air_calibration_says_a_fan_is_more_heat_loss(tmp_path):
    # calibrated on three still-air steps; two steps under a fan taking 2.8x the heat away
    # (no environment in their header) are diagnosed against that file: the refit lowers
    # the steady rise and the time constant together, and a note says what that is; the
    # still-air records diagnosed the same way get no such note
    from tca_ros.calibration.calibration import calibrate
    from tca_ros.diagnosis import diagnose
    start = describe_muscle(SPEC, load_thread_presets()).params
    fan = start.with_values(**{'thermal.convection_coefficient':
                               2.8 * start.thermal.convection_coefficient,
                               'effects.convection_exponent': 0.0})
    rng = np.random.default_rng(3)
    still = [bench_record(start, w, 0.02, rng, drift=0.0) for w in (0.3, 0.5, 0.7)]
    paths = {}
    for name, rec in [('still0', still[0]), ('still2', still[2]),
                      ('fan0', bench_record(fan, 0.5, 0.02, rng, drift=0.0)),
                      ('fan1', bench_record(fan, 1.0, 0.02, rng, drift=0.0))]:
        paths[name] = str(tmp_path / f'{name}.csv')
        write_csv_record(rec, paths[name])
    cal_path = str(tmp_path / 'cal.yaml')
    dump_params(calibrate(still, start, model='cst', check=False).params, cal_path)
    config = str(tmp_path / 'start.yaml')
    dump_params(start, config)
    fanned = diagnose([paths['fan0'], paths['fan1']], config, calibrated=cal_path,
                      progress=False)
    notes = [n for n in fanned.notes if n.startswith('the refitted nominal parameters')]
    assert len(notes) == 1 and 'more moving air or a liquid' in notes[0], fanned.notes
    factors = [float(x) for x in re.findall(r'x(\d\.\d\d)', notes[0])]
    assert len(factors) == 2 and max(factors) < 1.0 / 1.2, notes[0]
    assert 'dead_time' not in fanned.effects
    calm = diagnose([paths['still0'], paths['still2']], config, calibrated=cal_path,
                    progress=False)
    assert not [n for n in calm.notes if n.startswith('the refitted nominal parameters')]


def test_an_air_flow_never_calibrated_is_predicted_with_its_priors_heat_loss():
    # calibrated in still air only, the muscle runs at 0.8 W under a fan that takes 2.8x
    # the heat away: predicted with the forced-air prior (2.5x) it is closer than as
    # if the air were still
    from tca_ros.calibration.calibration import calibrate
    from tca_ros.calibration.conditions import scale_of
    from tca_ros.calibration.predictions import full_nrmse
    start = describe_muscle(SPEC, load_thread_presets()).params
    fan = start.with_values(**{'thermal.convection_coefficient':
                               2.8 * start.thermal.convection_coefficient,
                               'effects.convection_exponent': 0.0})
    rng = np.random.default_rng(9)
    records = [bench_record(start, w, 0.02, rng, drift=0.0) for w in (0.4, 0.6)]
    forced = bench_record(fan, 0.8, 0.02, rng, drift=0.0)
    forced.meta['environment'] = 'forced_air'
    cal = calibrate(records, start, model='cst', check=False)
    assert cal.environments == {} and scale_of('forced_air', cal.environments) == 2.5
    with_prior = full_nrmse(cal.params, [forced], 'cst')[0]
    as_still = full_nrmse(cal.params, [forced], 'cst', scales={'forced_air': 1.0})[0]
    assert with_prior < 0.5 * as_still, (with_prior, as_still)


def test_an_environment_the_calibration_never_saw_is_an_extrapolation(files, tmp_path):
    root, config, paths = files
    cal = str(root / 'cal.yaml')
    if not (root / 'cal.yaml').exists():
        run(['calibrate', paths['a'], paths['b'], '--config', config, '--out', cal,
             '--model', 'cst', '--quiet'])
    text = open(paths['b']).read().replace('# tca:', '# environment: forced_air\n# tca:', 1)
    path = tmp_path / 'fan.csv'
    path.write_text(text)
    code, out = run(['validate', str(path), '--config', cal, '--model', 'cst'])
    assert code == 0 and 'environment forced_air not calibrated' in out, out
    assert "taken at the prior 2.5x still air's" in out, out


def test_an_isotonic_calibration_predicts_the_force_of_an_isometric_rig(files, tmp_path):
    # the same truth clamped at its length under a 1 g pretension (the full rig dynamics),
    # logged as an isometric rig logs it: time, power, force and a '# rig: isometric' header
    from tca_ros.model.rig_simulation import simulate_rig
    root, config, paths = files
    cal = str(root / 'cal_iso.yaml')
    assert run(['calibrate', paths['a'], paths['b'], paths['c'], '--config', config,
                '--out', cal, '--model', 'cst', '--quiet'])[0] == 0
    start = describe_muscle(SPEC, load_thread_presets()).params
    c2, _, c0 = start.fiber.gamma_coefficients
    truth = start.with_values(**{'effects.second_thermal_lag': 4.0,
                                 'fiber.gamma_coefficients': [c2, 40.0 * c2, c0],
                                 'rig.mode': 'isometric', 'rig.pretension': 0.00981})
    t = np.arange(0.0, 60.0, 0.2)
    p = np.where((t >= 10.0) & (t < 35.0), 0.4, 0.0)
    force = simulate_rig(truth, t, p, model='cst', physics_rate=500.0).columns['force']
    force = force + 2e-4 * np.random.default_rng(1).standard_normal(t.size)
    path = tmp_path / 'iso.csv'
    path.write_text('# tca: free_stroke\n# mass_kg: 0.001\n# sample_rate_hz: 5\n'
                    '# rig: isometric\n# pretension_n: 0.00981\ntime,power,force\n'
                    + ''.join(f'{a:.3f},{b:.4f},{c:.6f}\n' for a, b, c in zip(t, p, force)))
    code, text = run(['validate', str(path), '--config', cal, '--model', 'cst'])
    assert code == 0, text
    row = next(line.split() for line in text.splitlines() if line.startswith('iso.csv'))
    assert float(row[3].rstrip('%')) < 10.0, text  # the force rise, from displacement only
    assert row[4] == '-'  # a lumped power-to-contraction model has no force to give
    assert 'rig isometric not calibrated' in text


def test_an_isometric_record_calibrates_the_same_params_and_predicts_a_load(tmp_path):
    # records of a clamped muscle alone (force, 1 g pretension) calibrate the muscle;
    # the calibrated file then predicts the same muscle with a hanging mass
    from tca_ros.calibration.calibration import calibrate
    from tca_ros.calibration.predictions import full_nrmse
    from tca_ros.model.rig_simulation import simulate_rig
    from tca_ros.records.data import read_record
    start = describe_muscle(SPEC, load_thread_presets()).params
    truth = start.with_values(**{'fiber.untwist_gain': 1.3, 'effects.second_thermal_lag': 2.0})
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 60.0, 0.2)
    paths = []
    for k, w in enumerate((0.3, 0.5)):
        p = np.where((t >= 10.0) & (t < 35.0), w, 0.0)
        iso = truth.with_values(**{'rig.mode': 'isometric', 'rig.pretension': 0.00981})
        force = simulate_rig(iso, t, p, model='cst', physics_rate=500.0).columns['force']
        force = force + 2e-4 * rng.standard_normal(t.size)
        path = tmp_path / f'iso{k}.csv'
        path.write_text('# tca: free_stroke\n# mass_kg: 0.001\n# sample_rate_hz: 5\n'
                        '# rig: isometric\n# pretension_n: 0.00981\ntime,power,force\n'
                        + ''.join(f'{a:.3f},{b:.4f},{c:.6f}\n' for a, b, c in zip(t, p, force)))
        paths.append(str(path))
    records = [read_record(p) for p in paths]
    cal = calibrate(records, start, model='cst')
    assert cal.report.success and 'force' in cal.channels
    assert max(cal.nrmse) < 0.03, cal.nrmse  # the full rig dynamics, force rise
    assert cal.report.values['actuation_gain'] == pytest.approx(1.3, rel=0.15)
    hanging = bench_record(truth, 0.4, 0.02, rng, drift=0.0)
    assert full_nrmse(cal.params, [hanging], 'cst')[0] < 0.08  # 5.6 % when written
    # the same from the command line: no lumped model can be fitted on force records
    out = tmp_path / 'iso_cal.yaml'
    assert run(['calibrate', *paths, '--config', str(_dump(start, tmp_path)), '--out',
                str(out), '--model', 'cst', '--quiet'])[0] == 0
    write_csv_record(hanging, str(tmp_path / 'hanging.csv'))
    code, text = run(['validate', str(tmp_path / 'hanging.csv'), '--config', str(out),
                      '--model', 'cst'])
    row = next(line.split() for line in text.splitlines() if line.startswith('hanging'))
    assert code == 0 and row[4] == '-' and 'rig dead_weight not calibrated' in text, text


def test_simulate_warns_when_a_calibrated_muscle_runs_past_its_calibration(
        files, tmp_path, capsys):
    root, config, paths = files
    cal = str(root / 'cal_sim.yaml')
    assert run(['calibrate', paths['a'], paths['b'], '--config', config, '--out', cal,
                '--model', 'cst', '--quiet'])[0] == 0
    profile = tmp_path / 'p.csv'
    profile.write_text('time,power\n0,0\n2,0.9\n10,0\n12,0\n')
    capsys.readouterr()
    assert main(['simulate', '--config', cal, '--model', 'cst', '--input', str(profile),
                 '--rate', '2'], out=io.StringIO()) == 0
    err = capsys.readouterr().err
    assert 'warning: extrapolates: power 0.9 W above the calibrated 0.45 W' in err, err
    hottest = read_trained_range(cal)['peak_temperature_c']
    hot = re.search(r'extrapolates: predicted (\d+) degC above the calibrated (\d+) degC', err)
    assert hot and int(hot.group(2)) == round(hottest) and int(hot.group(1)) > hottest + 10
    profile.write_text('time,power\n0,0\n2,0.4\n10,0\n12,0\n')
    assert main(['simulate', '--config', cal, '--model', 'cst', '--input', str(profile),
                 '--rate', '2'], out=io.StringIO()) == 0
    assert 'extrapolates' not in capsys.readouterr().err


@pytest.mark.slow
def test_a_spring_rig_record_calibrates_and_is_predicted(tmp_path):
    # the muscle on a 20 N/m series spring pulling 0.1 N at rest (the rig's full dynamics),
    # logged with its displacement and the gauge's force: calibrated from it alone, the
    # file then predicts the same muscle on the spring at another power
    from tca_ros.calibration.calibration import calibrate
    from tca_ros.model.rig_simulation import simulate_rig
    from tca_ros.records.data import read_record
    start = describe_muscle(SPEC, load_thread_presets()).params
    truth = start.with_values(**{'fiber.untwist_gain': 1.3, 'rig.mode': 'spring',
                                 'rig.pretension': 0.1, 'rig.spring_stiffness': 20.0})
    rng = np.random.default_rng(6)
    t = np.arange(0.0, 60.0, 0.2)
    paths = []
    for k, w in enumerate((0.3, 0.5, 0.7)):
        p = np.where((t >= 10.0) & (t < 35.0), w, 0.0)
        c = simulate_rig(truth, t, p, np.full_like(t, 0.1), model='cst',
                         physics_rate=500.0).columns
        x = c['displacement'] + 5e-6 * rng.standard_normal(t.size)
        f = c['force'] + 1e-4 * rng.standard_normal(t.size)
        path = tmp_path / f'spring{k}.csv'
        path.write_text('# tca: free_stroke\n# mass_kg: 0.001\n# sample_rate_hz: 5\n'
                        '# rig: spring\n# spring_stiffness_n_per_m: 20\n'
                        'time,power,load,displacement,force\n'
                        + ''.join(f'{a:.3f},{b:.4f},0.1,{d:.9f},{e:.6f}\n'
                                  for a, b, d, e in zip(t, p, x, f)))
        paths.append(str(path))
    records = [read_record(p) for p in paths]
    cal = calibrate(records[:2], start, model='cst')
    assert cal.report.success and 'force' in cal.channels
    assert max(cal.nrmse) < 0.03, cal.nrmse
    out = tmp_path / 'cal.yaml'
    assert run(['calibrate', *paths[:2], '--config', str(_dump(start, tmp_path)), '--out',
                str(out), '--model', 'cst', '--quiet'])[0] == 0
    code, text = run(['validate', paths[2], '--config', str(out), '--model', 'cst'])
    row = next(line.split() for line in text.splitlines() if line.startswith('spring2'))
    assert code == 0 and float(row[3].rstrip('%')) < 5.0, text


def _dump(params, folder):
    path = folder / 'start.yaml'
    dump_params(params, str(path))
    return path


def test_rig_pretension_and_environment_are_read_as_labs_write_them(tmp_path):
    from tca_ros.calibration.conditions import environment_of, rig_of
    from tca_ros.records.data import read_record
    rows = ''.join(f'{0.2 * i:.1f},0.5,{0.01 + 1e-4 * i:.5f}\n' for i in range(30))
    cases = (('pretension_g', '1', 0.00981), ('pretension_kg', '0.002', 0.01962),
             ('pretension_n', '0.05', 0.05))
    for key, value, newtons in cases:
        path = tmp_path / f'{key}.csv'
        path.write_text('# tca: free_stroke\n# mass_kg: 0\n# sample_rate_hz: 5\n'
                        f'# rig: Isometric\n# {key}: {value}\n# air: fan\ntime,power,force\n'
                        + rows)
        r = read_record(str(path))
        assert r.load[0] == pytest.approx(newtons) and rig_of(r) == 'isometric'
        assert environment_of(r) == 'forced_air' and not r.displacement.any()
    r.meta = {'rig': 'isotonic', 'environment': 'free'}
    assert rig_of(r) == 'dead_weight' and environment_of(r) == 'still_air'


@pytest.mark.parametrize('rise, tau, says', [
    (0.70, 0.68, 'more moving air'), (1.40, 1.30, 'stiller air'),
    (0.70, 1.00, None),  # the rise alone: a power loss, not a heat loss
    (0.90, 0.88, None),  # within the 1.2 factor: no change worth a word
    (0.50, 0.90, None)])  # not one scale: the two factors disagree
def test_the_heat_loss_note_needs_rise_and_time_constant_moved_together(rise, tau, says):
    from tca_ros.calibration.candidates import ParameterSpace
    from tca_ros.diagnosis.heat_loss_note import heat_loss_note
    start = describe_muscle(SPEC, load_thread_presets()).params
    r0, c0 = start.thermal.delivered_power_ratio, start.fiber.specific_heat
    values = {'thermal.delivered_power_ratio': rise * r0, 'fiber.specific_heat': tau * c0}
    spaces = (ParameterSpace('thermal.delivered_power_ratio', 0.7 * r0, 1.4 * r0, log=True),
              ParameterSpace('fiber.specific_heat', 0.6 * c0, 1.6 * c0, log=True))
    notes = heat_loss_note(start, values, spaces)
    if says is None:
        assert notes == []
    else:
        assert len(notes) == 1 and says in notes[0]
        assert ('at the edge of their refit range' in notes[0]) == (rise in (0.70, 1.40))
