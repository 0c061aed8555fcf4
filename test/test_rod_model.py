"""Tests of the 'rod' kinetostatic model, its table and the shape functions."""
import math

import numpy as np
import pytest

from tca_ros.model.conical import conical_end_height, conical_shapes
from tca_ros.model.kinetostatic_models import centreline, make_kinetostatic_model
from tca_ros.model.rod_model import rod_statics_sweep, RodKinetostatics
from tca_ros.model.rod_model import solution_elongation
from tca_ros.params.files import load_params


@pytest.fixture(scope='module')
def rod(free_stroke):
    return RodKinetostatics(free_stroke)


def test_factory_builds_rod(free_stroke):
    model = make_kinetostatic_model(free_stroke, 'rod')
    assert isinstance(model, RodKinetostatics) and model.name == 'rod'


def test_small_load_stiffness_equals_cst(free_stroke, rod):
    cst = make_kinetostatic_model(free_stroke, 'cst')
    k_rod = rod.stiffness(0.0, 25.0)
    assert k_rod == pytest.approx(22.52, abs=0.01)  # paper notes figure
    assert k_rod == pytest.approx(cst.stiffness(0.0, 25.0), rel=0.01)  # issue 3 item 6


@pytest.mark.parametrize('name, load', [('free_stroke', 0.59), ('self_coiled', 1.96)])
def test_table_error_below_a_thousandth_of_stroke(name, load):
    """Table f_rod vs exact solve, as a displacement error, over 25-160 degC."""
    params = load_params(name)
    model = RodKinetostatics(params)
    stroke = abs(model.equilibrium_elongation(load, 25.0)
                 - model.equilibrium_elongation(load, 160.0))
    rng = np.random.default_rng(7)
    worst = 0.0
    for temp, force in zip(rng.uniform(25.0, 160.0, 40), rng.uniform(-0.2, load, 40)):
        y = model.equilibrium_elongation(force, temp)  # exact helix at F
        y_table = y + (force - model.tension(y, temp)) / model.stiffness(y, temp)
        worst = max(worst, abs(y_table - y))
    assert worst <= 1e-3 * stroke  # issue 3 item 4 (measured ~2e-4 of the stroke)


def test_direct_tension_matches_table(rod):
    for y, temp in ((0.005, 40.0), (0.02, 150.0), (-0.01, 90.0)):
        assert rod.tension(y, temp) == pytest.approx(rod.direct_tension(y, temp),
                                                     abs=2e-4)  # N, ~10 um at 22 N/m


def test_stiffness_is_derivative_of_tension(rod):
    h = 1e-6  # m, central difference of a C1 Hermite table
    for y, temp in ((0.004, 60.0), (0.015, 130.0)):
        fd = (rod.tension(y + h, temp) - rod.tension(y - h, temp)) / (2 * h)
        assert rod.stiffness(y, temp) == pytest.approx(fd, rel=1e-4)
        assert rod.stiffness(y, temp) > 0.0


def test_equilibrium_elongation_inverts_tension(rod):
    y = rod.equilibrium_elongation(0.3, 120.0)
    assert rod.tension(y, 120.0) == pytest.approx(0.3, abs=1e-4)  # table accuracy (N)
    assert rod.free_elongation(120.0) < 0.0  # hot and unloaded: contracts


def test_rotation_locked_variant_is_stiffer(free_stroke):
    locked = RodKinetostatics(free_stroke, rotation_locked=True)
    assert locked.stiffness(0.0, 25.0) == pytest.approx(25.19, abs=0.01)  # paper notes


def test_bvp_sweep_matches_table_model(free_stroke, rod):
    """Algorithm 1 on the full 63-coil rod vs the exact-helix model (end layers only)."""
    temps = [25.0, 90.0, 160.0]
    sols = rod_statics_sweep(free_stroke, 0.3, temps)
    assert all(s.success for s in sols)
    stroke = rod.equilibrium_elongation(0.3, 25.0) - rod.equilibrium_elongation(0.3, 160.0)
    for temp, sol in zip(temps, sols):
        y_bvp = solution_elongation(free_stroke, sol)
        assert y_bvp == pytest.approx(rod.equilibrium_elongation(0.3, temp),
                                      abs=3e-3 * stroke)  # end layers, measured 1.5e-3


def test_centreline_shape_and_length(free_stroke, rod):
    xyz = centreline(free_stroke, 0.01, 90.0, 300)
    assert xyz.shape == (3, 300)
    assert xyz[2, 0] == 0.0
    assert -xyz[2, -1] == pytest.approx(rod.natural_length + 0.01, abs=1e-6)


def test_non_helix_is_rejected():
    with pytest.raises(ValueError, match='coil.shape'):
        RodKinetostatics(load_params('conical'))


def test_conical_shapes_and_end_height():
    params = load_params('conical')
    shapes = conical_shapes(params, [25.0, 160.0])
    s, xyz = shapes[0]
    assert xyz.shape == (3, s.size) and s[-1] == pytest.approx(params.fiber.length)
    # At ambient the shape is the spiral (36): end height z(l_t) from Eq. (37) inverted.
    a = 2 * math.pi / params.coil.spiral_pitch
    b = math.tan(0.5 * params.coil.cone_angle)
    r_end = math.hypot(xyz[0, -1], xyz[1, -1])
    assert r_end == pytest.approx(-b * xyz[2, -1], rel=0.025)  # on the cone: 16 steps/turn
    del a
    heights = conical_end_height(params, [25.0, 100.0, 160.0])
    assert heights[0] < heights[1] < heights[2]  # heating untwists: the end rises


def test_loaded_conical_converges_and_sags():
    """A 1 mN end load on the compliant conical coil (18 mm sag) still converges."""
    params = load_params('conical')
    free = conical_end_height(params, [60.0])
    loaded = conical_end_height(params, [60.0], load=1e-3)
    assert np.all(loaded < free - 1e-3)  # at least 1 mm lower under the load


def test_conical_centreline_is_the_no_load_shape():
    params = load_params('conical')
    xyz = centreline(params, 0.0, 25.0, 2000)
    (s, ref_xyz), = conical_shapes(params, [25.0])
    assert xyz.shape == (3, 2000)
    assert xyz[2, -1] == pytest.approx(ref_xyz[2, -1], abs=1e-4)  # two meshes, O(ds^2)
