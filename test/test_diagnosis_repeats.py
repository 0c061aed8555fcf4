"""A diagnosis of repeated runs sets its residual beside the spread between the runs."""
import numpy as np
import pytest

from tca_ros.diagnosis.identification import repeat_notes
from tca_ros.records.data import Record


def _run(offset, power=1.0, load=0.098):
    t = np.linspace(0.0, 60.0, 301)
    stroke = 0.01 * (1.0 - np.exp(-t / 5.0)) + offset
    return Record(time=t, power=np.full_like(t, power), load=np.full_like(t, load),
                  displacement=stroke, meta={}, source=f'{offset}')


def _compare(runs, residual_mm, samples=None):
    index = [np.arange(r.time.size) if samples is None else samples for r in runs]
    return repeat_notes(runs, [np.full(r.time.size, residual_mm * 1e-3) for r in runs], index)


def test_the_residual_is_compared_with_the_spread_of_repeats():
    # two runs 2 mm apart: each differs from the other (its repeats' mean) by 2 mm RMS
    runs = [_run(0.0), _run(0.002)]
    below = _compare(runs, 0.5)
    assert len(below) == 1 and 'is below the spread' in below[0] and '(2 mm' in below[0]
    above = _compare(runs, 4.0)
    assert 'is above the spread' in above[0] and 'misses more' in above[0]


def test_the_spread_is_taken_on_the_held_out_samples():
    # runs that agree at rest and differ by 4 mm while heated: a held-out block in the
    # heating sees a 4 mm spread, so a 3 mm residual there is below it (over the whole
    # records the spread would be smaller than 3 mm and the note would say "above")
    runs = [_run(0.0), _run(0.0)]
    runs[1].displacement[150:] += 0.004
    whole = _compare(runs, 3.0)
    assert 'is above the spread' in whole[0]
    heated = _compare(runs, 3.0, samples=np.arange(200, 260))
    assert 'is below the spread' in heated[0] and '(4 mm' in heated[0]


def test_records_without_repeats_get_no_note():
    # another power is another condition: no repeats, nothing to compare
    assert _compare([_run(0.0), _run(0.002, power=2.0)], 1.0) == []
    assert _compare([_run(0.0)], 1.0) == []


def test_a_records_air_flow_scales_the_heat_loss_the_diagnosis_simulates():
    # a record under a fan: the nominal model it is judged against loses heat as the
    # calibration's predictions do, by the fitted scale or else the prior's 2.5x
    from tca_ros.diagnosis.nominal import nominal_problems
    from tca_ros.model.muscle import describe_muscle, MuscleSpec
    from tca_ros.params.thread_presets import load_thread_presets
    spec = MuscleSpec(thread='nylon66_silver', thread_diameter=0.45e-3, coil='mandrel',
                      mandrel_diameter=0.8e-3, pitch_angle_deg=22.5, natural_length=0.05,
                      resistance=13.3, mass=0.02, model='cst')
    params = describe_muscle(spec, load_thread_presets()).params
    run = _run(0.0, power=0.3, load=0.196)
    run.power[:20] = 0.0
    h = params.thermal.convection_coefficient
    for meta, scales, factor in (({}, None, 1.0), ({'environment': 'forced_air'}, None, 2.5),
                                 ({'environment': 'fan'}, {'forced_air': 3.0}, 3.0)):
        run.meta = meta
        problems = nominal_problems([run], [params], False, {'model': 'cst'}, ['r.csv'],
                                    scales)[0]
        assert problems[0].params.thermal.convection_coefficient == \
            pytest.approx(factor * h), meta
