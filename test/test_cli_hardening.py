"""`tca_sim` never traces back, hangs or grows without bound (issue 10, items 7-11).

Each case is an input a fuzz campaign found (bench/fuzz_cli.py); the rule is one
error line on stderr naming the field and what is allowed, exit status 2 for bad
input, no NaN printed with exit status 0, and work refused before it starts when
it exceeds the stated limits.
"""
import io
import pathlib
import shutil
import time

import numpy as np
import pytest

from tca_ros.calibration.residuals import heating_mask
from tca_ros.cli.main import main, MAX_CONICAL_SHAPES, MAX_POWER_W, MESSAGE_CHARS
from tca_ros.params.config_search import config_dir

FAST_S = 5.0  # s: a refusal is decided before any simulation, well within this
HEADER = '# tca: {tca}\n# mass_kg: 0.03\n# sample_rate_hz: {rate}\n'
COLUMNS = 'time,power,load,displacement,temperature\n'


def run(argv, capsys):
    """Return (status, stdout, stderr, wall s) of one in-process `tca_sim` run."""
    out = io.StringIO()
    start = time.perf_counter()
    try:
        code = main(argv, out=out)
    except SystemExit as exc:  # argparse usage errors
        code = exc.code
    wall = time.perf_counter() - start
    return code, out.getvalue(), capsys.readouterr().err, wall


def assert_refused(result, *needles, status=2):
    code, out, err, wall = result
    assert code == status, (code, err)
    assert err.count('\n') == 1 and err.endswith('\n'), err[:2000]
    assert len(err) <= MESSAGE_CHARS + 100, len(err)
    assert 'Traceback' not in err and 'nan' not in out.lower()
    for needle in needles:
        assert needle in err, err
    assert wall < FAST_S, wall


def record(tmp_path, n=30, rate=10.0, tca='free_stroke', times=None, name='rec.csv',
           prefix=b''):
    """Write a valid diagnosis CSV (a heat-and-cool profile) and return its path."""
    t = np.arange(n) / rate if times is None else np.asarray(times)
    lines = [f'{float(ti)!r},{0.5 if i < n // 2 else 0.0},0.2943,{1e-4 * min(i, n - i):.6f},'
             f'{25 + 0.1 * min(i, n - i):.2f}' for i, ti in enumerate(t)]
    path = tmp_path / name
    path.write_bytes(prefix + (HEADER.format(tca=tca, rate=rate) + COLUMNS
                               + '\n'.join(lines) + '\n').encode())
    return str(path)


def profile(tmp_path, text, name='profile.csv'):
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return str(path)


SIMULATE = ['simulate', '--model', 'cst', '--input']


# -- item 7: tracebacks ---------------------------------------------------------------
@pytest.mark.parametrize('n, rate', [(20, 10.0), (25, 20.0), (20, 100.0), (30, 1000.0)])
def test_diagnose_of_a_minimal_valid_record_runs(tmp_path, capsys, n, rate):
    code, out, err, _ = run(['diagnose', record(tmp_path, n, rate), '--quiet'], capsys)
    assert code == 0 and 'Traceback' not in err and err == '', err
    assert 'verdict:' in out and 'nan' not in out.lower()


@pytest.mark.parametrize('n', [2, 5, 7, 10, 50])
def test_heating_mask_is_as_long_as_a_short_series(n):
    assert heating_mask(np.linspace(25.0, 30.0, n), 100.0).shape == (n,)


def test_first_time_of_minus_1e308_is_refused(tmp_path, capsys):
    times = [-1e308] + [0.1 * i for i in range(1, 30)]
    assert_refused(run(['diagnose', record(tmp_path, times=times), '--quiet'], capsys),
                   "row 7, column 'time': 0.2 s is not resolvable after -1e+308 s")


@pytest.mark.parametrize('text, needle', [
    ('time,power\n0,1\n1e308,1\n', '--max-samples'),
    ('time,power\n-1e308,1\n1e308,1\n', '--max-samples'),
    ('time,power\n1e300,1\n1.0000001e300,1\n', '--max-samples'),
    ('time,power\n0,1\n1,' + '1' * 200_000 + '\n', 'row 3: line longer than'),
    ('time,power\n0,1\n1,"' + 'x' * 200_000 + '"\n', 'row 3: line longer than'),
])
def test_simulate_huge_times_and_fields_are_refused(tmp_path, capsys, text, needle):
    assert_refused(run(SIMULATE + [profile(tmp_path, text)], capsys), needle)


@pytest.mark.parametrize('args, needle', [
    (['--physics-rate', '0'], '--physics-rate = 0: must be a positive rate'),
    (['--physics-rate', '1e308'], '--max-steps'),
    (['--physics-rate', '1e9'], '--max-steps'),
    (['--rate', '1e9'], '--max-samples'),
    (['--rate', 'nan'], "argument --rate: 'nan' is not a finite number"),
    (['--rate', '1e999'], 'beyond +-1.8e308'),
    (['--rate', '-5'], '--rate = -5: must be a positive rate'),
    (['--max-steps', '0'], "'0' is not a positive integer"),
])
def test_simulate_rates_are_checked_before_any_work(tmp_path, capsys, args, needle):
    path = profile(tmp_path, 'time,power\n0,1\n10,0\n')
    assert_refused(run(SIMULATE + [path] + args, capsys), needle)


def test_statics_shape_into_a_missing_directory_is_refused(tmp_path, capsys):
    target = str(tmp_path / 'missing' / 'shape.csv')
    assert_refused(run(['statics', '--config', 'conical', '--shape', target], capsys),
                   '--shape', 'does not exist')


@pytest.mark.parametrize('args, needle', [
    (['--tmax', '1e308', '--tstep', '1e307'], 'allowed -273.15 to 1000 degC'),
    (['--tmin', '-300'], 'allowed -273.15 to 1000 degC'),
    (['--mass', '1e308'], '--mass = 1e+308 kg: allowed 0 to'),
    (['--mass', '-1'], '--mass = -1 kg: allowed 0 to'),
    (['--tstep', 'nan'], "argument --tstep: 'nan' is not a finite number"),
])
def test_statics_arguments_are_checked_before_any_work(capsys, args, needle):
    assert_refused(run(['statics', '--model', 'cst'] + args, capsys), needle)


# -- item 8: hangs --------------------------------------------------------------------
def test_one_bad_last_timestamp_is_refused_before_resampling(tmp_path, capsys):
    times = [0.1 * i for i in range(29)] + [1e6]
    assert_refused(run(['diagnose', record(tmp_path, times=times), '--quiet'], capsys),
                   "row 34, column 'time'", '--max-samples')


@pytest.mark.parametrize('rate', [1e-3, 1e-6])
def test_very_slow_headers_are_refused(tmp_path, capsys, rate):
    assert_refused(run(['diagnose', record(tmp_path, rate=rate), '--quiet'], capsys),
                   '--max-steps')


def test_the_steps_limit_of_diagnose_counts_all_records_together(tmp_path, capsys):
    # each fit simulates every record: N short records cost N times one, so the bound is on
    # their sum (2.9 s at 200 Hz physics = 580 steps each)
    one = record(tmp_path, name='a.csv')
    two = record(tmp_path, name='b.csv')
    assert_refused(run(['diagnose', one, two, '--quiet', '--max-steps', '1000'], capsys),
                   'b.csv: with the records before it, 1160 physics steps',
                   'the limit is 1000 (--max-steps)')


def test_long_profile_and_fast_physics_are_refused(tmp_path, capsys):
    long = profile(tmp_path, 'time,power\n0,1\n100000,0\n')
    assert_refused(run(SIMULATE + [long], capsys), '1e+05 s', '--max-samples')
    assert_refused(run(SIMULATE + [long, '--rate', '1'], capsys), '1e+05 s', '--max-steps')
    assert_refused(run(['statics', '--model', 'cst', '--tstep', '1e-9'], capsys),
                   '--max-samples')


def test_conical_statics_have_a_lower_limit_of_their_own(capsys):
    # a rod shape per temperature costs ~0.1 s: 1351 of them would run for minutes
    assert_refused(run(['statics', '--config', 'conical', '--tstep', '0.1'], capsys),
                   '1351 rod shapes (conical)', f'the limit is {MAX_CONICAL_SHAPES}',
                   '--max-samples')
    # the helix limit is unchanged, and an explicit --max-samples applies to both
    assert_refused(run(['statics', '--config', 'conical', '--tstep', '0.1', '--max-samples',
                        '1000'], capsys), 'the limit is 1000')


def test_limits_are_overridable(tmp_path, capsys):
    path = profile(tmp_path, 'time,power\n0,1\n3,0\n')
    assert_refused(run(SIMULATE + [path, '--max-steps', '2000'], capsys), '--max-steps')
    code, out, _, _ = run(SIMULATE + [path, '--max-steps', '3000'], capsys)
    assert code == 0 and len(out.splitlines()) == 302


# -- item 9: exit codes and garbage accepted -------------------------------------------
def test_non_utf8_profile_names_file_and_row(tmp_path, capsys):
    path = profile(tmp_path, b'time,power\n0,1\n1,\xff\n')
    assert_refused(run(SIMULATE + [path], capsys), path, 'row 3', 'not UTF-8')


def test_non_utf8_record_names_row(tmp_path, capsys):
    path = tmp_path / 'rec.csv'
    text = pathlib.Path(record(tmp_path)).read_bytes().replace(b'0.2943', b'0.29\xe43', 1)
    path.write_bytes(text)
    assert_refused(run(['diagnose', str(path), '--quiet'], capsys), 'row 5', 'not UTF-8')


@pytest.mark.parametrize('row, needle', [
    ('0,1e308', f'allowed 0 to {MAX_POWER_W:g} W'),
    ('0,-1e308', "column 'power'"),
    ('0,-0.5', "column 'power': -0.5 W is out of range"),
    ('0,1,1e308', "column 'load': 1e+308 N is out of range"),
    ('0,1_000', "'1_000' is not a number"),
    ('0,\uff11', 'is not a number'),  # fullwidth 1
    ('0,\u0661', 'is not a number'),  # Arabic-Indic 1
    ('0,0x10', 'is not a number'),
])
def test_out_of_range_and_non_ascii_numbers_are_refused(tmp_path, capsys, row, needle):
    cols = 'time,power,load' if row.count(',') == 2 else 'time,power'
    extra = ',0' if row.count(',') == 2 else ''
    text = f'{cols}\n{row}\n1,0{extra}\n'
    assert_refused(run(SIMULATE + [profile(tmp_path, text)], capsys), 'row 2', needle)


def test_repeated_column_is_refused(tmp_path, capsys):
    path = profile(tmp_path, 'time,power,power\n0,1,1\n1,0,0\n')
    assert_refused(run(SIMULATE + [path], capsys), "column 'power' appears twice")


def test_byte_order_mark_is_accepted(tmp_path, capsys):
    path = profile(tmp_path, b'\xef\xbb\xbftime,power\n0,1\n1,0\n')
    code, out, err, _ = run(SIMULATE + [path, '--rate', '10'], capsys)
    assert code == 0 and len(out.splitlines()) == 12, err
    rec = record(tmp_path, prefix=b'\xef\xbb\xbf', name='bom.csv')
    from tca_ros.records.data import read_record
    assert read_record(rec).meta['tca'] == 'free_stroke'


def test_a_megabyte_value_is_not_echoed(tmp_path, capsys):
    path = tmp_path / 'rec.csv'
    text = pathlib.Path(record(tmp_path)).read_text().replace('0.2943', 'x' * 1_000_000, 1)
    path.write_text(text)
    assert_refused(run(['diagnose', str(path), '--quiet'], capsys), 'row 5')
    bad = 'time,power\n0,' + 'y' * 3000 + '\n1,0\n'
    assert_refused(run(SIMULATE + [profile(tmp_path, bad)], capsys), "'yyyy", '...')


@pytest.mark.parametrize('mass', ['5e-324', '1e-9', '1e308'])
def test_a_record_mass_the_model_cannot_step_is_refused(tmp_path, capsys, mass):
    # fuzz_cli case 874: '# mass_kg: 4.94e-324' passed the reader, then the nominal
    # simulation refused it (> 1000 substeps) with exit 1
    path = tmp_path / 'rec.csv'
    path.write_text(pathlib.Path(record(tmp_path)).read_text().replace(
        '# mass_kg: 0.03', f'# mass_kg: {mass}'))
    assert_refused(run(['diagnose', str(path), '--quiet'], capsys), "row 2, column 'mass_kg'",
                   'allowed 0 (quasi-static) or 1e-06 to 1000 kg')


@pytest.mark.parametrize('old, new, column', [
    ('0.5,0.2943', '1e308,0.2943', 'power'), ('0.5,0.2943', '0.5,1e308', 'load'),
    (',25.30', ',-300', 'temperature'),
    # fuzz_cli case 144: a reading of 1e308 degC passed and made the fit fail (exit 1)
    (',25.30', ',1e308', 'temperature'), (',25.30', ',1001', 'temperature'),
    (',0.000300,', ',1e308,', 'displacement'), (',0.000300,', ',-11,', 'displacement'),
])
def test_record_values_out_of_range_are_refused(tmp_path, capsys, old, new, column):
    path = tmp_path / 'rec.csv'
    path.write_text(pathlib.Path(record(tmp_path)).read_text().replace(old, new, 1))
    assert_refused(run(['diagnose', str(path), '--quiet'], capsys), f'column {column!r}',
                   'out of range (allowed')


def test_config_that_cannot_lose_heat_never_prints_nan(tmp_path, capsys):
    text = (pathlib.Path(config_dir()) / 'free_stroke.yaml').read_text()
    assert 'convection_coefficient' in text
    lines = [line if 'convection_coefficient' not in line else
             line.split(':')[0] + ': 0.0' for line in text.splitlines()]
    config = tmp_path / 'cold.yaml'
    config.write_text('\n'.join(lines) + '\n')
    path = profile(tmp_path, 'time,power\n0,1\n2,0\n')
    code, out, err, _ = run(SIMULATE + [path, '--config', str(config)], capsys)
    assert code in (1, 2) and err.count('\n') == 1, (code, err)
    assert 'nan' not in out.lower()


# -- item 10: MCAP ---------------------------------------------------------------------
def test_garbage_mcap_beside_a_valid_bag_is_refused(tmp_path, capsys):
    from test_diagnosis_bag import write_stamped_bag
    bag = tmp_path / 'bag'
    write_stamped_bag(bag)
    other = bag / 'other.mcap'
    other.write_bytes(b'garbage ' * 100)
    assert_refused(run(['diagnose', str(other), '--config', 'free_stroke', '--quiet'],
                       capsys), 'other.mcap', 'not a readable rosbag2 recording')


# -- item 11: the record's config header -----------------------------------------------
@pytest.mark.parametrize('tca', ['../../../../etc/passwd', '/etc/passwd', '..', 'sub/x'])
def test_record_header_cannot_name_an_arbitrary_path(tmp_path, capsys, tca):
    assert_refused(run(['diagnose', record(tmp_path, tca=tca), '--quiet'], capsys),
                   "row 1, column 'tca'", 'pass --config PATH')


@pytest.mark.parametrize('config', ['sub/free_stroke', 'missing_dir/free_stroke.yaml',
                                    '/nonexistent/conical.yaml'])
def test_a_missing_path_is_not_read_as_the_shipped_config(tmp_path, capsys, config):
    # found by bench/fuzz_cli.py: the basename of any missing path fell back to a shipped
    # file, so a mistyped directory silently ran the shipped parameters
    path = profile(tmp_path, 'time,power\n0,1\n1,0\n')
    assert_refused(run(SIMULATE + [path, '--config', config], capsys),
                   f"config '{config}': no such file, and not a shipped name")
    assert_refused(run(['diagnose', record(tmp_path), '--quiet', '--config', config], capsys),
                   'not a shipped name')


def test_record_header_may_name_a_params_file_beside_it(tmp_path):
    from tca_ros.records.data import read_record, record_config
    shutil.copy(pathlib.Path(config_dir()) / 'free_stroke.yaml', tmp_path / 'mine.yaml')
    rec = read_record(record(tmp_path, tca='mine'))
    assert record_config(rec) == str(tmp_path / 'mine.yaml')
    assert record_config(read_record(record(tmp_path, tca='conical'))) == 'conical'


def test_a_conical_config_with_a_helix_model_is_bad_input(tmp_path, capsys):
    """fuzz_cli case 178: exit 1 from deep in the model; now refused at load, exit 2."""
    path = profile(tmp_path, 'time,power\n0,1\n1,0\n')
    assert_refused(run(SIMULATE + [path, '--config', 'conical', '--model', 'cst'], capsys),
                   "parameter 'model' = 'cst': a conical TCA needs the rod model")
