"""The equations' one home takes floats or arrays: each muscle of an array as alone.

Eq. (1) (model/thermal.py), eq. (18) and the contact stop (model/end_motion.py),
the tendons of the pair (model/rigs.py) and the substep planner
(model/substeps.py) are written once for the scalar and the batch steppers; an
array of muscles with different effects must give each muscle's scalar result
to the bit.
"""
import math

import numpy as np
import pytest

from tca_ros.model import end_motion, substeps, thermal
from tca_ros.model.rigs import tendon_force
from tca_ros.model.tca_params import with_effects


@pytest.fixture(scope='module')
def mixed(free_stroke):
    """Four muscles: nominal, radiating, nonlinear convection, all thermal effects."""
    return [free_stroke,
            with_effects(free_stroke, emissivity=0.8),
            with_effects(free_stroke, convection_exponent=0.25, ambient_offset=-1.5),
            with_effects(free_stroke, emissivity=0.5, convection_exponent=0.3,
                         power_loss_fraction=0.2)]


def test_heat_balance_gathers_each_muscles_coefficients(mixed):
    batch = thermal.HeatBalance.gather(mixed)
    assert batch.radiates and batch.convects_nonlinearly and not batch.linear
    assert thermal.HeatBalance.of(mixed[0]).linear
    for k, p in enumerate(mixed):
        one = thermal.HeatBalance.of(p)
        assert batch.capacity[k] == one.capacity and batch.ambient[k] == one.ambient
        assert batch.gain[k] == one.gain and batch.exponent[k] == one.exponent


def test_heat_rate_and_steps_of_an_array_are_each_muscles(mixed):
    batch = thermal.HeatBalance.gather(mixed)
    temp = np.array([30.0, 80.0, 140.0, 60.0])  # degC
    power = np.array([0.0, 1.2, 3.0, 0.7])  # W
    rate = thermal.heat_rate(temp, power, batch)
    rk4 = thermal.heat_step_rk4(temp, power, 2e-3, batch)
    for k, p in enumerate(mixed):
        one = thermal.HeatBalance.of(p)
        assert rate[k] == thermal.heat_rate(temp[k], power[k], one)
        assert rk4[k] == thermal.heat_step_rk4(temp[k], power[k], 2e-3, one)
    assert np.all(np.abs(rate) > 0.0)  # no muscle at rest: the comparison means something
    linear = thermal.HeatBalance.gather(mixed[:1] * 2)
    exact = thermal.heat_step_exact(temp[:2], power[:2], thermal.heat_decay(1e-3, linear),
                                    linear)
    one = thermal.HeatBalance.of(mixed[0])
    assert exact[1] == thermal.heat_step_exact(temp[1], power[1],
                                               thermal.heat_decay(1e-3, one), one)


def test_nominal_rate_is_eq_1_as_printed(free_stroke):
    f, t = free_stroke.fiber, free_stroke.thermal
    temp, power = 40.0, 0.9  # degC, W
    loss = thermal.thermal_conductance(f, t) * (temp - t.ambient_temperature)
    assert thermal.thermal_rate(temp, power, f, t) == pytest.approx(
        (power - loss) / thermal.heat_capacity(f), rel=1e-15)


def test_lag_contact_and_tendons_of_an_array_are_each_muscles():
    value, target = np.array([1.0, 2.0, 3.0]), np.array([0.5, 2.5, -1.0])
    tau = np.array([0.0, 0.05, 0.3])  # s; the first lag off
    lagged = thermal.lag_step(value, target, 1e-3, tau)
    for k in range(3):
        assert lagged[k] == thermal.lag_step(value[k], target[k], 1e-3, tau[k])
    assert lagged[0] == target[0] and lagged[2] != target[2]
    q_next, q = np.array([1e-3, -2e-3, 5e-4]), np.array([1.1e-3, -1e-3, 4e-4])  # m
    contact = np.array([0.0, -1.5e-3, -math.inf])  # m
    stopped = end_motion.contact_stop(q_next, q, 0.0, contact)
    for k in range(3):
        one = end_motion.contact_stop(q_next[k], q[k], 0.0, contact[k])
        assert (stopped[0][k], stopped[1][k], bool(stopped[2][k])) == one
    assert stopped[2].tolist() == [False, True, False]
    tension = np.array([-0.1, 0.0, 0.3, math.nan])  # N
    pulled = tendon_force(tension)
    assert pulled[:3].tolist() == [0.0, 0.0, 0.3] and math.isnan(pulled[3])
    assert [tendon_force(f) for f in tension[:3]] == pulled[:3].tolist()


def test_the_planner_takes_one_limit_or_one_per_muscle():
    k, mass = np.array([20.0, 400.0, 0.0]), np.array([0.03, 0.03, 0.03])  # N/m, kg
    limits = substeps.central_difference_limit(k, mass)
    assert limits[2] == math.inf
    assert limits[1] == substeps.central_difference_limit(400.0, 0.03)
    dt = 0.05  # s
    assert substeps.substep_count(dt, limits) == substeps.substep_count(dt, float(limits[1]))
    assert substeps.substep_count(dt, limits) == math.ceil(dt / (0.9 * limits[1]))
    assert substeps.substep_count(dt, np.array([math.nan])) == substeps.MAX_SUBSTEPS + 1
