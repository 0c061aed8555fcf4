"""The small-signal plant of tca_ros.toolkit.linearize against the nonlinear model."""
from dataclasses import replace
import io
import json
import math
import subprocess
import sys

import control
import numpy as np
import pytest

from tca_ros.cli.main import main
from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.params_schema import GRAVITY
from tca_ros.model.resistance import power_from_voltage
from tca_ros.model.rod_table import TABLE_TEMP_BELOW, TABLE_TEMP_STEP
from tca_ros.model.tca_params import with_effects
from tca_ros.model.thermal import thermal_conductance, thermal_time_constant
from tca_ros.params.files import dump_params
from tca_ros.toolkit.linearize import linearize, OperatingPointError

P0 = 1.0  # W, operating power: 100 degC on the free-stroke TCA
STEP_SECONDS = 6.0  # 2 thermal time constants
DT = 1e-3  # s, the node's physics step


def nonlinear_step(params, plant, step, drive='power', seconds=STEP_SECONDS):
    """Return (t, displacement change, temperature change) after an input step.

    The simulator starts at the plant's operating point; under a voltage drive
    it gets P = V^2 / R(T, x) every physics step, as the node applies it.
    """
    op = plant.point
    sim = TcaSimulator(params, model=plant.model, dt=DT)
    state = sim.reset(load=op.load, temperature=op.temperature)
    x0 = state.displacement
    n = int(round(seconds / DT))
    disp, temp = np.zeros(n + 1), np.zeros(n + 1)
    for i in range(n):
        power = op.power + step if drive == 'power' else power_from_voltage(
            op.voltage + step, state.resistance)
        state = sim.step(power, op.load)
        disp[i + 1] = state.displacement - x0
        temp[i + 1] = state.temperature - op.temperature
    return np.arange(n + 1) * DT, disp, temp


def step_errors(params, plant, steps, drive='power'):
    """Return the max error of the linear prediction relative to its peak, per step.

    The response to a zero step is subtracted: the simulator starts at the exact
    static equilibrium, which the rod model's table holds within a micrometre, so
    it settles by that much on its own.
    """
    errors = []
    _, drift, _ = nonlinear_step(params, plant, 0.0, drive)
    for step in steps:
        t, disp, _ = nonlinear_step(params, plant, step, drive)
        disp = disp - drift
        linear = step * control.forced_response(plant.channel(), t, np.ones_like(t)).outputs
        errors.append(float(np.max(np.abs(disp - linear)) / np.max(np.abs(linear))))
    return errors


def test_cst_power_step_error_halves_with_the_step(free_stroke):
    plant = linearize(free_stroke, P0, model='cst')
    steps = (0.1, 0.05, 0.025)
    errors = step_errors(free_stroke, plant, steps)
    ratios = [a / b for a, b in zip(errors, errors[1:])]
    print('cst dP (W), relative error, ratio to the previous:',
          list(zip(steps, errors, [None] + ratios)))
    # the nonlinear remainder is second order in the step: relative error ~ step
    assert all(1.8 < r < 2.2 for r in ratios)
    assert errors[-1] < 0.015  # 25 mW (1.9 K) from 1 W


def test_rod_power_step_error_shrinks_with_the_step(free_stroke):
    plant = linearize(free_stroke, P0, model='rod')
    steps = (0.2, 0.05, 0.0125)
    errors = step_errors(free_stroke, plant, steps)
    print('rod dP (W), relative error:', list(zip(steps, errors)))
    # the rod's f_rod is linear in T within a table cell (2.5 K): the error falls at
    # least as fast as the step once the step stays inside the cell
    assert errors[0] > errors[1] > errors[2]
    assert errors[0] / errors[2] > 16.0
    assert errors[-1] < 0.01


def test_temperature_channel_is_exact(free_stroke):
    """Eq. (1) is linear: the linear and nonlinear temperatures agree to rounding."""
    plant = linearize(free_stroke, P0, model='cst')
    t, _, temp = nonlinear_step(free_stroke, plant, 0.2, seconds=3.0)
    linear = 0.2 * control.forced_response(plant.channel('temperature'), t,
                                           np.ones_like(t)).outputs
    np.testing.assert_allclose(temp, linear, rtol=0.0, atol=1e-9)  # K


def test_voltage_step_error_halves_with_the_step(free_stroke):
    plant = linearize(free_stroke, P0, model='cst', drive='voltage')
    steps = (0.2, 0.1)
    errors = step_errors(free_stroke, plant, steps, drive='voltage')
    print('cst voltage dV (V), relative error:', list(zip(steps, errors)))
    assert 1.7 < errors[0] / errors[1] < 2.3
    assert errors[1] < 0.05


def statics_slope(model, load, temp, half_span):
    """Return d(contraction)/dT (m/K) from `tca_sim statics` around temp (degC)."""
    out = io.StringIO()
    status = main(['statics', '--config', 'free_stroke', '--model', model,
                   '--mass', repr(load / GRAVITY), '--tmin', repr(temp - half_span),
                   '--tmax', repr(temp + 1.0001 * half_span), '--tstep', repr(half_span)],
                  out=out)
    assert status == 0
    rows = np.loadtxt(io.StringIO(out.getvalue()), delimiter=',', skiprows=1)
    assert rows.shape == (3, 2)
    # the printed temperatures are rounded to 6 digits: use the requested grid
    return (rows[2, 1] - rows[0, 1]) / (2.0 * half_span)


@pytest.mark.parametrize('model', ['cst', 'love'])
def test_dc_gain_equals_the_statics_slope(free_stroke, model):
    plant = linearize(free_stroke, P0, model=model)
    d_temp_d_power = 1.0 / thermal_conductance(free_stroke.fiber, free_stroke.thermal)
    slope = statics_slope(model, plant.point.load, plant.point.temperature, 0.1)
    # statics solve to 1e-13 m and print 9 digits; 0.1 K differences keep 1e-6
    assert plant.dc_gain() == pytest.approx(slope * d_temp_d_power, rel=1e-5)
    assert plant.dc_gain('temperature') == pytest.approx(d_temp_d_power, rel=1e-9)


def test_rod_dc_gain_is_the_statics_slope_within_the_table_error(free_stroke):
    """The rod dynamics interpolate exact statics linearly in T (2.5 K cells).

    Their slope is the statics chord over the cell around T0; it differs from
    the local statics slope by up to ~1 % (docs/toolkit.md).
    """
    plant = linearize(free_stroke, P0, model='rod')
    op = plant.point
    d_temp_d_power = 1.0 / thermal_conductance(free_stroke.fiber, free_stroke.thermal)
    local = statics_slope('rod', op.load, op.temperature, 0.1) * d_temp_d_power
    assert plant.dc_gain() == pytest.approx(local, rel=0.015)
    ambient = free_stroke.thermal.ambient_temperature
    first_row = ambient - TABLE_TEMP_BELOW  # degC, the table's first row
    cell = math.floor((op.temperature - first_row) / TABLE_TEMP_STEP)
    low = first_row + TABLE_TEMP_STEP * cell
    chord = statics_slope('rod', op.load, low + 0.5 * TABLE_TEMP_STEP,
                          0.5 * TABLE_TEMP_STEP) * d_temp_d_power
    assert plant.dc_gain() == pytest.approx(chord, rel=2e-3)


def test_thermal_pole_load_gain_and_lags(free_stroke):
    plant = linearize(free_stroke, P0, model='cst')
    tau = thermal_time_constant(free_stroke.fiber, free_stroke.thermal)
    assert plant.thermal_time_constant() == pytest.approx(tau, rel=1e-9)
    assert plant.bandwidth('temperature') == pytest.approx(1.0 / tau, rel=1e-6)
    omega = [0.1, 3.0, 30.0]  # rad/s: thermal corner, between, mechanical resonance
    np.testing.assert_allclose(plant.frequency_response(omega),
                               [complex(plant.channel()(1j * w)) for w in omega], rtol=1e-9)
    assert plant.dc_gain('displacement', 'load') == pytest.approx(
        -1.0 / plant.point.stiffness, rel=1e-5)
    # first-order lags in series add their time constants to the mean delay, and
    # leave the DC gain alone
    lagged = with_effects(free_stroke, second_thermal_lag=0.5, sensor_lag=0.2,
                          dead_time=0.1)
    other = linearize(lagged, P0, model='cst')
    assert other.states == ('temperature', 'fiber_temperature', 'elongation', 'velocity',
                            'sensor')
    assert other.dc_gain() == pytest.approx(plant.dc_gain(), rel=1e-9)
    assert other.mean_delay() - plant.mean_delay() == pytest.approx(0.8, rel=1e-6)


@pytest.mark.parametrize('mass,damping,states', [
    (0.0, 0.5, ('temperature', 'elongation')), (0.0, 0.0, ('temperature',))])
def test_massless_plants_keep_the_dc_gain(free_stroke, mass, damping, states):
    base = linearize(free_stroke, P0, model='cst')
    params = replace(free_stroke, dynamics=replace(free_stroke.dynamics, mass=mass,
                                                   damping=damping))
    plant = linearize(params, P0, model='cst')
    assert plant.states == states
    assert plant.dc_gain() == pytest.approx(base.dc_gain(), rel=1e-6)


def test_contact_and_play_operators_are_refused(free_stroke):
    with pytest.raises(OperatingPointError, match='coils touch'):
        linearize(free_stroke, 3.0, load=0.0, model='cst')
    with pytest.raises(OperatingPointError, match='effects.hysteresis_width'):
        linearize(with_effects(free_stroke, hysteresis_width=5.0), P0, model='cst')


def test_cli_linearize_prints_and_writes(tmp_path, free_stroke):
    out = io.StringIO()
    status = main(['linearize', '--config', 'free_stroke', '--model', 'cst', '--power', '1',
                   '--out', str(tmp_path)], out=out)
    text = out.getvalue()
    assert status == 0
    assert 'tau 3.0077 s (eq. (1), thermal)' in text
    assert 'power->displacement' in text and 'voltage->displacement' in text
    assert (tmp_path / 'bode.png').stat().st_size > 10_000
    record = json.loads((tmp_path / 'linear_model.json').read_text())
    a = np.array(record['power']['A'])
    assert record['power']['states'] == ['temperature', 'elongation', 'velocity']
    plant = linearize(free_stroke, P0, model='cst')
    np.testing.assert_allclose(a, plant.A)


@pytest.mark.parametrize('args,needle', [
    (['--power', '-1'], '--power = -1 W'),
    (['--power', '3', '--load', '0', '--model', 'cst'], 'coils touch'),
    (['--power', '1', '--load', '1e9'], '--load = 1e+09 N'),
    (['--power', '1', '--config', 'conical'], 'linearize needs a helical TCA')])
def test_cli_linearize_bad_input_is_one_line_exit_2(capsys, args, needle):
    assert main(['linearize', *args]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count('\n') == 1


def test_cli_linearize_refuses_hysteresis(tmp_path, capsys, free_stroke):
    path = tmp_path / 'hyst.yaml'
    dump_params(with_effects(free_stroke, hysteresis_width=5.0), path)
    assert main(['linearize', '--config', str(path), '--power', '1', '--model', 'cst']) == 2
    assert 'effects.hysteresis_width = 5' in capsys.readouterr().err


def test_toolkit_imports_neither_rclpy_nor_matplotlib():
    code = ('import sys, tca_ros.toolkit.linearize, tca_ros.toolkit.envs; '
            'print(sorted(m for m in sys.modules if '
            "m.split('.')[0] in ('rclpy', 'matplotlib') or m.startswith('tca_ros.ros.node')))")
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == '[]'
