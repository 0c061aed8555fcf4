"""Records of a rig with a force gauge (isometric tests): the force column is read."""
import numpy as np
import pytest

from tca_ros.model.rig_simulation import simulate_rig
from tca_ros.params.files import load_params
from tca_ros.records.data import DataError, read_record, Record, write_csv_record


def test_isometric_record_with_a_force_column_round_trips(tmp_path):
    params = load_params('free_stroke', model='cst', **{'rig.mode': 'isometric'})
    t = np.arange(0.0, 6.0, 0.1)
    out = simulate_rig(params, t, np.where(t < 3.0, 1.0, 0.0)).columns
    rec = Record(time=t, power=out['power'], load=np.zeros_like(t),
                 displacement=np.zeros_like(t), temperature=out['temperature'],
                 force=out['force'],
                 meta={'tca': 'free_stroke', 'mass_kg': 0.0, 'sample_rate_hz': 10.0})
    path = tmp_path / 'isometric.csv'
    write_csv_record(rec, str(path))
    assert path.read_text().splitlines()[3] == \
        'time,power,load,displacement,temperature,force'
    back = read_record(str(path))
    np.testing.assert_allclose(back.force, out['force'], atol=1e-6)  # written to 1 uN
    assert back.force.max() > 0.1 and back.resistance is None  # 0.05 N heated 3 s


def test_force_out_of_range_names_row_and_column(tmp_path):
    lines = ['# tca: free_stroke', '# mass_kg: 0', '# sample_rate_hz: 10',
             'time,power,load,displacement,force']
    lines += [f'{0.1 * i:.1f},0.5,0,0,{0.05 if i != 7 else 2e6}' for i in range(25)]
    path = tmp_path / 'bad.csv'
    path.write_text('\n'.join(lines) + '\n')
    with pytest.raises(DataError, match=r"row 12, column 'force': 2e\+06 N is out of range"):
        read_record(str(path))


def test_a_written_record_keeps_its_conditions(tmp_path):
    # rig, environment, pretension: header entries a writer must not drop
    t = np.arange(40) / 5.0
    meta = {'tca': 'free_stroke', 'mass_kg': 0.01, 'sample_rate_hz': 5.0,
            'environment': 'forced_air', 'rig': 'spring', 'spring_stiffness_n_per_m': 50.0}
    record = Record(time=t, power=np.where(t > 2.0, 1.0, 0.0), load=np.full_like(t, 0.1),
                    displacement=np.zeros_like(t), meta=meta, source='x')
    path = tmp_path / 'run.csv'
    write_csv_record(record, str(path), comments=['environment: water', 'synthetic: yes'])
    back = read_record(str(path)).meta
    assert back['rig'] == 'spring' and float(back['spring_stiffness_n_per_m']) == 50.0
    assert back['environment'] == 'water'  # a comment of that key takes its place
    assert path.read_text().count('environment:') == 1
