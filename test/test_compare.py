"""`tca_sim simulate --compare` / `--plot` and the shipped example inputs."""
import csv
import filecmp
import importlib.util
import io
import pathlib

import pytest

from tca_ros.cli.main import main
from tca_ros.params.files import dump_params, load_params
from tca_ros.records.data import read_record
from tca_ros.records.examples import EXAMPLES_DIR, resolve_example, shipped_examples

ROOT = pathlib.Path(__file__).resolve().parents[1]
PNG_MAGIC = b'\x89PNG\r\n\x1a\n'


def run(*argv):
    out = io.StringIO()
    status = main(list(argv), out=out)
    return status, out.getvalue()


def rows_of(text):
    return list(csv.DictReader(io.StringIO(text)))


def is_png(path):
    path = pathlib.Path(path)
    return path.is_file() and path.read_bytes()[:8] == PNG_MAGIC and path.stat().st_size > 5000


def test_shipped_examples_are_labelled_synthetic_and_readable():
    records = shipped_examples('rec_')
    assert len(records) == 4 and len(shipped_examples('profile_')) == 3
    powers, masses = set(), set()
    for name in records:
        record = read_record(resolve_example(name))
        assert record.meta['synthetic'].startswith('yes, SYNTHETIC')
        assert record.meta['hidden_effect'].startswith('power_loss_fraction 0.15')
        powers.add(float(record.power.max()))
        masses.add(record.mass)
    assert powers == {0.5, 1.0, 1.5} and masses == {0.03, 0.05}
    for name in shipped_examples('profile_'):
        assert 'not a measurement' in pathlib.Path(resolve_example(name)).read_text()
    assert 'SYNTHETIC' in (pathlib.Path(EXAMPLES_DIR) / 'README.md').read_text()


def test_make_examples_rewrites_the_shipped_files_identically(tmp_path):
    spec = importlib.util.spec_from_file_location('make_examples',
                                                  ROOT / 'bench' / 'make_examples.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(['--out', str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == sorted(n + '.csv' for n in shipped_examples())
    match, mismatch, errors = filecmp.cmpfiles(EXAMPLES_DIR, tmp_path, names, shallow=False)
    assert (mismatch, errors) == ([], [])


def test_compare_shows_the_hidden_power_loss(tmp_path):
    status, text = run('simulate', '--compare', 'rec_1W_30g', 'rec_1W_50g',
                       '--out', str(tmp_path))
    assert status == 0
    rows = rows_of(text)
    assert [r['record'] for r in rows] == ['rec_1W_30g', 'rec_1W_50g']
    for row in rows:
        assert row['samples'] == '801'
        # the nominal model heats 15 % more than the muscle: a clear, not a noise-level, error
        assert 10.0 < float(row['nrmse_percent']) < 25.0
        assert float(row['rmse_mm']) == pytest.approx(
            float(row['nrmse_percent']) / 100 * float(row['peak_stroke_mm']), rel=0.01)
        assert is_png(row['plot'])
        assert float(row['resistance_rmse_ohm']) > 0.05
        assert float(row['temperature_rmse_k']) > 3.0
    assert (tmp_path / 'compare.csv').read_text() == text


def test_compare_with_the_true_model_leaves_only_the_sensor_noise(tmp_path):
    truth = load_params('free_stroke').with_values(**{'effects.power_loss_fraction': 0.15})
    dump_params(truth, str(tmp_path / 'lossy.yaml'))
    path = resolve_example('rec_1p5W_30g')
    status, text = run('simulate', '--compare', path, '--config', str(tmp_path / 'lossy.yaml'),
                       '--out', str(tmp_path / 'cmp'))
    assert status == 0
    row = rows_of(text)[0]
    # the records' noise: displacement 5 um, temperature 0.2 K, resistance 0.005 ohm (1 sigma)
    assert float(row['rmse_mm']) < 0.0065
    assert float(row['temperature_rmse_k']) < 0.25
    assert float(row['resistance_rmse_ohm']) < 0.0065
    assert is_png(tmp_path / 'cmp' / 'rec_1p5W_30g.png')


def test_simulate_reads_a_record_as_its_profile_and_plots(tmp_path):
    status, text = run('simulate', '--input', 'rec_1W_30g', '--rate', '20', '--plot',
                       str(tmp_path / 'sim.png'))
    assert status == 0
    rows = text.splitlines()
    assert rows[0] == 'time,power,load,displacement,temperature,resistance'
    assert len(rows) == 802 and rows[-1].startswith('40,0,0.2943')
    assert is_png(tmp_path / 'sim.png')
    status, text = run('simulate', '--input', str(pathlib.Path(EXAMPLES_DIR) / 'profile_load.csv'),
                       '--rate', '10')
    assert status == 0 and text.splitlines()[-1].startswith('40,0,0.4905')


@pytest.mark.parametrize('argv, words', [
    (('--compare', 'rec_nothing'), ("--compare = 'rec_nothing'", 'rec_1W_30g')),
    (('--input', 'nodir/profile_steps.csv'), ('nodir/profile_steps.csv: cannot open',)),
    (('--compare', 'nodir/rec_1W_30g'), ('nodir/rec_1W_30g: no such file',)),
    (('--input', 'profile_steps', '--out', 'x'), ("--out = 'x': only with --compare",)),
    (('--compare', 'rec_1W_30g', '--plot', 'x.png'), ("--plot = 'x.png': only with --input",)),
    (('--compare', 'rec_1W_30g', '--rig', 'spring'), ('--rig = spring', 'dead_weight')),
    (('--compare', 'rec_1W_30g', '--physics-rate', '0'), ('--physics-rate = 0',)),
    (('--compare', 'rec_1W_30g', '--max-steps', '100'), ('--max-steps',)),
    (('--input', 'profile_steps', '--plot', 'nodir/x.png'), ("--plot = 'nodir/x.png'",)),
    (('--input', 'profile_steps', '--compare', 'rec_1W_30g'), ('not allowed with',)),
])
def test_bad_requests_are_one_line_with_status_2(argv, words, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        status, _ = run('simulate', *argv)
    except SystemExit as exc:  # argparse's own errors
        status = exc.code
    err = capsys.readouterr().err
    assert status == 2
    assert len(err.strip().splitlines()) == 1 and 'tca_sim' in err
    for word in words:
        assert word in err
    assert not (tmp_path / 'out').exists()


def test_a_bad_supply_header_is_named(tmp_path, capsys):
    text = pathlib.Path(resolve_example('rec_1W_30g')).read_text()
    bad = tmp_path / 'bad.csv'
    bad.write_text('# supply: battery\n' + text)
    status, _ = run('simulate', '--compare', str(bad), '--out', str(tmp_path))
    err = capsys.readouterr().err
    assert status == 2 and "row 1, column 'supply': 'battery'" in err


def test_a_record_without_temperature_leaves_its_error_empty(tmp_path):
    from dataclasses import replace
    from tca_ros.records.data import write_csv_record
    record = read_record(resolve_example('rec_1W_50g'))
    bare = tmp_path / 'no_thermometer.csv'
    write_csv_record(replace(record, temperature=None), str(bare))
    status, text = run('simulate', '--compare', str(bare), '--out', str(tmp_path / 'cmp'))
    row = rows_of(text)[0]
    assert status == 0 and row['temperature_rmse_k'] == ''
    assert float(row['resistance_rmse_ohm']) > 0.05 and is_png(row['plot'])


def test_the_examples_are_package_data(tmp_path):
    import subprocess
    import sys
    build = subprocess.run([sys.executable, 'setup.py', '-q', 'build', '--build-base',
                            str(tmp_path)], cwd=ROOT, capture_output=True, text=True)
    assert build.returncode == 0, build.stderr
    shipped = tmp_path / 'lib' / 'tca_ros' / 'data' / 'examples'
    assert sorted(p.name for p in shipped.iterdir()) == sorted(
        ['README.md'] + [n + '.csv' for n in shipped_examples()])


def test_compare_scales_a_record_s_air_flow_as_the_calibration_fitted_it(tmp_path):
    # the example muscle recorded in still air, relabelled as under a fan; the config's
    # still-air heat loss is a third of the truth's and its calibrated_on header says a
    # fan triples it: with the fitted scale the comparison is the true model (noise
    # only); with the prior's 2.5x the heat loss is 17 % short
    import dataclasses
    import json
    from tca_ros.calibration.transfer import header_line
    from tca_ros.records.data import write_csv_record
    record = read_record(resolve_example('rec_1p5W_30g'))
    fan = dataclasses.replace(record, meta={**record.meta, 'environment': 'forced_air'})
    write_csv_record(fan, str(tmp_path / 'fan.csv'))
    truth = load_params('free_stroke').with_values(**{'effects.power_loss_fraction': 0.15})
    still = truth.with_values(**{'thermal.convection_coefficient':
                                 truth.thermal.convection_coefficient / 3.0})
    fitted = {'environment': {'still_air': 1.0, 'forced_air': 3.0}}
    dump_params(still, str(tmp_path / 'fitted.yaml'), header=header_line(fitted))
    dump_params(still, str(tmp_path / 'prior.yaml'))
    assert json.loads(header_line(fitted).split(': ', 1)[1]) == fitted
    errors = {}
    for name in ('fitted', 'prior'):
        status, text = run('simulate', '--compare', str(tmp_path / 'fan.csv'), '--config',
                           str(tmp_path / f'{name}.yaml'), '--out', str(tmp_path / name))
        assert status == 0, text
        errors[name] = float(rows_of(text)[0]['temperature_rmse_k'])
    assert errors['fitted'] < 0.25 < 3.0 < errors['prior']
