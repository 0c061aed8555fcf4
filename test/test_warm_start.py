"""A record that begins warm: thermal.initial_temperature_rise in the simulators and the fit.

The plant of these records is heated before the record starts and cut at t = 0 (the
way a lab restarts its logger while the muscle still cools), not started warm by the
parameter the fit estimates.
"""
import dataclasses
import io
import math
import re

import numpy as np
import pytest

from tca_ros.calibration.calibration import calibrate, CalibrationError, starts_warm
from tca_ros.cli.main import main
from tca_ros.model.quasistatic import QuasiStaticUnsupported, simulate_quasistatic
from tca_ros.model.simulation import simulate
from tca_ros.model.tca_params import muscle_at_rest
from tca_ros.model.thermal import heat_capacity, thermal_conductance
from tca_ros.params.files import load_params
from tca_ros.records.data import write_csv_record
from tca_ros.records.record import Record

MASS = 0.02  # kg


def _params(**values):
    return load_params('free_stroke').with_values(
        **{'dynamics.mass': MASS, 'dynamics.load': MASS * 9.81, **values})


def _profile(rate=10.0, duration=90.0):
    t = np.arange(0.0, duration, 1.0 / rate)
    return t, np.where((t >= 20.0) & (t < 45.0), 0.6, 0.0), np.full_like(t, MASS * 9.81)


@pytest.mark.parametrize('model', ['cst', 'rod'])
@pytest.mark.parametrize('effect', [{}, {'effects.second_thermal_lag': 2.0},
                                    {'effects.emissivity': 0.8}])
def test_a_warm_start_reads_zero_then_cools_below_it_in_both_simulators(model, effect):
    p = _params(**{'thermal.initial_temperature_rise': 40.0, **effect})
    t, power, load = _profile()
    full = simulate(p, t, power, load, model=model, physics_rate=500.0)
    fast = simulate_quasistatic(p, t, power, load, model=model)
    ambient = p.thermal.ambient_temperature
    for sim in (full, fast):
        assert sim.displacement[0] == 0.0 and sim.true_displacement[0] == 0.0
        assert sim.temperature[0] == pytest.approx(ambient + 40.0)
        # before the power comes on the coil relaxes: the reading falls below its zero
        assert sim.displacement[t < 20.0].min() < -0.5e-3
    tau = heat_capacity(p.fiber) / thermal_conductance(p.fiber, p.thermal)
    if not effect:  # eq. (1) without power: the excess decays with the time constant
        k = int(np.searchsorted(t, tau))
        assert fast.temperature[k] - ambient == pytest.approx(40.0 * math.exp(-t[k] / tau),
                                                              rel=1e-6)
    np.testing.assert_allclose(fast.temperature, full.temperature, atol=0.2)
    assert np.sqrt(np.mean((fast.displacement - full.displacement) ** 2)) < 20e-6


def test_at_rest_nothing_moves_and_a_voltage_drive_refuses_the_warm_start():
    p = _params()
    t, power, load = _profile()
    # nothing moves: to round-off (a static map shared with earlier tests in the process
    # spans a wider grid, whose spline reads 1.7e-18 m at ambient)
    assert np.ptp(simulate_quasistatic(p, t, 0.0 * power, load).displacement) < 1e-15
    warm = _params(**{'thermal.initial_temperature_rise': 10.0})
    with pytest.raises(QuasiStaticUnsupported, match='initial_temperature_rise'):
        simulate_quasistatic(warm, t, power, load, supply='voltage')


def _record_cut_from_a_longer_run(pre_heat_s=30.0, cool_s=3.0):
    """The plant heated for ``pre_heat_s``, cooled for ``cool_s``, then recorded."""
    p = _params()
    t, power, load = _profile()
    lead = pre_heat_s + cool_s
    t_all = np.concatenate((np.arange(-lead, 0.0, 0.1), t))
    p_all = np.concatenate((np.where(np.arange(-lead, 0.0, 0.1) < -cool_s, 0.6, 0.0), power))
    run = simulate(p, t_all - t_all[0], p_all, np.full_like(t_all, load[0]), model='cst',
                   physics_rate=500.0)
    start = t_all.size - t.size
    x = run.displacement[start:] - run.displacement[start]
    rng = np.random.default_rng(3)
    x = x + rng.normal(0.0, 5e-6, x.size)
    temp = run.temperature[start:] + rng.normal(0.0, 0.1, x.size)
    record = Record(time=t, power=power, load=load, displacement=x, temperature=temp,
                    meta={'mass_kg': MASS, 'sample_rate_hz': 10.0}, source='warm.csv')
    return record, run.temperature[start] - p.thermal.ambient_temperature


def test_the_calibration_finds_the_excess_of_a_record_that_begins_warm():
    record, excess = _record_cut_from_a_longer_run()
    assert excess > 10.0  # the record starts well above ambient
    start = _params()
    names = ['heat_capacity', 'heat_loss', 'actuation_gain']
    warm = calibrate([record], start, model='cst', fit=names + ['initial_temperature_rise'],
                     check=False)
    cold = calibrate([record], start, model='cst', fit=names, check=False)
    rise = warm.report.values['initial_temperature_rise']
    assert rise == pytest.approx(excess, rel=0.05)
    assert warm.report.record_rmse[0]['displacement'] < 0.05 * \
        cold.report.record_rmse[0]['displacement']
    # the params file describes the muscle, which starts at rest
    muscle, note = muscle_at_rest(warm.params)
    assert muscle.thermal.initial_temperature_rise == 0.0 and 'above ambient' in note


def test_at_rest_the_fitted_excess_stays_near_zero():
    record, excess = _record_cut_from_a_longer_run(pre_heat_s=0.0, cool_s=0.0)
    assert excess == 0.0
    cal = calibrate([record], _params(), model='cst', fit=['heat_capacity',
                    'heat_loss', 'actuation_gain', 'initial_temperature_rise'], check=False)
    assert cal.report.values['initial_temperature_rise'] < 1.0


def test_the_logged_temperature_decides_whether_the_default_fit_takes_the_excess():
    warm, _ = _record_cut_from_a_longer_run()
    rest, _ = _record_cut_from_a_longer_run(pre_heat_s=0.0, cool_s=0.0)
    ambient = _params().thermal.ambient_temperature
    assert starts_warm(warm, ambient) and not starts_warm(rest, ambient)
    # a power sensor reads noise at rest: that is no heating
    noise = np.abs(np.random.default_rng(5).normal(0.0, 0.01 * warm.power.max(),
                                                   warm.power.size))
    assert starts_warm(dataclasses.replace(warm, power=warm.power + noise), ambient)
    # a displacement alone cannot tell a cooling coil from a creeping one: at rest
    blind = dataclasses.replace(warm, temperature=None)
    assert not starts_warm(blind, ambient)
    # an ambient 5 K warmer than the config's is no warm start: the temperature holds
    offset = dataclasses.replace(rest, temperature=rest.temperature + 5.0)
    assert not starts_warm(offset, ambient)
    cal = calibrate([warm], _params(), model='cst', check=False)
    assert 'initial_temperature_rise' in cal.report.values
    assert any('begins warm' in n for n in cal.notes)
    at_rest = calibrate([rest], _params(), model='cst', check=False)
    assert 'initial_temperature_rise' not in at_rest.report.values


def test_one_excess_for_several_records_is_refused_in_one_line():
    record, _ = _record_cut_from_a_longer_run(pre_heat_s=0.0, cool_s=0.0)
    with pytest.raises(CalibrationError, match="'initial_temperature_rise': one value"):
        calibrate([record, record], _params(), model='cst', check=False,
                  fit=['heat_loss', 'initial_temperature_rise'])


def test_a_warm_record_among_several_is_said_to_be_taken_at_rest():
    warm, _ = _record_cut_from_a_longer_run()
    rest, _ = _record_cut_from_a_longer_run(pre_heat_s=0.0, cool_s=0.0)
    rest = dataclasses.replace(rest, source='rest.csv')
    cal = calibrate([rest, warm], _params(), model='cst', check=False,
                    fit=['heat_loss', 'actuation_gain'])
    said = [n for n in cal.notes if 'the logged temperature falls' in n]
    assert len(said) == 1 and said[0].startswith('warm.csv: ')


def test_tca_sim_calibrate_fits_a_warm_start_and_writes_the_muscle_at_rest(tmp_path):
    record, excess = _record_cut_from_a_longer_run()
    path, out_path = tmp_path / 'warm.csv', tmp_path / 'cal.yaml'
    write_csv_record(dataclasses.replace(record, meta={**record.meta, 'tca': 'free_stroke'}),
                     str(path))
    out = io.StringIO()
    assert main(['calibrate', str(path), '--model', 'cst', '--out', str(out_path),
                 '--quiet'], out=out) == 0
    printed = out.getvalue()
    assert 'initial_temperature_rise' in printed and 'the record begins warm' in printed
    text = out_path.read_text()
    said = re.search(r'the record began ([0-9.]+) K above ambient', text)
    assert said and float(said.group(1)) == pytest.approx(excess, rel=0.05)
    assert load_params(str(out_path)).thermal.initial_temperature_rise == 0.0
