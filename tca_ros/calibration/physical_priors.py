"""Physical priors of a calibration and the plausibility of what it found.

Each calibration parameter has a prior centred on the user's description (the
start params file) with a stated spread, and an independent physical reference
from the thread and the geometry: the heat capacity m_t c_p from the fibre's mass
and specific heat, the heat loss from a convection correlation for a thin heated
cylinder in still air plus radiation (model/heat_transfer.py), stiffness and
actuation from the thread preset (scale 1). A calibrated value past its stated
physical limits is **implausible**: the fit spent its freedom there to stand in for
something the model lacks (docs/calibration.md, "Physical priors").
"""
from dataclasses import dataclass
import math

from tca_ros.model.heat_transfer import natural_convection_coefficient, radiation_coefficient, \
    REFERENCE_RISE_K, STILL_AIR_EMISSIVITY as EMISSIVITY
from tca_ros.model.thermal import heat_capacity, surface_area

#: parameters whose uncertainty is in their unit (the rest relative: x/÷ (1 + u))
LINEAR = ('expansion_zero_temperature', 'actuation_lag', 'expansion_plateau_temperature',
          'ambient_temperature')
#: the actuation lag's prior centre (s): about none (0 is its bound, where a fit could
#: not start)
ACTUATION_LAG_PRIOR = 0.5
#: physical limits (low, high) of value / physical reference (ratio parameters)
PLAUSIBLE_RATIO = {
    'heat_capacity': (0.5, 2.0),
    'heat_loss': (1.0 / 3.0, 3.0),  # still air; a fan or a liquid is another condition
    'actuation_gain': (0.25, 4.0),
    'stiffness_scale': (1.0 / 3.0, 3.0),
    'delivered_power_ratio': (0.5, 1.2),
}
#: absolute limits (low, high) of parameters with no reference ratio (unit of each)
PLAUSIBLE_RANGE = {
    'expansion_zero_temperature': (-60.0, None),  # degC: a nearly linear Gamma(T) below it
    'actuation_lag': (None, 60.0),  # s
    # degC: the top of nylon 6,6's glass transition lies above it, dry or wet (G50)
    'expansion_plateau_temperature': (40.0, None),
}
#: |z| beyond which a value has left what the description stated: a finding to explain
SHIFT_Z = 2.0
#: |z| beyond which values within SHIFT_Z may still have left the description together
#: (:func:`jointly_shifted`)
JOINT_Z = 1.5


def joint_bound(m):
    """Return the bound of the sum of m values' z^2 (-): as rare as one value past SHIFT_Z.

    The chi-square quantile with m degrees of freedom at the two-sided normal tail
    beyond SHIFT_Z (4.0 for one value, 6.18 for two, 8.02 for three).
    """
    from scipy.stats import chi2, norm
    return float(chi2.isf(2.0 * norm.sf(SHIFT_Z), m))


def jointly_shifted(zs):
    """Return the names of ``zs`` ({name: z}) that left the description together (a set).

    Each value within SHIFT_Z prior spreads alone but beyond JOINT_Z; those
    together are a finding when the sum of their z^2 passes :func:`joint_bound`:
    as unlikely under the description as one value beyond SHIFT_Z. A power loss of
    9 % described exactly, 20 Hz with no thermometer, moves the heat capacity
    +1.9, the heat loss +1.8 and the actuation gain -1.6 spreads (confusion
    benchmark 10034): none is a finding alone, the three together are (9.2 against
    8.02; decisions G80). Empty when they are not.
    """
    between = {n: z for n, z in zs.items() if JOINT_Z < abs(z) <= SHIFT_Z}
    if len(between) < 2 or sum(z * z for z in between.values()) <= joint_bound(len(between)):
        return set()
    return set(between)


def prior_spreads(params):
    """Return {name: prior spread} from ``params.uncertainty`` (the description's).

    The params file states how well each value is known (section ``uncertainty``:
    relative, the prior is x/÷ (1 + u), so the spread of ln(value) is ln(1 + u);
    in K or s for the two LINEAR parameters). Its defaults (params_schema.py) are
    what `tca_sim config new` writes: a thread's mass and c_p known to about 15 %
    each (0.3), the heat loss from a still-air correlation (0.6), the paper's
    untwist law on another thread (1), the preset's moduli (0.5), the damping and
    the lag not known, the power per logged watt to 25 %.
    """
    stated = params.uncertainty
    out = {}
    for name in fields_of(stated):
        value = float(getattr(stated, name))
        out[name] = value if name in LINEAR else math.log1p(value)
    return out


def fields_of(stated):
    """Return the field names of an UncertaintyParams."""
    from dataclasses import fields
    return [f.name for f in fields(stated)]


def still_air_heat_loss(params):
    """Return h A_0 (W/K) of the twisted thread in still air, convection and radiation.

    Morgan's correlation on the thread's diameter 2 r_t at REFERENCE_RISE_K above
    ambient plus the linearised radiation at EMISSIVITY, on the smooth area A_0
    (the roughness factor c_s of eq. (1) is what the correlation already gives:
    for the paper's thread, 55 W/(m^2 K) against its h c_s = 57.5).
    """
    ambient = params.thermal.ambient_temperature
    d = 2.0 * params.fiber.radius
    h = natural_convection_coefficient(d, REFERENCE_RISE_K, ambient) \
        + radiation_coefficient(EMISSIVITY, REFERENCE_RISE_K, ambient)
    return h * surface_area(params.fiber)


def physical_reference(params):
    """Return {name: (value, how)}: each parameter's physical estimate from the description."""
    return {
        'heat_capacity': (heat_capacity(params.fiber), 'm_t c_p of the thread'),
        'heat_loss': (still_air_heat_loss(params), 'thin cylinder in still air'),
        'actuation_gain': (1.0, "the paper's untwist law"),
        'stiffness_scale': (1.0, "the thread preset's moduli"),
        'delivered_power_ratio': (1.0, 'the logged power heats the thread'),
    }


@dataclass
class Plausibility:
    """One calibrated value beside its prior and its physical reference."""

    name: str
    unit: str
    value: float
    prior: float
    z: float  # (value - prior) / prior spread, in fit coordinates
    reference: float  # physical estimate (nan where there is none)
    how: str
    low: float  # plausible limits (unit; nan: open)
    high: float
    implausible: bool
    jointly: bool = False  # within SHIFT_Z, but left the description with others (G80)

    @property
    def shifted(self):
        """Return True when the value left its prior: a finding.

        Beyond SHIFT_Z spreads alone, or beyond JOINT_Z together with others
        (:func:`jointly_shifted`).
        """
        return abs(self.z) > SHIFT_Z or self.jointly

    @property
    def ratio(self):
        """Return value / physical reference (-), nan without one."""
        return self.value / self.reference if self.reference > 0.0 else float('nan')


def plausibility(parameters, values, params, aside=()):
    """Return [Plausibility] of calibrated ``values`` ({name: value}) of ``parameters``.

    ``parameters``: {name: engine.Parameter} (priors); ``params``: the start TcaParams;
    ``aside``: names whose shift is no evidence (a sensor's drift made it), left out
    of the values judged together (:func:`jointly_shifted`).
    """
    reference = physical_reference(params)
    rows = []
    for name, value in values.items():
        par = parameters.get(name)
        if par is None:
            continue
        z = (par.to_fit(value) - par.to_fit(par.prior)) / par.spread
        ref, how = reference.get(name, (float('nan'), ''))
        if name in PLAUSIBLE_RATIO and ref > 0.0:
            low, high = (ref * k for k in PLAUSIBLE_RATIO[name])
        else:
            low, high = PLAUSIBLE_RANGE.get(name, (None, None))
        low = float('nan') if low is None else low
        high = float('nan') if high is None else high
        bad = bool(value < low or value > high)
        rows.append(Plausibility(name, par.unit, float(value), par.prior, float(z),
                                 float(ref), how, low, high, bad))
    together = jointly_shifted({r.name: r.z for r in rows
                                if not r.implausible and r.name not in aside})
    for row in rows:
        row.jointly = row.name in together
    return rows


#: what a finding that stands for no catalogue effect is said to be (G82)
NO_EFFECT_MOVES_IT = 'no catalogue effect moves it that way'
#: catalogue effects (model/effects.py) a shift of each calibrated value can stand for,
#: by the shift's direction (+1 up, -1 down): an effect moves a value its own way only,
#: and a shift no effect makes stands for none (decisions G82)
STANDS_FOR = {
    'delivered_power_ratio': {-1: ('power_loss',)},
    # a slower response: a lag, or a play the stroke waits out, on the temperature
    # (hysteresis, G54) or on the end's force (friction, G93); a faster one: a loss that
    # grows with the temperature (a shorter tau when hot)
    'heat_capacity': {1: ('second_thermal_lag', 'sensor_lag', 'dead_time', 'hysteresis',
                          'friction'),
                      -1: ('radiation', 'nonlinear_convection')},
    'stiffness_scale': {-1: ('modulus_softening', 'creep')},
    # on the convex stroke-temperature relation of eq. (2) a warmer room strokes more
    # per kelvin, a colder one less (without a thermometer nothing else tells)
    'actuation_gain': {1: ('ambient_offset',),
                       -1: ('power_loss', 'modulus_softening', 'ambient_offset')},
    'damping': {1: ('second_thermal_lag', 'sensor_lag', 'friction', 'hysteresis')},
    'actuation_lag': {1: ('second_thermal_lag', 'sensor_lag', 'dead_time')},
    # eq. (2) reads T - T_z: a room offset by d moves the stroke as T_z moved by -d
    'expansion_zero_temperature': dict.fromkeys(
        (1, -1), ('modulus_softening', 'hysteresis', 'ambient_offset')),
    # a stroke that stops growing when hot: the coil softening under its load
    'expansion_plateau_temperature': {-1: ('modulus_softening',)},
}
#: the heat loss, read with the time constant (:func:`stands_for`)
#: an ambient offset either way: on the convex stroke-temperature relation of eq. (2) a
#: warmer room strokes more per watt, which a calibration takes up as a higher steady rise
#: (the loss down) as well as a higher gain, a colder room the reverse (decisions G90)
HEAT_LOSS_STANDS_FOR = {
    'steady': {1: ('power_loss', 'ambient_offset'), -1: ('ambient_offset',)},
    'moved': {1: ('radiation', 'nonlinear_convection', 'power_loss', 'ambient_offset'),
              -1: ('nonlinear_convection', 'ambient_offset')},
}
TAU_STEADY_Z = 1.0  # |z| of the time constant below which it counts as unchanged


def stands_for(name, z, tau_z=None):
    """Return the catalogue effects a shift of calibrated ``name`` by ``z`` spreads can stand for.

    Signed: each effect moves a value one way (a lag slows the response, so a heat
    capacity moved down stands for none of the lags); a shift no catalogue effect
    makes stands for none, and stays a finding the catalogue cannot explain.
    The heat loss is read with the time constant: a steady rise that moved with tau
    unchanged (|``tau_z``| < TAU_STEADY_Z prior spreads) is the power heating the
    thread (power_loss, the loss up); with tau it is the loss itself (radiation,
    nonlinear convection, or another air flow: a condition, conditions.py), or still a
    power loss that the priors let the heat capacity follow only part of the way (a
    23 % loss described to 4 %: heat loss +6.1 spreads, heat capacity +2.8, tau
    0.87 x); a loss moved down with tau only a convection exponent makes (the loss
    falls below the reference rise where n > 0). Either way, and with tau or without,
    it may be a room other than described (an ambient offset: a warmer room moves the
    loss down, a colder one up).
    """
    sign = 1 if z > 0.0 else -1
    if name == 'heat_loss':
        steady = tau_z is not None and abs(tau_z) < TAU_STEADY_Z
        return HEAT_LOSS_STANDS_FOR['steady' if steady else 'moved'].get(sign, ())
    return STANDS_FOR.get(name, {}).get(sign, ())


def moves_the_other_way(name, z, tau_z=None):
    """Return the catalogue effects that move calibrated ``name`` against a shift of ``z`` spreads.

    Those :func:`stands_for` gives for the opposite shift and not for this one (an
    ambient offset moves the actuation gain either way with its sign, so it is
    against neither). A fit of such an effect that still needs the value shifted
    this way has its effect's own signature undone by the nominal value (decisions
    G83).
    """
    return tuple(e for e in stands_for(name, -z, tau_z) if e not in stands_for(name, z, tau_z))


def undone_findings(cal, effects):
    """Return [(name, z, effects)] of Calibration ``cal``'s findings that ``effects`` move against.

    ``cal``: a calibration with the catalogue ``effects`` fitted jointly with the
    nominal parameters; each finding it leaves (Calibration.findings) whose value
    one of those effects moves the other way (:func:`moves_the_other_way`), with
    those effects. Such a fit explains the records only with its effect's own
    signature undone: fitted larger than the records ask, and a nominal value moved
    past its description to take the excess back (a softening fitted where a sensor
    reads nonlinearly, the actuation gain +2.9 spreads up: decisions G83).
    """
    tau_z = cal.time_constant_z()
    out = []
    for name, z, _ in cal.findings():
        against = tuple(e for e in moves_the_other_way(name, z, tau_z) if e in effects)
        if against:
            out.append((name, z, against))
    return out


def finding_causes(name, z, effects, tau_z=None, tau_determined=True):
    """Return the words naming what a finding of ``name`` (shifted ``z`` spreads) stands for.

    The catalogue ``effects`` (stands_for); a heat loss above the description's
    with the time constant moved, or not determined by the records
    (``tau_determined``), is also what another air flow does (a draught, a fan):
    not an effect of the muscle but a condition of the record, which a
    ``# environment:`` header gives its own heat-loss scale (conditions.py).
    """
    words = (' or '.join(effects) if effects
             else f'an effect the model lacks ({NO_EFFECT_MOVES_IT})')
    steady = tau_z is not None and abs(tau_z) < TAU_STEADY_Z and tau_determined
    if name == 'heat_loss' and z > 0.0 and not steady:
        words += (', or more air flow than the description assumes (a draught, a fan: '
                  "a condition of the record, which its '# environment:' header fits "
                  'with a heat-loss scale of its own)')
    return words


def finding_causes_of(cal, name, z, effects):
    """Return :func:`finding_causes` of a finding of Calibration ``cal`` (its tau read in)."""
    tau = cal.derived().get('thermal_time_constant')
    return finding_causes(name, z, effects, cal.time_constant_z(),
                          tau is None or tau.determined)


def degenerate_combinations(estimates, parameters, correlation, names, threshold=0.9):
    """Return [(a, b, kind, spread)]: pairs the records fix only in combination.

    Two parameters, at least one not determined by the records, whose posterior
    correlation exceeds ``threshold`` in magnitude. For two log parameters the
    records fix their product (kind 'product', correlation < 0) or ratio ('ratio',
    > 0) to the relative ``spread`` (-); otherwise a linear combination in fit
    coordinates ('combination', spread nan). The priors share the rest between them.
    """
    out = []
    if correlation is None:
        return out
    for i, a in enumerate(names):
        for j in range(i + 1, len(names)):
            b = names[j]
            ea, eb = estimates.get(a), estimates.get(b)
            if ea is None or eb is None or (ea.determined and eb.determined):
                continue
            rho = correlation[i, j]
            if not abs(rho) >= threshold:
                continue
            if parameters[a].log and parameters[b].log:
                sa, sb = ea.stderr / ea.value, eb.stderr / eb.value
                var = sa ** 2 + sb ** 2 - 2.0 * abs(rho) * sa * sb  # of ln a +- ln b
                out.append((a, b, 'ratio' if rho > 0 else 'product', math.sqrt(max(var, 0.0))))
            else:
                out.append((a, b, 'combination', float('nan')))
    return out
