"""A calibration's posterior kept in its params file, drawn, and carried into simulate/linearize.

One synthetic calibration (a random muscle's step records without a thermometer,
calibrated on its lowest and highest power with the fast cst model) is shared by
the tests; its middle power is held out.
"""
import csv
import dataclasses
import io
import json
import re

import numpy as np
import pytest

from tca_ros.calibration.posterior import BAND_LABEL, CALIBRATED_FLOOR, check_posterior, \
    draw_coordinates, draw_params, mean_params, POSTERIOR_KEY, PosteriorError, read_posterior, \
    UNMEASURED_NOTE, write_line
from tca_ros.cli.compare import simulate_record
from tca_ros.cli.main import main
from tca_ros.model.tca_params import to_flat_dict
from tca_ros.params.files import dump_params, load_params
from tca_ros.records.data import write_csv_record
from tca_ros.synthetic.realistic import realistic_set

SEED = 5


def run(*argv):
    out = io.StringIO()
    status = main([str(a) for a in argv], out=out)
    return status, out.getvalue()


@pytest.fixture(scope='module')
def calibrated(tmp_path_factory):
    """Return (folder, synthetic set, held-out record path, its truth's path)."""
    folder = tmp_path_factory.mktemp('posterior')
    rs = realistic_set(SEED, drift=0.0)
    for i, record in enumerate(rs.records):
        write_csv_record(record, folder / f'r{i}.csv')
    held = rs.records[1]
    truth = simulate_record(rs.truth.with_values(model='cst'), held, 500.0)
    # the held-out step as the truth made it, with a thermometer the calibration never had
    write_csv_record(dataclasses.replace(held, displacement=truth.displacement,
                                         temperature=truth.temperature), folder / 'truth.csv')
    dump_params(rs.start, folder / 'start.yaml')
    status, text = run('calibrate', folder / 'r0.csv', folder / 'r2.csv', '--config',
                       folder / 'start.yaml', '--model', 'cst', '--out', folder / 'cal.yaml',
                       '--quiet')
    assert status == 0, text
    return folder, rs


def test_the_posterior_line_round_trips_and_the_mean_is_the_file(calibrated):
    folder, _ = calibrated
    path = folder / 'cal.yaml'
    lines = path.read_text(encoding='utf-8').splitlines()
    post_lines = [ln for ln in lines if ln.startswith(f'# {POSTERIOR_KEY}: ')]
    assert len(post_lines) == 1  # one line, a comment: the file stays a params file
    post = read_posterior(path)
    assert post['channels'] == ['displacement']  # the records had no thermometer
    assert check_posterior(write_line(post)[len(POSTERIOR_KEY) + 1:]) == post
    params = load_params(str(path))
    # the posterior mean re-applied onto the file reproduces every entry of the file
    assert to_flat_dict(mean_params(params, post)) == to_flat_dict(params)
    # its standard deviations are the header's standard errors (printed to 2 digits)
    cov = np.array(post['cov'])
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0.0)
    stated = {}
    for line in lines:
        parts = line.lstrip('# ').split()
        if len(parts) > 4 and parts[1] == '=' and parts[3] == '+-':
            stated[parts[0]] = (float(parts[2]), float(parts[4]))
    assert set(post['names']) <= set(stated)
    for i, (name, log) in enumerate(zip(post['names'], post['log'])):
        value, stderr = stated[name]
        sd = np.sqrt(cov[i, i]) * (value if log else 1.0)
        assert sd == pytest.approx(stderr, rel=0.06, abs=1e-12), name


def test_the_file_states_what_the_calibration_left_unknown_as_its_uncertainty(calibrated):
    folder, rs = calibrated
    post = read_posterior(folder / 'cal.yaml')
    written = load_params(str(folder / 'cal.yaml')).uncertainty
    tighter = []
    for i, (name, log) in enumerate(zip(post['names'], post['log'])):
        if not hasattr(written, name):
            continue
        sd = float(np.sqrt(post['cov'][i][i]))
        left = np.expm1(sd) if log else sd
        described = getattr(rs.start.uncertainty, name)
        floor = CALIBRATED_FLOOR.get(name, CALIBRATED_FLOOR['relative'])
        assert getattr(written, name) == pytest.approx(min(described, max(left, floor))), name
        if getattr(written, name) < 0.8 * described:
            tighter.append(name)
    # the step records fix some values far better than the description did
    assert len(tighter) >= 2, tighter


@pytest.mark.slow
def test_a_record_in_a_draught_against_the_calibrated_file_is_a_heat_loss_finding(calibrated):
    """The calibrated file's tightened priors reveal what the description's absorb."""
    from tca_ros.diagnosis import diagnose, format_summary
    folder, rs = calibrated
    cal = load_params(str(folder / 'cal.yaml'))
    held = rs.records[1]
    fan = cal.with_values(**{'thermal.convection_coefficient':
                             2.8 * cal.thermal.convection_coefficient})
    noise = np.random.default_rng(3).normal(0.0, 20e-6, held.time.size)
    for name, params in (('still', cal), ('fan', fan)):
        sim = simulate_record(params, held, 500.0)
        write_csv_record(dataclasses.replace(held, displacement=sim.displacement + noise),
                         folder / f'{name}.csv')
    texts = {}
    for name in ('still', 'fan'):
        for config in ('cal.yaml', 'start.yaml'):
            result = diagnose(str(folder / f'{name}.csv'), str(folder / config), model='cst',
                              progress=False)
            texts[name, config] = format_summary(result)
    assert 'finding: heat_loss' in texts['fan', 'cal.yaml']
    assert 'more air flow than the description assumes' in texts['fan', 'cal.yaml']
    assert 'verdict: adequate' not in texts['fan', 'cal.yaml']
    assert 'finding: heat_loss' not in texts['still', 'cal.yaml']
    # against the description's loose heat-loss prior (x/÷ 1.6) the same move weighs less
    z = {config: float(re.search(r'heat_loss +\S+ W/K +\(start \S+, z ([-+.\d]+)',
                                 texts['fan', config]).group(1))
         for config in ('cal.yaml', 'start.yaml')}
    assert z['cal.yaml'] > z['start.yaml'] + 0.5, z


def test_calibrating_the_same_records_from_the_calibrated_file_warns(calibrated, capsys):
    folder, _ = calibrated
    capsys.readouterr()
    status, _ = run('calibrate', folder / 'r0.csv', '--config', folder / 'cal.yaml', '--model',
                    'cst', '--out', folder / 'again.yaml', '--quiet')
    err = capsys.readouterr().err
    assert status == 0
    assert 'was calibrated on 1 of these records (r0.csv' in err and 'counts twice' in err
    status, _ = run('calibrate', folder / 'r1.csv', '--config', folder / 'cal.yaml', '--model',
                    'cst', '--out', folder / 'new.yaml', '--quiet')
    assert status == 0 and 'counts twice' not in capsys.readouterr().err  # a new record


def test_draws_have_the_posterior_covariance_and_apply_like_the_calibration(calibrated):
    folder, _ = calibrated
    post = read_posterior(folder / 'cal.yaml')
    mean, cov = np.array(post['mean']), np.array(post['cov'])
    sd = np.sqrt(np.diag(cov))
    # draws are clipped to the bounds: compare the parameters well inside them
    inside = (mean - 4.0 * sd > np.array(post['low'])) & (mean + 4.0 * sd < post['high'])
    assert inside.sum() >= 4
    z = draw_coordinates(post, 4000, seed=1)[:, inside]
    chol = np.linalg.cholesky(cov[np.ix_(inside, inside)])
    white = np.linalg.solve(chol, (z - mean[inside]).T)
    assert np.abs(np.cov(white) - np.eye(int(inside.sum()))).max() < 0.1
    assert np.abs(white.mean(axis=1)).max() < 0.1
    params = load_params(str(folder / 'cal.yaml'))
    draws = draw_params(params, post, 3, seed=2)
    gains = np.exp(draw_coordinates(post, 3, seed=2)[:, post['names'].index('actuation_gain')])
    assert [d.fiber.untwist_gain for d in draws] == pytest.approx(gains, rel=1e-12)
    assert len({d.moduli.youngs_modulus for d in draws}) == 3
    assert all(d.fiber.radius == params.fiber.radius for d in draws)  # not fitted: kept


def test_the_band_covers_a_held_out_record_and_flags_the_unmeasured_temperature(calibrated):
    folder, _ = calibrated
    status, text = run('simulate', '--compare', folder / 'r1.csv', folder / 'truth.csv',
                       '--config', folder / 'cal.yaml', '--model', 'cst', '--out',
                       folder / 'cmp', '--draws', 12, '--physics-rate', 200)
    assert status == 0, text
    bands = {row['record']: row for row in csv.DictReader(
        io.StringIO((folder / 'cmp' / 'band.csv').read_text(encoding='utf-8')))}
    # the noiseless truth of the held-out power lies mostly inside the model's band
    assert float(bands['truth']['displacement_in_band_percent']) >= 60.0
    # the measured record (sensor noise) inside the band widened by the fit's residual
    assert float(bands['r1']['displacement_in_band_residual_percent']) >= 85.0
    assert float(bands['r1']['displacement_in_band_percent']) < 85.0  # the noise is outside
    lines = [ln for ln in text.splitlines() if ln.startswith('# band: truth:')]
    assert len(lines) == 1 and 'temperature' in lines[0] and UNMEASURED_NOTE in lines[0]
    assert UNMEASURED_NOTE not in lines[0].split('temperature')[0]  # not on displacement
    assert (folder / 'cmp' / 'truth.png').stat().st_size > 5000


def test_linearize_gives_gain_and_time_constant_with_their_spread(calibrated, tmp_path):
    folder, _ = calibrated
    status, text = run('linearize', '--config', folder / 'cal.yaml', '--model', 'cst',
                       '--power', 0.5, '--draws', 10, '--out', tmp_path / 'lin')
    assert status == 0, text
    spread = {}
    for line in text.splitlines():
        if '+-' in line and ('dc_gain' in line or 'thermal time constant' in line):
            head, _, rest = line.partition(' +- ')
            spread[head.strip().rsplit(' ', 1)[0]] = float(rest.split()[0])
    assert set(spread) >= {'power->displacement dc_gain', 'power->temperature dc_gain',
                           'thermal time constant'}
    assert spread['power->displacement dc_gain'] > 0.0 and spread['thermal time constant'] > 0
    temperature = [ln for ln in text.splitlines() if ln.startswith('power->temperature')
                   or 'power->temperature dc_gain' in ln]
    assert len(temperature) == 2 and all(UNMEASURED_NOTE in ln for ln in temperature)
    record = json.loads((tmp_path / 'lin' / 'linear_model.json').read_text(encoding='utf-8'))
    tau = record['uncertainty']['thermal_time_constant']
    assert tau['p5'] <= tau['mean'] <= tau['p95'] and tau['std'] > 0.0


def test_a_config_without_posterior_prints_no_uncertainty():
    status, text = run('linearize', '--config', 'free_stroke', '--model', 'cst', '--power', 1)
    assert status == 0 and 'uncertainty' not in text and UNMEASURED_NOTE not in text
    assert not [ln for ln in text.splitlines() if 'dc_gain' in ln and '+-' in ln]


def test_bad_posterior_or_draws_is_one_line_with_status_2(calibrated, tmp_path, capsys):
    folder, _ = calibrated
    text = (folder / 'cal.yaml').read_text(encoding='utf-8')
    bad = tmp_path / 'bad.yaml'
    bad.write_text(text.replace('"cov":', '"kov":'), encoding='utf-8')
    with pytest.raises(PosteriorError, match="lacks 'cov'"):
        read_posterior(bad)
    status, _ = run('linearize', '--config', bad, '--power', 0.5)
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1 and "lacks 'cov'" in err
    assert run('linearize', '--config', bad, '--power', 0.5, '--draws', 0)[0] == 0
    with pytest.raises(SystemExit) as exc:
        run('simulate', '--compare', folder / 'r1.csv', '--config', folder / 'cal.yaml',
            '--draws', 1)
    assert exc.value.code == 2 and "--draws: '1'" in capsys.readouterr().err


def test_a_profile_plot_draws_the_band(calibrated, tmp_path, monkeypatch):
    import tca_ros.cli.compare as cli_compare
    folder, _ = calibrated
    seen = {}
    original = cli_compare.plot_simulation

    def spy(text, path, title, limits=None, posterior=None):
        seen.update(limits=limits, posterior=posterior)
        return original(text, path, title, limits, posterior)
    monkeypatch.setattr(cli_compare, 'plot_simulation', spy)
    import matplotlib.figure
    labels, save = [], matplotlib.figure.Figure.savefig

    def legends(fig, *args, **kwargs):
        labels.extend(t.get_text() for ax in fig.axes if ax.get_legend()
                      for t in ax.get_legend().get_texts())
        return save(fig, *args, **kwargs)
    monkeypatch.setattr(matplotlib.figure.Figure, 'savefig', legends)
    status, text = run('simulate', '--config', folder / 'cal.yaml', '--model', 'cst',
                       '--input', 'profile_steps', '--rate', 5, '--physics-rate', 200,
                       '--draws', 4, '--plot', tmp_path / 'steps.png')
    assert status == 0 and (tmp_path / 'steps.png').stat().st_size > 5000
    assert set(seen['limits']) == {'displacement', 'temperature', 'resistance'}
    low, high = seen['limits']['displacement']
    assert np.all(low <= high) and np.max(high - low) > 0.0
    assert seen['posterior']['channels'] == ['displacement']
    assert f'{BAND_LABEL} {UNMEASURED_NOTE}' in labels  # the temperature's band
    assert f'temperature (modelled) {UNMEASURED_NOTE}' in labels
    assert BAND_LABEL in labels and 'displacement (modelled)' in labels  # measured: no note
