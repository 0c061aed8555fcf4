"""In-range parameters the models refused or divided by zero on (issue 10, item 6).

The fuzz campaign found six in-range values the rod table refused ("exact helix
failed or lost monotonicity"), and Love's model raising ZeroDivisionError mid-run.
Each is now supported, or refused at load time in one line naming the field, the
value and the reason (the schema range where the model cannot hold).
"""
import math

import pytest

from tca_ros.model.dynamics import TcaSimulator
from tca_ros.model.params_schema import ParameterError
from tca_ros.model.rod_model import RodKinetostatics, RodTableError
from tca_ros.model.tca_params import from_flat_dict


def _params(**dotted):
    return from_flat_dict({k.replace('__', '.'): v for k, v in dotted.items()})


def _one_line(message, *needles):
    assert '\n' not in message
    for needle in needles:
        assert needle in message, message


def test_a_micrometre_fiber_builds_its_table():
    """fiber.radius = 1e-6 m: the table's y(F) step is now relative to its force span.

    The coil holds micronewtons (k = 1.3e-8 N/m): the table spans 2 nN, and the
    former absolute 1e-7 N difference step left it.
    """
    params = _params(fiber__radius=1e-6, dynamics__load=0.0, dynamics__mass=0.0,
                     model='rod')
    rod = RodKinetostatics(params)
    y = rod.equilibrium_elongation(1e-10, 60.0)
    assert rod.tension(y, 60.0) == pytest.approx(1e-10, rel=1e-3)
    sim = TcaSimulator(params, dt=1e-3)
    for _ in range(100):
        sim.step(0.01)
    assert math.isfinite(sim.state.displacement) and sim.state.displacement > 0.0


def test_pitch_angles_past_60_degrees_are_out_of_range():
    """A coil at 89 deg is a straight fiber: y(F) flat to round-off (the table failed)."""
    with pytest.raises(ParameterError) as info:
        _params(coil__pitch_angle_deg=89.0)
    _one_line(str(info.value), "'coil.pitch_angle_deg' = 89.0", '[0.5, 60] deg')
    rod = RodKinetostatics(_params(coil__pitch_angle_deg=60.0, model='rod'))
    assert rod.temperature_range[1] >= 250.0  # 60 deg: to the melt


@pytest.mark.parametrize('name, value', [('moduli.youngs_modulus', 1e6),
                                         ('moduli.shear_modulus', 1e12)])
def test_a_coil_without_a_regular_hot_helix_fails_when_it_gets_there(name, value):
    """E << G: the exact helix ceases to exist above ~78 degC. The table ends there.

    Below, the model runs; a temperature beyond the table's end raises one line (the
    node marks the muscle broken) instead of refusing the whole parameter set.
    """
    rod = RodKinetostatics(_params(**{name: value, 'model': 'rod'}))
    top = rod.temperature_range[1]
    assert 50.0 < top < 100.0
    y = rod.equilibrium_elongation(0.01, top)  # N: within what this soft coil holds
    assert rod.tension(y, top) == pytest.approx(0.01, rel=1e-2)
    with pytest.raises(RodTableError) as info:
        rod.tension(y, top + 1.0)
    _one_line(str(info.value), 'beyond the rod table', 'no regular exact helix')


@pytest.mark.parametrize('name, value', [('moduli.fiber_modulus', 1e6),
                                         ('moduli.fiber_softening', 1e9)])
def test_a_fiber_that_softens_to_its_floor_before_melting_is_refused(name, value):
    """Eq. (11) would take E_f to its floor within a few kelvin: y(F) is not monotonic."""
    with pytest.raises(ParameterError) as info:
        _params(**{name: value})
    _one_line(str(info.value), "parameter 'moduli.fiber_softening'", 'by 260 degC',
              'lose its stiffness before it melts')


#: One of the 17-in-3000 sets of the fuzz sweep: Love divided by zero at 168 degC.
LOVE_DIVISION = {'model': 'love', 'fiber.specific_heat': 45.46492384812994,
                 'coil.radius': 0.0074584924602632335, 'dynamics.damping': 0.0,
                 'effects.hysteresis_width': 61.07398454073946}


def test_love_refuses_a_coil_its_heated_helix_cannot_describe():
    """|sin a^h| of eqs. (19), (24) passed 1 at 130 degC (a 7.5 mm coil of a 0.21 mm fiber).

    The clamp cos a^h = 0 then gave Love a negative stiffness; the coil ran straight
    and eq. (25) divided by cos a = 0. Refused at load; CST and rod take the set.
    """
    with pytest.raises(ParameterError) as info:
        from_flat_dict(LOVE_DIVISION)
    _one_line(str(info.value), "parameter 'model' = 'love'", "Love's heated helix",
              'sin alpha^h = ', 'use cst or rod')
    cst = from_flat_dict(dict(LOVE_DIVISION, model='cst'))
    sim = TcaSimulator(cst, dt=1e-3)
    for k in range(300):
        sim.step(1.0 if k < 150 else 5.0)
    assert math.isfinite(sim.state.elongation)


def test_love_past_a_straight_coil_raises_one_line_not_a_division(free_stroke):
    from tca_ros.model.kinetostatics import LoveModel
    love = LoveModel(free_stroke.with_values(model='love'))
    past = free_stroke.fiber.length - love.natural_length  # the coil's full stretch (m)
    with pytest.raises(ArithmeticError) as info:
        love.tension(past, 25.0)
    assert not isinstance(info.value, ZeroDivisionError)
    _one_line(str(info.value), 'reaches the fiber length', 'use cst or rod')
