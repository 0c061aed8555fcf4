"""A play of the stroke (friction, hysteresis) is structure: the residual by the last motion."""
import pytest

from conftest import benchmark_case  # noqa: I100


@pytest.mark.slow
def test_a_friction_held_end_of_a_record_not_at_rest_is_searched_and_named(tmp_path):
    # seed 9447 of the confusion benchmark: 34 mN of friction on a rod plant at 2 Hz,
    # without a thermometer, its record starting 30 s after a 0.5 W heating, described
    # exactly. The calibrated nominal model's residual is +-0.9 mm, on two branches by
    # the direction of the stroke; without the last direction among the structure
    # test's signals it read as noise (floor 373 um), no effect was searched and the
    # verdict was `adequate`
    result, truth = benchmark_case(tmp_path, 9447, ['friction'])
    assert result.effects == ['friction'], result.notes
    assert result.extended_values['effects.friction_force'] == pytest.approx(
        truth.effects.friction_force, rel=0.5)


@pytest.mark.slow
def test_a_friction_the_heat_capacity_took_up_is_tested_as_its_cause(tmp_path):
    # seed 10047: 12 mN of friction on a rod plant at 2 Hz, no thermometer, the encoder
    # drifting. The calibrated nominal model leaves noise with its heat capacity +2.0
    # spreads: a slower response, which a play on the end's force makes as a hysteresis
    # does. Among the finding's effects (G93) friction fell the objective most and
    # predicted the held-out part best; without it the hysteresis was named. The inputs
    # predict that noise below the floor (p < 0.001), so the search now runs (G96) and
    # names friction first, at 548.2 against the hysteresis's 233.5
    result, truth = benchmark_case(tmp_path, 10047, ['friction'])
    assert result.effects == ['friction'], result.notes
    assert any(n.startswith('friction is named by the search') and 'hysteresis' in n
               for n in result.notes), result.notes
    assert result.extended_values['effects.friction_force'] == pytest.approx(
        truth.effects.friction_force, rel=0.3)
