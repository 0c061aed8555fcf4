"""The experiment that separates rival effects the records explain alike (issue 25, item 3)."""
from types import SimpleNamespace

import numpy as np
import pytest

from tca_ros.calibration.experiments import SEPARATES, separating_experiment
from tca_ros.calibration.predictions import predictor
from tca_ros.diagnosis.joint import JointFit
from tca_ros.diagnosis.rivals import DECISIVE_DEVIANCE, rival_experiment_notes
from tca_ros.synthetic.realistic import realistic_set

NOISE_M = 20e-6  # m, the residual RMS of a good fit of a bench record


@pytest.fixture(scope='module')
def lagged():
    """A step record of a random muscle (5 Hz, one load) and its calibration's parts."""
    s = realistic_set(3, drift=0.0, duration=60.0, on=(10.0, 35.0))
    record = s.records[-1]  # the hottest step
    cal = SimpleNamespace(start=s.start, model='cst', supply='power', records=[record],
                          channels=['displacement', 'temperature'],
                          report=SimpleNamespace(channel_scale={'displacement': NOISE_M}))
    return cal


def _fit(name, values, cal):
    report = SimpleNamespace(values=values, channel_scale=cal.report.channel_scale)
    calibration = SimpleNamespace(**{**vars(cal), 'report': report})
    return JointFit(name=name, values=values, n_params=1, sims=[], criterion=100.0,
                    explained=True, pinned=[], calibration=calibration)


def test_neither_lag_delays_the_measured_temperature(lagged):
    # the model (effects.py): a sensor lag filters the displacement reading, a second
    # thermal lag the actuating temperature; eq. (1)'s T, what a thermometer reads, is
    # the same under both, so a temperature channel cannot tell them apart
    predict = predictor(lagged.start, 'cst', ['temperature', 'displacement'])
    sensor, thermal = (predict({name: 1.2}, lagged.records)[0]
                       for name in ('effects.sensor_lag', 'effects.second_thermal_lag'))
    np.testing.assert_array_equal(sensor['temperature'], thermal['temperature'])
    # both delay the stroke: on the record they differ far less than the stroke
    stroke = float(np.ptp(sensor['displacement']))
    assert np.sqrt(np.mean((sensor['displacement'] - thermal['displacement']) ** 2)) \
        < 0.05 * stroke


def test_a_load_step_separates_a_sensor_lag_from_a_second_thermal_lag(lagged):
    rivals = [{'effects.sensor_lag': 1.2}, {'effects.second_thermal_lag': 1.2}]
    e = separating_experiment(lagged, rivals, ('sensor_lag', 'second_thermal_lag'), 'effects')
    assert e.experiment.startswith('the same steps with the load raised')
    assert e.separates and e.difference >= SEPARATES * NOISE_M
    # the step tells them apart by more than the record does
    assert e.difference > 2.0 * e.on_records, e
    notes = rival_experiment_notes(_fit('sensor_lag', rivals[0], lagged),
                                   [_fit('second_thermal_lag', rivals[1], lagged)])
    assert len(notes) == 1
    assert notes[0].startswith('sensor_lag and second_thermal_lag are rivals')
    assert 'the load raised to 2x over their middle third separates them' in notes[0]
    # a rival the records tell apart (its gain decisively below) gets no experiment
    worse = _fit('second_thermal_lag', rivals[1], lagged)
    worse.criterion = 100.0 - DECISIVE_DEVIANCE - 1.0
    assert rival_experiment_notes(_fit('sensor_lag', rivals[0], lagged), [worse]) == []


def test_a_dead_time_is_told_from_a_sensor_lag_and_moves_the_temperature_too(lagged):
    # a dead time delays the power, so the temperature too: without a thermometer, one
    # tells it from a sensor lag that never touches the temperature
    blind = SimpleNamespace(**{**vars(lagged), 'channels': ['displacement']})
    rivals = [{'effects.sensor_lag': 1.0}, {'effects.dead_time': 1.0}]
    e = separating_experiment(blind, rivals, ('sensor_lag', 'dead_time'), 'effects')
    assert e.separates, e
    predict = predictor(lagged.start, 'cst', ['temperature'])
    first, second = (predict(v, lagged.records)[0]['temperature'] for v in rivals)
    assert np.max(np.abs(first - second)) > 1.0  # K


@pytest.mark.slow
def test_a_second_thermal_lag_with_a_thermometer_is_named_without_the_sensor_lag(tmp_path):
    # seed 9141 of the confusion benchmark: a 3.83 s second thermal lag, rod plant, 5 Hz,
    # thermometer on, jittered stamps (read on the clock they scatter around, z = 7.3:
    # decisions G81), described exactly. The search leaves the records unexplained with
    # friction beside the lag; the second thermal lag alone, calibrated jointly on the
    # training part and confirmed on the whole record, explains them, and the sensor
    # lag, which moves the stroke alike on one load, is not said as explaining them too.
    # (Seed 9121, a 1.52 s lag under the same conditions and this test's case before
    # G81, read at its stamps had the lag named; read on its clock, the lag is found at
    # 1.58 s but the rod's shape leaves 378 um the inputs predict over a 197 um floor:
    # unexplained, said as such.)
    from conftest import benchmark_case
    result, truth = benchmark_case(tmp_path, 9141, ['second_thermal_lag'])
    assert 'samples taken on the clock' in result.notes[0]
    assert result.verdict == 'explained' and result.effects == ['second_thermal_lag'], \
        result.notes
    assert not [n for n in result.notes if 'also explained' in n and 'sensor_lag' in n], \
        result.notes
    assert result.extended_values['effects.second_thermal_lag'] == pytest.approx(
        truth.effects.second_thermal_lag, rel=0.3)
