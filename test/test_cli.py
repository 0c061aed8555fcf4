"""`tca_sim` statics / simulate / bench and its input errors."""
import io

import numpy as np
import pytest

from tca_ros.cli.main import main, read_profile


def run(argv):
    out = io.StringIO()
    code = main(argv, out=out)
    return code, out.getvalue()


def test_statics_prints_contraction_from_tmin():
    code, text = run(['statics', '--config', 'free_stroke', '--model', 'cst', '--mass',
                      '0.03', '--tmin', '25', '--tmax', '160', '--tstep', '45'])
    assert code == 0
    lines = text.strip().splitlines()
    assert lines[0] == 'temperature,displacement'
    values = np.array([[float(v) for v in line.split(',')] for line in lines[1:]])
    np.testing.assert_allclose(values[:, 0], [25, 70, 115, 160])
    assert values[0, 1] == 0.0 and np.all(np.diff(values[:, 1]) > 0.0)
    assert 0.015 < values[-1, 1] < 0.035  # tens of mm at 160 degC (Fig. 10c)


def _profile(tmp_path, text):
    path = tmp_path / 'profile.csv'
    path.write_text(text)
    return str(path)


def test_simulate_profile(tmp_path):
    rows = ['time,power,load'] + [f'{t:.1f},{1.0 if t < 2 else 0.0},0.2943'
                                  for t in np.arange(0, 4.01, 0.5)]
    code, text = run(['simulate', '--model', 'cst', '--input',
                      _profile(tmp_path, '\n'.join(rows)), '--rate', '10'])
    assert code == 0
    lines = text.strip().splitlines()
    assert lines[0] == 'time,power,load,displacement,temperature,resistance'
    data = np.array([[float(v) for v in line.split(',')] for line in lines[1:]])
    assert data.shape == (41, 6)
    assert data[20, 4] > 40.0 and data[-1, 4] < data[20, 4]  # heats, then cools
    assert data[0, 3] == 0.0 and data[20, 3] > 0.0


@pytest.mark.parametrize('text, needle', [
    ('time,pwr\n0,1\n1,1\n', "row 1: missing column 'power'"),
    ('time,power,volts\n0,1,1\n1,1,1\n', "row 1: unknown column 'volts'"),
    ('time,power\n0,1\n1,abc\n', "row 3, column 'power': 'abc' is not a number"),
    ('time,power\n0,1\n1,nan\n', "row 3, column 'power': 'nan' is not finite"),
    ('time,power\n0,1\n2,1\n1,1\n', "row 4, column 'time': 1 s is not after 2 s"),
    ('time,power,load\n0,1,-1\n1,1,0\n', "row 2, column 'load': -1 N is compressive"),
    ('time,power\n0,1\n1\n', 'row 3: 1 fields, expected 2'),
])
def test_bad_profile_is_one_line_error_exit_2(tmp_path, capsys, text, needle):
    code, _ = run(['simulate', '--model', 'cst', '--input', _profile(tmp_path, text)])
    err = capsys.readouterr().err
    assert code == 2
    assert needle in err and err.count('\n') == 1


def test_bad_config_and_arguments_exit_2(tmp_path, capsys):
    assert run(['statics', '--config', 'nope'])[0] == 2
    assert "config 'nope'" in capsys.readouterr().err
    assert run(['statics', '--model', 'cst', '--tstep', '0'])[0] == 2
    assert '--tstep = 0' in capsys.readouterr().err
    assert run(['simulate', '--model', 'cst', '--input', str(tmp_path / 'none.csv')])[0] == 2
    assert 'cannot open' in capsys.readouterr().err


def test_read_profile_without_load(tmp_path):
    t, p, load = read_profile(_profile(tmp_path, '# comment\ntime,power\n0,0.5\n1,0.25\n'))
    assert load is None and t.tolist() == [0.0, 1.0] and p.tolist() == [0.5, 0.25]


def test_bench_prints_a_row_per_model():
    code, text = run(['bench', '--seconds', '0.2'])
    assert code == 0
    rows = [line.split()[0] for line in text.splitlines() if not line.startswith('#')][1:]
    assert {'cst', 'love'} <= set(rows)


def test_conical_statics_end_passes_the_clamp_and_writes_shapes(tmp_path):
    shape = tmp_path / 'shape.csv'
    code, text = run(['statics', '--config', 'conical', '--tstep', '67.5',
                      '--shape', str(shape)])
    assert code == 0
    rows = [line.split(',') for line in text.strip().splitlines()]
    assert rows[0] == ['temperature', 'end_height']
    heights = [float(r[1]) for r in rows[1:]]
    assert len(heights) == 3 and heights[0] < -0.05 and heights[-1] > 0.0  # dual-side stroke
    lines = shape.read_text().splitlines()
    assert lines[0] == 'temperature,s,x,y,z'
    assert {float(line.split(',')[0]) for line in lines[1:]} == {25.0, 92.5, 160.0}
    assert (tmp_path / 'shape.png').stat().st_size > 10000


def test_conical_needs_rod_and_shape_needs_conical(capsys):
    assert run(['statics', '--config', 'conical', '--model', 'cst'])[0] == 2
    assert 'needs the rod model' in capsys.readouterr().err
    assert run(['statics', '--model', 'cst', '--shape', 'x.csv'])[0] == 2
    assert 'only for a conical TCA' in capsys.readouterr().err
