"""Search spaces of the candidate extensions: bounds, scaling and screening starts.

Each effect of ``tca_ros.model.effects.CATALOGUE`` is fitted over the parameters it
owns, within bounds wider than any record we generate (the fit must not know the
generator's ranges) but still physical. Coil contact is special: its parameter
acts only once the stroke reaches the stop, so its screening starts are placed
where the stop would cut the nominal peak contraction of the record.
"""
from dataclasses import dataclass, field
import math

from tca_ros.model.effects import CATALOGUE, heating_power, true_ambient
from tca_ros.model.heat_transfer import radiation_coefficient, REFERENCE_RISE_K
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import loaded_length
from tca_ros.model.kinetostatics import pitch_angle_of_length
from tca_ros.model.params_schema import SPECS
from tca_ros.model.thermal import surface_area, thermal_conductance


@dataclass(frozen=True)
class ParameterSpace:
    """Bounds and scaling of one fitted parameter (dotted name, schema units)."""

    name: str
    low: float
    high: float
    log: bool = False

    @property
    def unit(self):
        """Return the parameter's unit from the schema."""
        return SPECS[self.name].unit

    def to_unit(self, value):
        """Return ``value`` mapped to [0, 1] (linear or logarithmic)."""
        if self.log:
            z = math.log(value / self.low) / math.log(self.high / self.low)
        else:
            z = (value - self.low) / (self.high - self.low)
        return min(max(z, 0.0), 1.0)

    def from_unit(self, z):
        """Return the parameter value at ``z`` in [0, 1]."""
        z = min(max(float(z), 0.0), 1.0)
        if self.log:
            return self.low * (self.high / self.low) ** z
        return self.low + z * (self.high - self.low)


#: Fit bounds (schema units) and screening starts of each effect parameter.
_SPACES = {
    'effects.creep_compliance': (ParameterSpace('effects.creep_compliance', 0.0, 0.05),
                                 (0.003, 0.01, 0.025)),
    'effects.creep_time_constant': (ParameterSpace('effects.creep_time_constant', 2.0, 400.0,
                                                   log=True), (15.0, 60.0)),
    'effects.hysteresis_width': (ParameterSpace('effects.hysteresis_width', 0.0, 40.0),
                                 (4.0, 10.0, 20.0)),
    'effects.emissivity': (ParameterSpace('effects.emissivity', 0.0, 1.0), (0.3, 0.6, 0.95)),
    'effects.convection_exponent': (ParameterSpace('effects.convection_exponent', 0.0, 1.0),
                                    (0.1, 0.25, 0.5)),
    'effects.extra_softening': (ParameterSpace('effects.extra_softening', 0.0, 3e7),
                                (3e6, 8e6, 1.6e7)),
    'effects.sensor_lag': (ParameterSpace('effects.sensor_lag', 0.0, 3.0), (0.1, 0.3, 0.8)),
    'effects.ambient_offset': (ParameterSpace('effects.ambient_offset', -15.0, 15.0),
                               (-6.0, -2.0, 2.0, 6.0)),
    'effects.power_loss_fraction': (ParameterSpace('effects.power_loss_fraction', 0.0, 0.6),
                                    (0.05, 0.15, 0.3)),
    'effects.dead_time': (ParameterSpace('effects.dead_time', 0.0, 5.0), (0.2, 0.6, 1.5)),
    'effects.second_thermal_lag': (ParameterSpace('effects.second_thermal_lag', 0.0, 30.0),
                                   (0.5, 2.0, 6.0)),
    # F_c / k of 0.1 N is ~4 mm on the 23 N/m free-stroke coil: beyond a recorded offset
    'effects.friction_force': (ParameterSpace('effects.friction_force', 0.0, 0.1),
                               (0.005, 0.02, 0.05)),
    # where the end starts in its band: at rest (0) or left at an edge by a heating (-1, 1)
    'effects.friction_start': (ParameterSpace('effects.friction_start', -1.0, 1.0),
                               (-1.0, 0.0, 1.0)),
}
#: parameters whose range ends are states a muscle is found in, not limits a fit runs
#: into: a friction-held end starts at an edge of its band after any heating
START_STATES = ('effects.friction_start',)


def effect_space(name):
    """Return (ParameterSpace, screening starts) of a catalogue effect parameter (dotted).

    Raises KeyError for a name that no catalogue effect owns.
    """
    return _SPACES[name]


#: Nominal parameters a recalibration may move while an effect is fitted: name ->
#: (factor below, factor above) the calibrated value. Actuation gain (stroke per
#: kelvin), delivered power (steady rise), specific heat (time constant) and damping
#: (a lag the calibration may have given it; docs/diagnosis_method.md, "Calibrate first").
#: Narrower where the description states the value better (recalibration_spaces).
RECALIBRATION = {'fiber.untwist_gain': (0.6, 1.6), 'thermal.delivered_power_ratio': (0.7, 1.4),
                 'fiber.specific_heat': (0.6, 1.6), 'dynamics.damping': (0.05, 1.0)}
#: the description's uncertainty entry (params file ``uncertainty.*``) of each of them
STATED_AS = {'fiber.untwist_gain': 'actuation_gain',
             'thermal.delivered_power_ratio': 'delivered_power_ratio',
             'fiber.specific_heat': 'heat_capacity', 'dynamics.damping': 'damping'}
#: Effects that are one of the RECALIBRATION parameters under another name: a power
#: loss eta scales the heating power as the delivered power ratio r does ((1 - eta) r P,
#: effects.heating_power). Where r is refitted over all of its RECALIBRATION factors, eta
#: is not identifiable and is not searched; where the description states r more tightly,
#: the loss beyond what r may take is the effect's (absorbed_candidates).
ABSORBED = {'power_loss': 'thermal.delivered_power_ratio'}
#: Effects that are an offset from a described value no calibration fits, with the
#: uncertainty entry (in the value's unit) stating how well the description knows it:
#: an ambient offset is the room at T_inf + offset where the description says T_inf
STATED_OFFSETS = {'ambient_offset': ('effects.ambient_offset', 'ambient_temperature')}
#: Effects that change the heat loss h c_s A_0 the description states (the uncertainty
#: entry): radiation of emissivity eps is, linearised at the rise a still-air loss is
#: quoted at (heat_transfer.REFERENCE_RISE_K), 4 eps sigma T_m^3 A_0 more of it (the
#: still-air reference of the heat loss counts radiation in, physical_priors); nonlinear
#: convection of exponent n scales h by (dT / dT_ref)^n, which bends the loss away from
#: the stated one at rises other than dT_ref (heat_loss_at)
LOSS_TWINS = {'radiation': 'heat_loss', 'nonlinear_convection': 'heat_loss'}
#: K, the rises over which a stated heat loss is read: half and twice the rise a still-air
#: loss is quoted at, and that rise (decisions G74)
LOSS_RISES = (0.5 * REFERENCE_RISE_K, REFERENCE_RISE_K, 2.0 * REFERENCE_RISE_K)
#: the uncertainty entry (K) of T_z, which a stroke without a temperature channel cannot
#: tell from the ambient (twin_shift)
CURVATURE_ENTRY = 'expansion_zero_temperature'
CONTACT_START_FRACTIONS = (0.9, 0.75, 0.6, 0.45)  # stop at these fractions of the peak
CONTACT_MARGIN_DEG = 0.05  # alpha_min stays this far below alpha* (validation rule)


@dataclass(frozen=True)
class Candidate:
    """One candidate extension: its name, parameter spaces and screening starts."""

    name: str
    spaces: tuple  # of ParameterSpace
    starts: tuple  # of tuples of values, one per space
    #: {dotted name: (low, high, what)}: a fitted value outside (schema units) is
    #: contradicted by a measurement (``what`` names it)
    measured: dict = field(default_factory=dict)

    @property
    def n_params(self):
        """Return the number of fitted parameters."""
        return len(self.spaces)


def contact_space(params, model, load0, peak_contraction, measured_peak=None):
    """Return the Candidate of 'coil_contact' for a record (bounds and starts in deg).

    The stop bounds the contraction (m) from the loaded reference by
    L0 - l_t sin(alpha_min). Below the angle whose stop equals the nominal peak
    of the training part the cost is flat (the stop never binds), so the starts
    cut the nominal training ``peak_contraction`` (m) to CONTACT_START_FRACTIONS
    of itself, plus one at the ``measured_peak`` (m) when that is lower.
    """
    low = math.degrees(params.coil.min_pitch_angle)
    high = math.degrees(params.coil.pitch_angle) - CONTACT_MARGIN_DEG
    km = make_kinetostatic_model(params, model)
    loaded = loaded_length(km, load0, true_ambient(params.thermal, params.effects))
    starts = []
    fractions = list(CONTACT_START_FRACTIONS)
    if measured_peak is not None and 0.0 < measured_peak < peak_contraction:
        fractions.append(measured_peak / peak_contraction)
    for fraction in fractions:
        angle = math.degrees(pitch_angle_of_length(loaded - fraction * peak_contraction,
                                                   params.fiber))
        if low < angle < high:
            starts.append((angle,))
    space = ParameterSpace('coil.min_pitch_angle_deg', low, high)
    return Candidate('coil_contact', (space,), tuple(starts))


#: K: a thermometer's reading at rest is the ambient within this (a thermocouple's or an
#: infrared camera's stated accuracy is 1-2 K; its noise averages out over the window)
THERMOMETER_TOLERANCE_K = 1.0


def build_candidates(params, model, load0, peak_contraction, names=None,
                     initial_temperature=None, measured_peak=None):
    """Return the Candidates of the catalogue (all, or ``names``), catalogue order.

    A candidate without starts (coil contact that cannot bind in this record) is
    kept with an empty ``starts`` and reported as not identifiable. When the
    measured ``initial_temperature`` (degC, the records start at rest at ambient) is
    given, its difference from the nominal ambient is one more ambient_offset start,
    and an offset fitted more than THERMOMETER_TOLERANCE_K from it is contradicted
    (``Candidate.measured``, :func:`contradicted_by_measurement`);
    ``peak_contraction`` and ``measured_peak`` (m) are the nominal and measured
    peak contractions of the training part (see ``contact_space``).
    """
    out = []
    for name, dotted in CATALOGUE.items():
        if names is not None and name not in names:
            continue
        if name == 'coil_contact':
            out.append(contact_space(params, model, load0, peak_contraction, measured_peak))
            continue
        spaces = tuple(_SPACES[d][0] for d in dotted)
        grids = [_SPACES[d][1] for d in dotted]
        measured = {}
        if name == 'ambient_offset' and initial_temperature is not None:
            # the fibre of a record that starts at rest is at the ambient: the thermometer
            # measures the offset from the described one (a start, and the range a fitted
            # offset must stay in to be the cause: contradicted_by_measurement)
            space = spaces[0]
            offset = initial_temperature - params.thermal.ambient_temperature
            grids = [tuple(grids[0]) + (min(max(offset, space.low), space.high),)]
            measured = {space.name: (offset - THERMOMETER_TOLERANCE_K,
                                     offset + THERMOMETER_TOLERANCE_K,
                                     f'the thermometer at rest ({initial_temperature:.4g} degC)')}
        starts = [()]
        for grid in grids:
            starts = [s + (v,) for s in starts for v in grid]
        out.append(Candidate(name, spaces, tuple(starts), measured))
    return out


def recalibration_spaces(params, described=None, spreads=None):
    """Return (ParameterSpaces, their current values) of RECALIBRATION around ``params``.

    Log-scaled between the factors of RECALIBRATION times the calibrated value;
    the values are the dotted names' present values (schema units). A parameter at
    zero (a params file without damping) has no scale to refit around and stays fixed.
    With the description ``described`` (TcaParams) and ``spreads`` (STATED_AS's
    uncertainty entries -> prior spread of ln value, physical_priors.prior_spreads),
    each range is also held within SHIFT_Z prior spreads of the described value (and
    always holds the calibrated one): a value the description states to 3 % is not
    refitted by 60 % to take up an effect (docs/diagnosis_method.md, "Calibrate first").
    """
    from tca_ros.calibration.physical_priors import SHIFT_Z
    spaces, values = [], {}
    for name, (low, high) in RECALIBRATION.items():
        value = _dotted(params, name)
        if value <= 0.0:
            continue
        low, high = low * value, high * value
        prior = _dotted(described, name) if described is not None else 0.0
        spread = (spreads or {}).get(STATED_AS[name])
        if prior > 0.0 and spread is not None:
            width = math.exp(SHIFT_Z * spread)
            low = max(low, min(value, prior / width))
            high = min(high, max(value, prior * width))
            if high <= low:  # a range of one value: nothing to refit
                continue
        spaces.append(ParameterSpace(name, low, high, log=True))
        values[name] = value
    return tuple(spaces), values


def _dotted(params, name):
    """Return the float value of dotted ``name`` ('fiber.untwist_gain') in ``params``."""
    section, field_name = name.split('.')
    return float(getattr(getattr(params, section), field_name))


def absorbed_candidates(candidates, recalibration):
    """Return (kept Candidates, names of those a recalibration parameter absorbs).

    ``recalibration``: the ParameterSpaces refitted with every candidate; an
    effect of ABSORBED whose twin is among them over the whole of its RECALIBRATION
    factors (the description states the twin no better than they reach) is dropped
    from the search: the twin takes it. Where the description narrowed the twin's
    range (recalibration_spaces), the effect is searched and credited only with
    what the twin cannot take.
    """
    refitted = {s.name: s for s in recalibration}
    absorbed = []
    for name, twin in ABSORBED.items():
        space = refitted.get(twin)
        if space is None or not any(c.name == name for c in candidates):
            continue
        low, high = RECALIBRATION[twin]
        if space.high / space.low >= (1.0 - 1e-9) * high / low:
            absorbed.append(name)
    return [c for c in candidates if c.name not in absorbed], absorbed


def twin_shift(name, params, described, spreads, thermometer=True):
    """Return how far effect ``name`` in ``params`` moves its twin, in prior spreads, or None.

    An ABSORBED effect is its twin under another name: a power loss eta heats the
    thread as a delivered power ratio r (1 - eta) would (effects.heating_power).
    The shift is |ln(that ratio / the described one)| over the twin's prior spread
    (``spreads``: STATED_AS's uncertainty entries -> spread of ln value,
    physical_priors.prior_spreads, of the description ``described``). Within
    SHIFT_Z spreads the description admits the effect as its twin: the search
    refits the twin that far (recalibration_spaces) and credits the effect only
    beyond. An ambient offset (STATED_OFFSETS) is the described ambient moved: its
    shift is |offset| over the stated uncertainty of the ambient (K). Without a
    temperature channel (``thermometer`` False) the records see the temperature
    only through the stroke, whose expansion rate 2 c2 (T - T_z) of eq. (2) a room
    warmer by o moves as T_z lower by o would: the offset is then admitted within
    the spread of T_inf - T_z, sqrt(u_ambient^2 + u_Tz^2) (decisions G66). None for
    an effect without a twin or a twin without a stated spread. Radiation and nonlinear
    convection (LOSS_TWINS) move the stated heat loss: their shift is the largest
    |ln(loss / stated loss)| over LOSS_RISES (:func:`heat_loss_at`).
    """
    if name in LOSS_TWINS:
        spread = (spreads or {}).get(LOSS_TWINS[name])
        if not spread or described is None:
            return None
        stated = thermal_conductance(described.fiber, described.thermal)
        return max(abs(math.log(heat_loss_at(params, rise) / stated))
                   for rise in LOSS_RISES) / spread
    if name in STATED_OFFSETS:
        dotted, entry = STATED_OFFSETS[name]
        spreads = spreads or {}
        spread = spreads.get(entry)
        if spread and not thermometer:
            spread = math.hypot(spread, spreads.get(CURVATURE_ENTRY, 0.0))
        return abs(_dotted(params, dotted)) / spread if spread else None
    twin = ABSORBED.get(name)
    spread = (spreads or {}).get(STATED_AS.get(twin))
    stated = _dotted(described, twin) if twin is not None and described is not None else 0.0
    if not spread or stated <= 0.0:
        return None
    equivalent = heating_power(1.0, params.effects, _dotted(params, twin))
    return abs(math.log(equivalent / stated)) / spread


def loss_with_radiation(params):
    """Return h c_s A_0 + 4 eps sigma T_m^3 A_0 (W/K): eq. (1)'s loss, radiation linearised.

    T_m (K) is the mean of the true ambient and REFERENCE_RISE_K above it, the rise a
    still-air heat loss is quoted at; eps the 'radiation' effect's emissivity.
    """
    rise = radiation_coefficient(params.effects.emissivity, REFERENCE_RISE_K,
                                 true_ambient(params.thermal, params.effects))
    return thermal_conductance(params.fiber, params.thermal) + rise * surface_area(params.fiber)


def heat_loss_at(params, rise):
    """Return eq. (1)'s loss conductance (W/K) at a ``rise`` (K) above the true ambient.

    h c_s A_0 (rise / dT_ref)^n (nonlinear convection's exponent n, 0 without it)
    plus radiation linearised as in :func:`loss_with_radiation`.
    """
    e = params.effects
    scale = (rise / e.convection_reference_dt) ** e.convection_exponent
    return loss_with_radiation(params) + (scale - 1.0) * thermal_conductance(params.fiber,
                                                                             params.thermal)


def contradicted_by_measurement(effects, values, candidates):
    """Return [(dotted name, value, low, high, what)] of found values a measurement refutes.

    A fitted ambient offset more than THERMOMETER_TOLERANCE_K from what the
    thermometer read at rest (``Candidate.measured``) is not the ambient: it
    stands in for another cause (the intercept of a straight heat loss laid
    through radiation's curved one).
    """
    out = []
    for c in candidates:
        if c.name not in effects:
            continue
        for name, (low, high, what) in c.measured.items():
            value = values.get(name)
            if value is not None and not low <= value <= high:
                out.append((name, value, low, high, what))
    return out


BOUND_SHARE = 0.005  # a fitted value within this share of its range from a bound is at it


def parameters_at_bounds(effects, values, candidates):
    """Return [(dotted name, value, bound)] of the found effects' parameters at a bound.

    A parameter fitted to the end of its physical range (a 15 K ambient offset,
    a 3 s sensor lag) says the data ask for more of it than it can be: the
    effect then stands in for something else and is not named as the cause.
    The lower end counts only where it is not zero (zero is the effect's absence);
    the ends of START_STATES' ranges are states, not limits, and do not count.
    """
    spaces = {s.name: s for c in candidates if c.name in effects for s in c.spaces
              if s.name not in START_STATES}
    out = []
    for name, space in spaces.items():
        value = values.get(name)
        if value is None:
            continue
        z = space.to_unit(value)
        if z >= 1.0 - BOUND_SHARE:
            out.append((name, value, space.high))
        elif z <= BOUND_SHARE and space.low != 0.0:
            out.append((name, value, space.low))
    return out
