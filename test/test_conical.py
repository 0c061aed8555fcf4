"""The conical TCA hanging from its apex clamp (issue 11, items 1 and 6).

Statics with a weight (height-controlled rod branches), the orientation against
gravity, the dynamics table against the statics, the CLI, and the numbers of the
docs figure (bench/plot_conical.py, docs/fig_conical.csv).
"""
import csv
import importlib.util
import pathlib

import numpy as np
import pytest

from tca_ros.cli.main import main
from tca_ros.model.conical import conical_end_height, HANGING, hanging_statics
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.simulation import simulate
from tca_ros.params.files import load_params

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCRIPT = ROOT / 'bench' / 'plot_conical.py'
_spec = importlib.util.spec_from_file_location('plot_conical', SCRIPT)
plot_conical = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(plot_conical)
TWO_GRAMS = 0.002 * 9.81  # N


@pytest.fixture(scope='module')
def conical():
    return load_params('conical')


@pytest.fixture(scope='module')
def loaded_25(conical):
    """The equilibrium under 2 g at 25 degC (followed from no load)."""
    return hanging_statics(conical, TWO_GRAMS, [25.0])[0]


def _figure_rows():
    with open(ROOT / 'docs' / 'fig_conical.csv', encoding='utf-8') as fh:
        return list(csv.DictReader(fh))


def test_the_weight_hangs_below_the_apex_clamp(conical, loaded_25):
    """The cone hangs from its apex: the weight pulls the end down, world Z up."""
    free = conical_end_height(conical, [25.0, 160.0])
    assert -0.064 < free[0] < -0.062  # unloaded: 63 mm below the clamp
    assert free[1] > 0.08  # heated, the coils pass each other: the end is above it
    sol = loaded_25.solution
    force = HANGING @ sol.end_force()  # the external force on the end, world frame
    np.testing.assert_allclose(force, [0.0, 0.0, -TWO_GRAMS], atol=1e-8)  # the weight, down
    shape = HANGING @ sol.positions
    np.testing.assert_allclose(shape[:, 0], 0.0, atol=1e-12)  # the apex clamp
    assert shape[2, -1] == pytest.approx(-loaded_25.drop)
    assert -loaded_25.drop < free[0] - 0.03  # 2 g stretch the soft cone by 40 mm
    assert np.all(shape[2, 1:] < 0.0)  # the whole coil below the clamp


def test_the_dynamics_table_matches_the_statics(conical, loaded_25):
    model = make_kinetostatic_model(conical)
    assert model.natural_length == pytest.approx(-conical_end_height(conical, [25.0])[0],
                                                 abs=1e-9)
    y = model.equilibrium_elongation(TWO_GRAMS, 25.0)
    assert y + model.natural_length == pytest.approx(loaded_25.drop, abs=2e-5)
    assert model.stiffness(y, 25.0) > 0.0
    np.testing.assert_allclose(model.tension(y, 25.0), TWO_GRAMS, rtol=1e-9)


def test_dynamics_rests_at_the_statics_and_contracts_when_heated(conical):
    time = np.arange(0.0, 3.01, 0.5)
    rest = simulate(conical, time, np.zeros_like(time), np.full_like(time, TWO_GRAMS))
    np.testing.assert_allclose(rest.displacement, 0.0, atol=1e-12)
    np.testing.assert_allclose(rest.tension, TWO_GRAMS, rtol=1e-9)
    heated = simulate(conical, time, np.full_like(time, 0.1))
    assert np.all(np.diff(heated.displacement) > 0.0)  # the end rises (contraction)
    assert heated.temperature[-1] < 35.0  # within the rows the other tests build


def test_cli_statics_with_a_weight_from_70_to_100_degc(capsys):
    """2 g at 70-100 degC (issue 11: a traceback before), and a load over the break."""
    assert main(['statics', '--config', 'conical', '--mass', '0.002', '--tmin', '70',
                 '--tmax', '100', '--tstep', '30']) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == 'temperature,end_height' and len(out) == 3
    heights = [float(line.split(',')[1]) for line in out[1:]]
    assert all(-0.11 < h < -0.08 for h in heights)
    assert main(['statics', '--config', 'conical', '--mass', '0.3', '--tmin', '25',
                 '--tmax', '25']) == 1
    err = capsys.readouterr().err
    assert 'exceeds fiber.break_force 2.354 N: the thread breaks' in err
    assert err.count('\n') == 1


def test_figure_numbers_are_the_models(conical, loaded_25):
    """docs/fig_conical.csv (quoted in docs/rod.md) against cheap recomputations."""
    rows = _figure_rows()
    statics = {(float(r['mass_or_time']), float(r['temperature'])): float(r['end_height'])
               for r in rows if r['kind'] == 'statics'}
    free = conical_end_height(conical, [25.0, 100.0, 160.0])
    for temp, height in zip((25.0, 100.0, 160.0), free):
        assert statics[0.0, temp] == pytest.approx(height, abs=1e-7)
    assert statics[0.002, 25.0] == pytest.approx(-loaded_25.drop, abs=1e-6)
    assert statics[0.0, 25.0] == pytest.approx(-0.0632, abs=5e-5)  # quoted: -63.2 mm
    assert statics[0.0, 160.0] == pytest.approx(0.0861, abs=5e-5)  # quoted: +86.1 mm
    dynamic = [(float(r['mass_or_time']), float(r['temperature']), float(r['end_height']))
               for r in rows if r['kind'] == 'dynamic']
    time, temp, height = plot_conical.dynamic_case(total=2.0)  # stays below 35 degC
    for k in range(time.size):
        assert dynamic[k][0] == pytest.approx(time[k])
        assert dynamic[k][1] == pytest.approx(temp[k], abs=1e-6)
        assert dynamic[k][2] == pytest.approx(height[k], abs=1e-8)  # %.6e in the CSV


def test_rows_persist_in_the_params_layers_store(conical, tmp_path, monkeypatch):
    """The model solves a row; tca_ros.params.row_cache keeps it on disk, read back bit for bit."""
    from tca_ros.model import conical_table
    from tca_ros.model.rod_model import mechanical_params
    from tca_ros.params.row_cache import DiskRowStore
    assert isinstance(conical_table._default_store, DiskRowStore)  # installed by tca_ros.params
    store = DiskRowStore(str(tmp_path))
    solved = conical_table.ConicalTable(mechanical_params(conical), store=store).row(0)
    assert len(list(tmp_path.glob('conical_*_000.npz'))) == 1

    def no_solve(*args):
        raise AssertionError('row solved again instead of read from the store')
    monkeypatch.setattr(conical_table, 'build_row', no_solve)
    read = conical_table.ConicalTable(mechanical_params(conical), store=store).row(0)
    for name, value in solved.__dict__.items():
        assert np.array_equal(getattr(read, name), value), name
