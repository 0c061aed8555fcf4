"""The crept reference state (issue 11, item 2; Sec. V-D1 of the paper; docs D6).

Off by default (Table III's 22.42 deg for every load). On, the rest pitch angle
follows sin a*(F) = sin a_c - (sin a_c - sin a_0) exp(-F/F_c) with the coil count
kept; the numbers of docs/fig_crept_reference.png (bench/plot_crept_reference.py)
are pinned here.
"""
import io
import math

import numpy as np
import pytest

from tca_ros.cli.main import main
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import contact_elongation
from tca_ros.model.params_schema import GRAVITY, ParameterError
from tca_ros.model.reference_state import crept_pitch_angle, crept_under
from tca_ros.model.simulation import static_displacement
from tca_ros.model.tca_params import to_flat_dict
from tca_ros.params.files import dump_params

#: The authors' TCA_geo.m: rest pitch angle (deg) looked up by hanging mass (kg).
AUTHORS_TABLE = {0.0: 15.0, 0.002: 16.0, 0.030: 20.0, 0.060: 22.0}
#: docs/fig_crept_reference.png: contraction at 160 degC (mm) and the temperature (degC)
#: from which the coils touch (None: not by 160 degC), rod model, 25-160 degC.
FIGURE = {  # (crept, mass kg): (alpha* deg, x(160) mm, contact onset)
    (False, 0.002): (22.42, 24.70, None),
    (False, 0.030): (22.42, 24.41, None),
    (False, 0.060): (22.42, 19.04, None),
    (True, 0.002): (15.57, 11.58, 110.0),
    (True, 0.030): (20.21, 25.23, None),
    (True, 0.060): (21.77, 19.21, None),
}


@pytest.fixture(scope='module')
def crept(free_stroke):
    return free_stroke.with_values(**{'coil.crept_reference': True})


def test_off_by_default_every_load_uses_table_iii(free_stroke):
    assert not free_stroke.coil.crept_reference
    for load in (0.0, 0.0196, 0.5886):
        p = free_stroke.with_values(**{'dynamics.load': load})
        assert math.degrees(p.coil.pitch_angle) == pytest.approx(22.42)
        assert p.coil.radius == 0.408e-3
        assert crept_under(p, 0.3) is p


def test_the_law_follows_the_authors_table_to_half_a_degree(crept):
    """Defaults a_0 = 15 deg, F_c = 0.24 N: within 0.43 deg of 15/16/20/22 deg."""
    errors = [math.degrees(crept_pitch_angle(mass * GRAVITY, crept.coil)) - angle
              for mass, angle in AUTHORS_TABLE.items()]
    assert max(map(abs, errors)) == pytest.approx(0.428, abs=0.001)
    assert errors[0] == pytest.approx(0.0, abs=1e-12)  # a_0 exactly at no load
    heavy = math.degrees(crept_pitch_angle(100.0, crept.coil))
    assert heavy == pytest.approx(22.42, abs=1e-9)  # a heavily crept coil: as coiled


def test_the_crept_reference_keeps_the_coil_count_and_the_file_values(crept):
    """r* cos a* is the same for every load (eq. (24)); a params file keeps a_c, r_c."""
    counts = []
    for mass in AUTHORS_TABLE:
        p = crept_under(crept, mass * GRAVITY)
        assert math.degrees(p.coil.pitch_angle) == pytest.approx(
            FIGURE.get((True, mass), (math.degrees(p.coil.pitch_angle),))[0], abs=0.005)
        counts.append(math.cos(p.coil.pitch_angle) / p.coil.radius)
        flat = to_flat_dict(p)
        assert flat['coil.pitch_angle_deg'] == pytest.approx(22.42)
        assert flat['coil.radius'] == 0.408e-3
    np.testing.assert_allclose(counts, counts[0], rtol=1e-12)


@pytest.mark.parametrize('crept_on, mass', sorted(FIGURE))
def test_fig10_numbers_for_both_readings(free_stroke, crept_on, mass):
    """Contraction at 160 degC to 0.01 mm (rounding of the figure's table)."""
    alpha, x160, onset = FIGURE[(crept_on, mass)]
    load = mass * GRAVITY
    p = crept_under(free_stroke.with_values(**{'coil.crept_reference': crept_on}), load)
    assert math.degrees(p.coil.pitch_angle) == pytest.approx(alpha, abs=0.005)
    temps = np.arange(25.0, 160.5, 5.0)
    x = static_displacement(p, load, temps, model='rod')
    assert 1e3 * x[-1] == pytest.approx(x160, abs=0.01)
    km = make_kinetostatic_model(p, 'rod')
    touching = [t for t in range(25, 161) if km.equilibrium_elongation(load, float(t))
                < contact_elongation(p)]
    assert (touching[0] if touching else None) == onset
    if onset is not None:  # contact-limited: the stroke stops there
        assert np.all(x[temps >= onset + 5.0] == x[-1])


def test_cli_statics_takes_the_reference_crept_under_its_mass(crept, tmp_path):
    path = tmp_path / 'crept.yaml'
    dump_params(crept, str(path))
    out = io.StringIO()
    code = main(['statics', '--config', str(path), '--model', 'rod', '--mass', '0.002',
                 '--tstep', '45'], out=out)
    assert code == 0
    last = out.getvalue().strip().splitlines()[-1].split(',')
    assert float(last[0]) == 160.0 and 1e3 * float(last[1]) == pytest.approx(11.58, abs=0.01)


def test_an_unloaded_angle_above_the_coiled_one_is_refused(crept):
    with pytest.raises(ParameterError) as info:
        crept.with_values(**{'coil.unloaded_pitch_angle_deg': 30.0})
    message = str(info.value)
    assert '\n' not in message
    assert "'coil.unloaded_pitch_angle_deg' = 30" in message
    assert 'at most coil.pitch_angle_deg (22.42)' in message
