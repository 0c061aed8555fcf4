"""`tca_sim simulate` on each load rig (--rig or rig.mode of the params file)."""
import io

import numpy as np

from tca_ros.cli.main import main
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.rig_statics import isometric_force
from tca_ros.params.files import load_params


def _run(tmp_path, text, *options):
    path = tmp_path / 'profile.csv'
    path.write_text(text)
    out = io.StringIO()
    code = main(['simulate', '--model', 'cst', '--input', str(path), '--rate', '2',
                 *options], out=out)
    lines = out.getvalue().strip().splitlines()
    rows = np.array([[float(v) for v in line.split(',')] for line in lines[1:]]) \
        if code == 0 else None
    return code, (lines[0].split(',') if lines else []), rows


def test_spring_rig_prints_the_tca_force_on_the_spring_line(tmp_path):
    code, names, rows = _run(tmp_path, 'time,power\n0,1.0\n15,1.0\n', '--rig', 'spring')
    assert code == 0
    assert names == ['time', 'power', 'load', 'displacement', 'temperature', 'resistance',
                     'force']
    col = dict(zip(names, rows.T))
    assert np.all(col['load'] == 0.05)  # the pretension F_0 (rig.pretension)
    # F = F_0 + k_s x, up to the damping force b_t x' (0.5 N s/m x <= 0.8 mm/s while
    # heating, 1e-5 N once T settles at 15 s)
    line = 0.05 + 20.0 * col['displacement']
    np.testing.assert_allclose(col['force'], line, atol=5e-4)
    np.testing.assert_allclose(col['force'][-1], line[-1], atol=2e-5)
    assert col['displacement'][-1] > 3e-3


def test_isometric_rig_prints_the_force_of_the_clamped_muscle(tmp_path, capsys):
    code, names, rows = _run(tmp_path, 'time,power\n0,0.5\n20,0.5\n', '--rig', 'isometric')
    assert code == 0
    assert names == ['time', 'power', 'temperature', 'resistance', 'force']
    col = dict(zip(names, rows.T))
    km = make_kinetostatic_model(load_params('free_stroke', model='cst'))
    np.testing.assert_allclose(col['force'][-1],
                               isometric_force(km, col['temperature'][-1], 0.05), rtol=1e-5)
    # a load column has no meaning on a clamped muscle: one line, exit status 2
    code, _, _ = _run(tmp_path, 'time,power,load\n0,0.5,0.1\n2,0.5,0.1\n', '--rig',
                      'isometric')
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "unknown column 'load' (allowed time,power)" in err


def test_antagonistic_rig_reads_one_power_per_muscle(tmp_path):
    text = 'time,power,power_2\n0,1.0,0.0\n10,0.0,1.0\n20,0.0,1.0\n'
    code, names, rows = _run(tmp_path, text, '--rig', 'antagonistic')
    assert code == 0
    col = dict(zip(names, rows.T))
    assert names[:6] == ['time', 'power', 'power_2', 'angle', 'angular_velocity', 'torque']
    assert col['angle'][20] > 0.2  # the agonist heated first turns the joint positive
    assert col['angle'][-1] < -0.2  # then the antagonist turns it back past zero
    assert col['temperature_2'][20] == 25.0 and col['temperature'][-1] < 40.0
