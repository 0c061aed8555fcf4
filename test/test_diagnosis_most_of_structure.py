"""Effects that take away most of the structure are named beside what remains (decisions G91)."""
import pytest

from tca_ros.calibration.residuals import ResidualStats
from tca_ros.diagnosis.most_of_structure import most_of_structure_text, MOST_SHARE, \
    takes_most_of_structure
from tca_ros.diagnosis.noise import STRUCTURE_ALPHA, StructureTest
from tca_ros.diagnosis.verdict_text import found_sentence

UNITS = {'displacement': 'm', 'temperature': 'K'}


def _stat(channel, predictable, floor):
    """Return ResidualStats whose structure test predicts ``predictable`` above ``floor``."""
    test = StructureTest(p_value=0.1 * STRUCTURE_ALPHA, predictable_rms=predictable,
                         noise_rms=floor, floor=floor, ar_order=1, n=200)
    return ResidualStats(channel, UNITS[channel], predictable, floor, 1.0, 0.0, 0.0, 0.0,
                         0.5, 0.5, 0.1, 0.0, 0.0, 0.0, structure=test)


def _stats(**channels):
    """Return {channel: ResidualStats} from channel=(predictable, floor)."""
    return {c: _stat(c, *v) for c, v in channels.items()}


def test_a_dead_time_that_takes_nine_tenths_of_each_channel_is_named():
    # seed 9841 (a 1.59 s dead time, rod plant described as cst): 3.6 mm -> 0.37 mm of
    # displacement, 21 K -> 0.56 K of temperature predicted by the inputs
    nominal = _stats(displacement=(3.6e-3, 230e-6), temperature=(21.1, 1.02))
    extended = _stats(displacement=(0.372e-3, 230e-6), temperature=(0.56, 1.02))
    assert extended['displacement'].structured and not extended['temperature'].structured
    assert takes_most_of_structure(nominal, extended)
    text = most_of_structure_text(nominal, extended)
    assert 'displacement 99 %' in text and 'temperature 100 %' in text
    sentence = found_sentence(['dead_time'], extended, text)
    assert sentence.startswith('dead_time found: it takes away')
    assert 'something else acts too' in sentence


@pytest.mark.parametrize('left', [0.67, 0.79, 0.945])
def test_an_effect_that_leaves_most_of_the_structure_is_not_named(left):
    # what the catalogue's best did beside a sensor nonlinearity, a fatigue, a hysteresis
    nominal = _stats(displacement=(1e-3, 1e-4))
    extended = _stats(displacement=(left * 1e-3, 1e-4))
    assert not takes_most_of_structure(nominal, extended)


def test_the_share_is_a_tenth_of_the_variance_on_either_side():
    nominal = _stats(displacement=(1e-3, 1e-5))
    assert takes_most_of_structure(nominal, _stats(displacement=(0.99 * MOST_SHARE * 1e-3,
                                                                 1e-5)))
    assert not takes_most_of_structure(nominal, _stats(displacement=(1.01 * MOST_SHARE * 1e-3,
                                                                     1e-5)))


def test_a_channel_made_worse_keeps_the_effects_unnamed():
    # seed 9653 (a fatigue): the convection exponent took a third off the displacement
    # and made the temperature structured where the nominal model left it within its floor
    nominal = _stats(displacement=(1.25e-3, 0.54e-3), temperature=(1.2, 2.16))
    extended = _stats(displacement=(0.05e-3, 0.54e-3), temperature=(2.2, 2.16))
    assert not nominal['temperature'].structured and extended['temperature'].structured
    assert not takes_most_of_structure(nominal, extended)


def test_nothing_is_taken_where_the_nominal_model_left_the_held_out_part_unstructured():
    nominal = _stats(displacement=(1e-5, 1e-4))
    extended = _stats(displacement=(0.0, 1e-4))
    assert not takes_most_of_structure(nominal, extended)


def test_an_effect_at_the_end_of_its_range_stands_in_whatever_it_takes_away():
    # at_bounds' tests (standing_in) hold here too: a dead time fitted at its 5 s limit asks for
    # more than a dead time can be, an offset 6 K from the room the thermometer read
    # at rest is not the room
    from types import SimpleNamespace

    from tca_ros.calibration.candidates import build_candidates
    from tca_ros.diagnosis.extension import standing_in
    from tca_ros.params.files import load_params
    params = load_params('free_stroke', model='cst')
    candidates = build_candidates(params, 'cst', 0.1, 5e-3,
                                  names=('dead_time', 'ambient_offset'),
                                  initial_temperature=params.thermal.ambient_temperature)
    nominal = SimpleNamespace(candidates=candidates, problems=[], sims=[])
    assert standing_in(['dead_time'], {'effects.dead_time': 1.6}, nominal, [], False) is None
    assert 'end of its physical range' in standing_in(['dead_time'], {'effects.dead_time': 5.0},
                                                      nominal, [], False)
    assert standing_in(['ambient_offset'], {'effects.ambient_offset': 0.5}, nominal, [],
                       False) is None
    assert 'stands in for another cause' in standing_in(
        ['ambient_offset'], {'effects.ambient_offset': 6.0}, nominal, [], False)
