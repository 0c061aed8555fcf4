"""An effect is named only where its own part of the prediction exceeds the structure floor."""
import pytest

from tca_ros.diagnosis.effect_size import below_floor_note, switched_off
from tca_ros.model.effects import CATALOGUE
from tca_ros.params.files import load_params

from conftest import benchmark_case  # noqa: I100


def test_switching_an_effect_off_puts_its_size_at_the_neutral_default():
    assert switched_off('friction') == {'effects.friction_force': 0.0}
    assert switched_off('power_loss') == {'effects.power_loss_fraction': 0.0}
    neutral = load_params('free_stroke')  # a shipped config holds no effect
    assert switched_off('coil_contact') is None  # the coils' geometry: nothing neutral
    for name in set(CATALOGUE) - {'coil_contact'}:
        ((size, value),) = switched_off(name).items()
        assert size == CATALOGUE[name][0]
        assert neutral.with_values(**{size: value}).effects == neutral.effects, name
    note = below_floor_note([('friction', {'displacement': (4e-5, 5.5e-5)})], ['creep'])
    assert 'friction (displacement 40 within 55 um)' in note and 'creep is named' in note


@pytest.mark.slow
def test_a_friction_moving_the_stroke_less_than_its_practical_floor_is_not_named(tmp_path):
    # seed 9600 of the confusion benchmark: no effect hidden, a cst plant at 100 Hz with
    # a thermometer, described exactly. The calibrated nominal model leaves 106 um the
    # inputs predict (floor 55 um: 0.5 % of the swing); a friction of 1 mN calibrated
    # jointly takes it just below the floor while changing the prediction by 40 um: not
    # named (a creep that moves it by 473 um under 556 um of noise, tuned seed 9106, is)
    result, _ = benchmark_case(tmp_path, 9600, [])
    assert result.effects == [] and result.verdict == 'unexplained', result.notes
    (note,) = [n for n in result.notes if n.startswith('fitted but not named')]
    assert 'friction (displacement' in note and "nominal model's" in note
    own, floor = (float(x) for x in note.split('displacement ')[1].split(' um')[0]
                  .split(' within '))
    assert 0.0 < own <= floor


@pytest.mark.slow
def test_a_lone_effect_the_nominal_calibration_took_up_is_measured_against_it(tmp_path):
    # seed 9807 of the confusion benchmark's fourth sample: a creep (2.0 mm, 40 s) on a
    # rod plant at 2 Hz whose record starts a minute after a 0.5 W heating, its encoder
    # drifting. Fitted jointly (0.33 mm, 30 s) the creep switched off changes the
    # prediction by 48 um under an 84 um floor, but the calibrated nominal model, whose
    # values took part of it up, differs from the extension by 130 um and leaves
    # structure: the creep is named (decisions G78)
    result, truth = benchmark_case(tmp_path, 9807, ['creep'])
    assert truth.effects.creep_compliance > 0.0
    assert result.effects == ['creep'] and result.verdict == 'explained', result.notes
    assert not [n for n in result.notes if n.startswith('fitted but not named')]
