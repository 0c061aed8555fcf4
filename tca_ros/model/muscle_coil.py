"""The coil of a maker's muscle: r*, alpha* and l_t from what the maker measured.

A helical coil (self-coiled or on a mandrel) gets its radius from the one diameter
given (or the self-coiled estimate), its pitch angle from the angle or the coil count,
and its fiber length from the natural or the loaded length; a conical coil gets the
spiral of eq. (36) and its equivalent helix. muscle.py calls these and derives the rest
of the params file; the geometric relations themselves are in coil_geometry.py.

Conventions
-----------
- r* is the mean (centreline) coil radius of [1, Table III]. On a mandrel the thread
  lies against the core, so r* = mandrel radius + thread radius; a caliper gives the
  outer diameter, r* = outer radius - thread radius.
- The natural length is l* = l_t sin(alpha*) and the coil count N = l_t cos(alpha*) /
  (2 pi r*) [1, eqs. (24), (26)].
- Coils touch when the gap between neighbouring turns, measured normal to the thread
  on the developed coil cylinder, equals the thread diameter: 2 pi r* sin(alpha_min) =
  2 r_t (see contact_pitch_angle).

References
----------
[1] J. Sun and J. Zhao, "Physics-based modeling of twisted-and-coiled actuators using
    Cosserat rod theory," IEEE Trans. Robot., 2022.
"""
import math

from scipy.optimize import brentq

from tca_ros.model.coil_geometry import coil_count, conical_coil_count, \
    conical_fiber_length, conical_height_of_coil_count, contact_pitch_angle, \
    equivalent_helix, fiber_length_of_natural_length, mandrel_coil_radius, \
    outer_coil_radius, pitch_angle_of_coil_count
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import loaded_length
from tca_ros.model.muscle_spec import check_exactly_one, Derived, MuscleError, SPEC_UNITS
from tca_ros.model.params_schema import SPECS
from tca_ros.model.tca_params import from_flat_dict

#: r* / r_t of the paper's self-coiled TCA (0.227 mm / 0.21 mm, [1] Tables II-III): the
#: estimate of a self-coiled coil radius when the maker gives no diameter.
SELF_COILED_RADIUS_RATIO = 0.227 / 0.21
#: Conical mandrel of [1, Sec. V-A] (config/conical.yaml): the defaults of a conical coil.
PAPER_SPIRAL_PITCH = 10.6e-3  # m
PAPER_CONE_ANGLE_DEG = 12.0  # deg
#: Relative change of l_t at which the loaded-length fixed point stops (the loaded
#: length is proportional to l_t for a uniform helix, so it converges in 1-2 passes).
LENGTH_TOLERANCE = 1e-10
LENGTH_MAX_ITERATIONS = 30
#: Largest pitch angle accepted (deg): the schema's upper bound of coil.pitch_angle_deg.
MAX_PITCH_ANGLE_DEG = SPECS['coil.pitch_angle_deg'].high


def helix_geometry(spec, flat, derived, r_t):
    """Fill coil and fiber length of a helical (self- or mandrel-coiled) TCA.

    ``flat`` (schema name -> value, SI units, angles in deg) gets coil.* and
    fiber.length; ``derived`` gets a Derived per quantity not given; r_t is the
    thread radius (m). Raises MuscleError on a coil that cannot exist.
    """
    for name in ('spiral_pitch', 'cone_angle_deg'):
        if getattr(spec, name) is not None:
            raise MuscleError(name, getattr(spec, name),
                              f'only for a conical coil (this one is {spec.coil})',
                              SPEC_UNITS[name])
    check_exactly_one(spec, 'loaded_length', 'natural_length')
    radius = _coil_radius(spec, r_t, derived)
    if radius <= r_t:
        raise MuscleError(_radius_field(spec), _radius_value(spec),
                          f'gives a coil radius r* = {radius:g} m, not above the thread '
                          f'radius {r_t:g} m (the coil would have no bore)', 'm')
    check_exactly_one(spec, 'pitch_angle_deg', 'coils')
    contact = contact_pitch_angle(radius, r_t)
    alpha_min = contact if spec.min_pitch_angle_deg is None else math.radians(
        spec.min_pitch_angle_deg)
    if spec.min_pitch_angle_deg is None:
        derived['min_pitch_angle_deg'] = Derived(
            math.degrees(contact), 'deg', 'coil contact: sin(alpha_min) = r_t / (pi r*)')
    flat.update({'coil.shape': 'helix', 'coil.radius': radius, 'coil.contact': True,
                 'coil.min_pitch_angle_deg': math.degrees(alpha_min)})
    if spec.pitch_angle_deg is not None:
        alpha = math.radians(spec.pitch_angle_deg)
        _check_pitch(spec, 'pitch_angle_deg', spec.pitch_angle_deg, alpha, alpha_min)
        flat['coil.pitch_angle_deg'] = spec.pitch_angle_deg
        if spec.natural_length is not None:
            length = fiber_length_of_natural_length(spec.natural_length, alpha)
            _set_length(flat, length, 'natural_length', spec.natural_length)
            derived['fiber_length'] = Derived(length, 'm', 'l_t = l* / sin(alpha*), eq. (26)')
        else:
            length = _fiber_length_of_loaded_length(flat, spec)
            derived['fiber_length'] = Derived(
                length, 'm', f'loaded length at ambient under the mass ({spec.model} model)')
    elif spec.natural_length is not None:
        alpha = pitch_angle_of_coil_count(spec.natural_length, radius, spec.coils)
        _check_pitch(spec, 'coils', spec.coils, alpha, alpha_min)
        flat['coil.pitch_angle_deg'] = math.degrees(alpha)
        length = fiber_length_of_natural_length(spec.natural_length, alpha)
        _set_length(flat, length, 'natural_length', spec.natural_length)
        derived['pitch_angle_deg'] = Derived(math.degrees(alpha), 'deg',
                                             'tan(alpha*) = l* / (2 pi r* N)')
        derived['fiber_length'] = Derived(length, 'm', 'l_t = l* / sin(alpha*), eq. (26)')
    else:
        alpha, length = _pitch_of_coils_loaded(flat, spec, radius, alpha_min)
        derived['pitch_angle_deg'] = Derived(
            math.degrees(alpha), 'deg', f'N coils at the loaded length ({spec.model} model)')
        derived['fiber_length'] = Derived(
            length, 'm', f'loaded length at ambient under the mass ({spec.model} model)')
    length = flat['fiber.length']
    alpha = math.radians(flat['coil.pitch_angle_deg'])
    if spec.coils is None:
        derived['coils'] = Derived(coil_count(length, radius, alpha), '-',
                                   'N = l_t cos(alpha*) / (2 pi r*), eq. (24)')
    if spec.natural_length is None:
        derived['natural_length'] = Derived(length * math.sin(alpha), 'm',
                                            'l* = l_t sin(alpha*), eq. (26)')


def _coil_radius(spec, r_t, derived):
    """Return r* (m) from the one diameter given, or the self-coiled estimate."""
    given = [n for n in ('mandrel_diameter', 'coil_diameter', 'outer_diameter')
             if getattr(spec, n) is not None]
    if len(given) > 1:
        raise MuscleError(given[1], getattr(spec, given[1]),
                          f'give one of <mandrel_diameter>, <coil_diameter> and '
                          f'<outer_diameter> (also got <{given[0]}>)',
                          'm')
    if spec.coil == 'self_coiled' and spec.mandrel_diameter is not None:
        raise MuscleError('mandrel_diameter', spec.mandrel_diameter,
                          'a self-coiled muscle has no mandrel (give the coil or outer '
                          'diameter, or none to estimate it)', 'm')
    if spec.mandrel_diameter is not None:
        radius = mandrel_coil_radius(spec.mandrel_diameter, spec.thread_diameter)
        note = 'r* = (mandrel diameter + thread diameter) / 2'
    elif spec.coil_diameter is not None:
        return 0.5 * spec.coil_diameter
    elif spec.outer_diameter is not None:
        radius = outer_coil_radius(spec.outer_diameter, spec.thread_diameter)
        note = 'r* = (outer diameter - thread diameter) / 2'
    elif spec.coil == 'self_coiled':
        radius = SELF_COILED_RADIUS_RATIO * r_t
        note = ("ESTIMATED: r*/r_t of the paper's self-coiled TCA (0.227/0.21); "
                'measure the coil to replace it')
    else:
        raise MuscleError('mandrel_diameter', None, 'a mandrel-coiled muscle needs one of '
                          '<mandrel_diameter>, <coil_diameter> and <outer_diameter>')
    derived['coil_radius'] = Derived(radius, 'm', note)
    return radius


def _radius_field(spec):
    for name in ('mandrel_diameter', 'coil_diameter', 'outer_diameter'):
        if getattr(spec, name) is not None:
            return name
    return 'thread_diameter'


def _radius_value(spec):
    return getattr(spec, _radius_field(spec))


def _check_pitch(spec, name, value, alpha, alpha_min):
    """Refuse a pitch angle at or below contact, or beyond the schema's range."""
    unit = SPEC_UNITS[name]
    if alpha <= alpha_min:
        source = ('the measured contact angle' if spec.min_pitch_angle_deg is not None
                  else 'the contact angle asin(r_t / (pi r*))')
        what = ('' if name == 'pitch_angle_deg'
                else f'gives a pitch angle {math.degrees(alpha):g} deg, ')
        raise MuscleError(name, value, f'{what}at or below {source} '
                          f'{math.degrees(alpha_min):.3g} deg (neighbouring coils would '
                          'overlap)', unit)
    if math.degrees(alpha) > MAX_PITCH_ANGLE_DEG:
        raise MuscleError(name, value, f'gives a pitch angle above {MAX_PITCH_ANGLE_DEG:g} '
                          'deg (a straight thread, not a coil)', unit)


def _set_length(flat, length, name, value):
    """Set fiber.length, refusing a value outside the schema's range."""
    spec = SPECS['fiber.length']
    if not spec.low <= length <= spec.high:
        raise MuscleError(name, value, f'gives a fiber length l_t = {length:g} m outside '
                          f'[{spec.low:g}, {spec.high:g}] m', 'm')
    flat['fiber.length'] = length


def _loaded_length_of(flat, spec, length):
    """Return the static length (m) at ambient under the mass for fiber length (m)."""
    trial = dict(flat)
    trial['fiber.length'] = length
    params = from_flat_dict(trial)
    model = make_kinetostatic_model(params, spec.model)
    return loaded_length(model, params.dynamics.load, params.thermal.ambient_temperature)


def _fiber_length_of_loaded_length(flat, spec):
    """Set and return l_t (m) so that the loaded length at ambient is spec.loaded_length.

    Fixed point l_t <- l_t L / L(l_t), started from l_t = L / sin(alpha*). For a
    uniform helix with the end free to rotate the static strains do not depend on
    l_t, so L(l_t) is proportional to l_t and one pass is exact to the solver's
    tolerance; the iteration guards the contact stop and the rod model's table.
    """
    target = spec.loaded_length
    alpha = math.radians(flat['coil.pitch_angle_deg'])
    length = fiber_length_of_natural_length(target, alpha)
    for _ in range(LENGTH_MAX_ITERATIONS):
        _set_length(flat, length, 'loaded_length', target)
        current = _loaded_length_of(flat, spec, length)
        new = length * target / current
        if abs(new - length) <= LENGTH_TOLERANCE * length:
            _set_length(flat, new, 'loaded_length', target)
            return new
        length = new
    raise MuscleError('loaded_length', target, 'no fiber length found giving this loaded '
                      f'length (fixed point did not converge in {LENGTH_MAX_ITERATIONS} '
                      'passes)', 'm')


def _pitch_of_coils_loaded(flat, spec, radius, alpha_min):
    """Return (alpha* (rad), l_t (m)) giving spec.coils coils at the loaded length.

    Brent's method on alpha* over (alpha_min, MAX_PITCH_ANGLE_DEG]: the
    coil count l_t(alpha) cos(alpha) / (2 pi r*) falls as alpha* grows.
    """
    low = max(alpha_min, math.radians(SPECS['coil.pitch_angle_deg'].low)) * (1.0 + 1e-9)
    high = math.radians(MAX_PITCH_ANGLE_DEG)

    def excess(alpha):
        flat['coil.pitch_angle_deg'] = math.degrees(alpha)
        length = _fiber_length_of_loaded_length(flat, spec)
        return coil_count(length, radius, alpha) - spec.coils

    try:
        f_low, f_high = excess(low), excess(high)
    except MuscleError as exc:
        raise MuscleError('coils', spec.coils, exc.reason, '-') from None
    if f_low < 0.0:
        raise MuscleError('coils', spec.coils, f'more than fit at the loaded length: even at '
                          f'the contact angle {math.degrees(low):.3g} deg only '
                          f'{f_low + spec.coils:.4g} coils do', '-')
    if f_high > 0.0:
        raise MuscleError('coils', spec.coils, 'too many for this loaded length: the pitch '
                          f'angle would exceed {MAX_PITCH_ANGLE_DEG:g} deg', '-')
    alpha = brentq(excess, low, high, xtol=1e-12, rtol=1e-12)
    flat['coil.pitch_angle_deg'] = math.degrees(alpha)
    return alpha, _fiber_length_of_loaded_length(flat, spec)


def conical_geometry(spec, flat, derived):
    """Fill coil and fiber length of a conical TCA (spiral of eq. (36)).

    As ``helix_geometry`` (SI units, angles in deg); the defaults are the paper's
    conical mandrel (PAPER_SPIRAL_PITCH, PAPER_CONE_ANGLE_DEG).
    """
    for name in ('mandrel_diameter', 'coil_diameter', 'outer_diameter', 'pitch_angle_deg',
                 'loaded_length'):
        if getattr(spec, name) is not None:
            raise MuscleError(name, getattr(spec, name), 'not for a conical coil (give '
                              '<spiral_pitch>, <cone_angle_deg> and <coils> or '
                              '<natural_length>)', SPEC_UNITS[name])
    check_exactly_one(spec, 'coils', 'natural_length')
    pitch = PAPER_SPIRAL_PITCH if spec.spiral_pitch is None else spec.spiral_pitch
    cone_deg = PAPER_CONE_ANGLE_DEG if spec.cone_angle_deg is None else spec.cone_angle_deg
    if not cone_deg < 170.0:
        raise MuscleError('cone_angle_deg', cone_deg, 'must be below 170 deg', 'deg')
    if spec.coils is not None:
        height = conical_height_of_coil_count(pitch, spec.coils)
        derived['natural_length'] = Derived(height, 'm', 'z = N p_c, eq. (36)')
        coils = spec.coils
    else:
        height = spec.natural_length
        coils = conical_coil_count(pitch, height)
        derived['coils'] = Derived(coils, '-', 'N = z / p_c, eq. (36)')
    length = conical_fiber_length(pitch, math.radians(cone_deg), height)
    _set_length(flat, length, 'coils' if spec.coils is not None else 'natural_length',
                spec.coils if spec.coils is not None else spec.natural_length)
    derived['fiber_length'] = Derived(length, 'm', 'l_t = s(z), arc length of eq. (37)')
    radius, alpha = equivalent_helix(length, height, coils)
    if math.degrees(alpha) < SPECS['coil.pitch_angle_deg'].low:
        raise MuscleError('spiral_pitch', pitch, 'gives an almost flat spiral (mean pitch '
                          f'angle {math.degrees(alpha):.3g} deg)', 'm')
    derived['coil_radius'] = Derived(radius, 'm', 'equivalent helix: same l_t, height, N')
    derived['pitch_angle_deg'] = Derived(math.degrees(alpha), 'deg',
                                         'equivalent helix: sin(alpha) = z / l_t')
    contact = contact_pitch_angle(radius, flat['fiber.radius'])
    min_deg = (math.degrees(contact) if spec.min_pitch_angle_deg is None
               else spec.min_pitch_angle_deg)
    flat.update({'coil.shape': 'conical', 'coil.radius': radius,
                 'coil.pitch_angle_deg': math.degrees(alpha), 'coil.spiral_pitch': pitch,
                 'coil.cone_angle_deg': cone_deg, 'coil.contact': False,
                 'coil.min_pitch_angle_deg': min_deg})
