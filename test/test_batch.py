"""The vectorised batch simulator (tca_ros.toolkit.batch) against TcaSimulator."""
from dataclasses import replace
import math

import numpy as np
import pytest

from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import contact_elongation
from tca_ros.model.resistance import power_from_voltage
from tca_ros.model.simulation import simulate
from tca_ros.model.tca_params import with_effects
from tca_ros.toolkit.batch import BatchSimulator, simulate_batch
from tca_ros.toolkit.batch_forces import cst_tension, MuscleArrays

# Same relations, same order of operations up to NumPy vs math rounding: the
# observed differences are 1e-15 m and 1e-13 ohm over thousands of steps.
DISPLACEMENT_TOL = 1e-12  # m
TEMPERATURE_TOL = 1e-9  # K
RESISTANCE_TOL = 1e-9  # ohm
TENSION_TOL = 1e-9  # N

TIME = np.arange(0.0, 2.0001, 0.01)  # s, 100 Hz samples, physics at 1 kHz
POWER = np.where(TIME < 1.2, 1.8, 0.0)  # W: heat 1.2 s, then cool


def muscles(free_stroke, self_coiled):
    """Six muscles that differ in load, mass, damping, thermal, geometry, effects."""
    heavy = replace(free_stroke, dynamics=replace(free_stroke.dynamics, mass=0.06,
                                                  load=0.5886, damping=0.8))
    windy = replace(free_stroke, thermal=replace(free_stroke.thermal,
                                                 convection_coefficient=30.0))
    early_contact = replace(free_stroke, coil=replace(free_stroke.coil,
                                                      min_pitch_angle=math.radians(21.5)),
                            dynamics=replace(free_stroke.dynamics, load=0.05))
    lagged = with_effects(free_stroke, sensor_lag=0.05, second_thermal_lag=0.3,
                          power_loss_fraction=0.1, ambient_offset=2.0)
    return [free_stroke, heavy, windy, early_contact, self_coiled, lagged]


def assert_same(batch, k, scalar):
    np.testing.assert_allclose(batch['displacement'][k], scalar.displacement, rtol=0,
                               atol=DISPLACEMENT_TOL)
    np.testing.assert_allclose(batch['temperature'][k], scalar.temperature, rtol=0,
                               atol=TEMPERATURE_TOL)
    np.testing.assert_allclose(batch['resistance'][k], scalar.resistance, rtol=0,
                               atol=RESISTANCE_TOL)
    np.testing.assert_allclose(batch['tension'][k], scalar.tension, rtol=0, atol=TENSION_TOL)


@pytest.mark.parametrize('model', ['cst', 'rod'])
def test_one_muscle_agrees_with_the_scalar_simulator(free_stroke, model):
    batch = simulate_batch(free_stroke, TIME, POWER, model=model)
    assert batch['displacement'].shape == (1, TIME.size)
    scalar = simulate(free_stroke, TIME, POWER, model=model)
    assert np.max(scalar.displacement) > 3e-3  # a real stroke: 3 mm and more
    assert_same(batch, 0, scalar)


@pytest.mark.parametrize('model', ['cst', 'rod'])
def test_different_muscles_agree_with_the_scalar_simulator(free_stroke, self_coiled, model):
    group = muscles(free_stroke, self_coiled)
    if model == 'rod':  # one rod table (~2 s to build) for the muscles of one mechanics
        group = [p for k, p in enumerate(group) if k not in (3, 4)]
    power = np.vstack([POWER * (1.0 + 0.2 * k) for k in range(len(group))])
    load = np.vstack([np.where(TIME < 1.5, p.dynamics.load, p.dynamics.load + 0.1)
                      for p in group])
    batch = simulate_batch(group, TIME, power, load=load, model=model)
    for k, p in enumerate(group):
        assert_same(batch, k, simulate(p, TIME, power[k], load[k], model=model))
    if model == 'cst':  # the early-contact muscle reaches its stop: that branch is taken
        stop = TcaSimulator(group[3], model=model)
        assert np.max(batch['displacement'][3]) == pytest.approx(
            stop.reference_elongation - contact_elongation(group[3]), abs=DISPLACEMENT_TOL)


def test_voltage_drive_agrees_with_the_node_rule(free_stroke):
    """P = V^2 / R(T, x) each physics step, as the node applies voltage_cmd."""
    batch = BatchSimulator([free_stroke, free_stroke], model='cst', dt=1e-3)
    scalar = TcaSimulator(free_stroke, model='cst', dt=1e-3)
    voltage = np.array([5.0, 0.0])
    for _ in range(1500):
        state = scalar.step(power_from_voltage(5.0, scalar.state.resistance))
        batch.step_voltage(voltage)
    assert batch.state.temperature[0] == pytest.approx(state.temperature, abs=TEMPERATURE_TOL)
    assert batch.state.displacement[0] == pytest.approx(state.displacement,
                                                        abs=DISPLACEMENT_TOL)
    assert batch.state.temperature[1] == pytest.approx(25.0, abs=1e-12)  # no voltage


def test_cst_force_matches_the_scalar_model(free_stroke, self_coiled):
    # one muscle past its plateau temperature T_p of eq. (2) at 90 and 200 degC (G50)
    plateau = free_stroke.with_values(**{'fiber.expansion_plateau_temperature': 70.0})
    muscles = (free_stroke, self_coiled, plateau)
    arrays = MuscleArrays(list(muscles))
    for temp in (25.0, 90.0, 160.0, 200.0):
        for y, force in ((0.002, 0.3), (0.0005, 0.05)):
            got = cst_tension(np.full(3, y), np.full(3, temp), np.full(3, force), arrays)
            for k, p in enumerate(muscles):
                want = make_kinetostatic_model(p, 'cst').tension(y, temp, force)
                assert got[k] == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize('change,needle', [
    (dict(effects='creep'), 'creep_compliance'), (dict(mass=0.0), 'dynamics.mass'),
    (dict(model='love'), 'cst or rod')])
def test_unsupported_requests_are_refused(free_stroke, change, needle):
    p, model = free_stroke, change.get('model', 'cst')
    if 'effects' in change:
        p = with_effects(p, creep_compliance=1e-3)
    if 'mass' in change:
        p = replace(p, dynamics=replace(p.dynamics, mass=0.0))
    with pytest.raises(ValueError, match=needle):
        BatchSimulator([free_stroke, p], model=model)
