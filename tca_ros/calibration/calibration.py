"""Calibrate a TCA's unmeasurable parameters on its recordings (docs/calibration.md).

A maker knows the geometry, the thread and the hanging mass; the heat loss, the
heat capacity, how strongly the fiber untwists, the stiffness of the coil, the
damping and the power that really heats the thread when only the supply setting
is logged must be fitted. They are fitted jointly over every record given
(different powers and loads share one muscle), by the engine in engine.py:

=========================== ======= ==================================================
calibration parameter       unit    where it acts (params file entries it sets)
=========================== ======= ==================================================
heat_capacity               J/K     m_t c_p of eq. (1) (fiber.specific_heat)
heat_loss                   W/K     h c_s A_0 of eq. (1) (thermal.convection_coefficient)
actuation_gain              -       fiber.untwist_gain on eq. (4)
stiffness_scale             -       moduli.youngs_modulus and moduli.shear_modulus
damping                     N s/m   dynamics.damping, b_t of eq. (18)
delivered_power_ratio       -       thermal.delivered_power_ratio (nominal power only)
resistance                  ohm     electrical.resistance, R0 (with a resistance column)
resistance_temperature_coef 1/K     electrical.temperature_coefficient
resistance_strain_coef      -       electrical.strain_coefficient
expansion_zero_temperature  degC    T_z where dGamma/dT of eq. (2) vanishes: the curvature
                                    of the stroke-temperature characteristic
                                    (fiber.gamma_coefficients c1 = -2 c2 T_z)
actuation_lag               s       lag of the actuating temperature behind eq. (1)'s
                                    (effects.second_thermal_lag)
initial_temperature_rise    K       thermal.initial_temperature_rise: the record begins
                                    that much above ambient (one record; when named in
                                    ``fit``, or by default when starts_warm says so)
effects.<name>              schema  a catalogue effect's parameter (model/effects.py),
                                    when named in ``fit``: the nominal model and one
                                    effect calibrated together (the diagnosis's joint
                                    calibration, docs/diagnosis_method.md)
=========================== ======= ==================================================

Every parameter has a prior centred on the description with a physical spread
(physical_priors.py); the report sets each value beside its prior and a physical
reference and marks it implausible past stated limits. A record without
temperature fixes the thermal time constant C / G by itself and the stroke per
watt (gain / G) only in product: the report says which combinations the records
fixed and which values their priors hold.

The parameters' priors, bounds and apply_calibration are in calibration_parameters.py.
The search simulates with the quasi-static reduction (model/quasistatic.py) and
the config's kinetostatic model; the calibrated parameters are then checked with
the full central-difference dynamics (18) of the same model, and those are the
figures reported.
"""
from dataclasses import dataclass, field
import math

import numpy as np

from tca_ros.calibration import engine
from tca_ros.calibration.calibration_parameters import apply_calibration, calibration_priors, \
    coil_stiffness, damping_bound, DEFAULT_FIT, default_fit, EFFECT_PARAMETERS, \
    effect_priors, MAX_DAMPING_RATIO, OPTIONAL_FIT, PHYSICS_FIT, physics_names, \
    plateau_start  # noqa: F401
from tca_ros.calibration.conditions import environment_priors, environment_scales, \
    held_strength, is_isometric, measured, with_tension
from tca_ros.calibration.predictions import defect_corrections, full_predictions, \
    normalised_rmse, peak_response, predictor, record_params
from tca_ros.calibration.progress import Progress
from tca_ros.calibration.warm_start import starts_warm  # noqa: F401 (calibration.starts_warm)
from tca_ros.model.kinetostatics import static_elongation
from tca_ros.model.static_maps import make_statics

DISPLACEMENT_SCALE_FLOOR = 1e-6  # m, residual scale floor (a good encoder's resolution)
FORCE_SCALE_FLOOR = 1e-5  # N, likewise (a load cell's resolution, 1 mg)
NOMINAL_LEVELS = 2  # a power column with at most this many distinct values is nominal
BASE_NFEV = 40  # solver evaluations of a calibration by default
PHYSICS_NFEV = 15  # more per added physics parameter (PHYSICS_FIT)
#: the finding on the room the thermometer reads at rest (Calibration.room_reading), named
#: as the description's uncertainty entry of the ambient
ROOM = 'ambient_temperature'


class CalibrationError(ValueError):
    """The records and the start config cannot be calibrated (one-line reason)."""


def is_nominal_power(records):
    """Return True when every record's power takes at most NOMINAL_LEVELS values (on/off)."""
    return all(np.unique(r.power).size <= NOMINAL_LEVELS for r in records)


def match_loaded_length(params, length, load, model=None):
    """Return ``params`` with l_t scaled so the loaded length at ambient is ``length`` (m).

    The coil radius and pitch angle are kept: the maker's measured length fixes
    how many coils the muscle has. A few fixed-point passes (the elongation
    under load scales with l_t too).
    """
    for _ in range(6):
        statics = make_statics(params, model)
        current = statics.natural_length + static_elongation(
            statics, load, params.thermal.ambient_temperature)
        if abs(current - length) < 1e-9:
            break
        params = params.with_values(**{'fiber.length': params.fiber.length * length / current})
    return params


@dataclass
class Calibration:
    """Result of ``calibrate``: the calibrated params and how well they fit."""

    start: object  # TcaParams
    params: object  # TcaParams, calibrated
    report: engine.FitReport
    model: str
    supply: str
    channels: list
    nominal_power: bool
    records: list
    start_nrmse: list = field(default_factory=list)  # per record, full dynamics
    nrmse: list = field(default_factory=list)  # per record, full dynamics, calibrated
    start_fit: list = field(default_factory=list)  # per record: full-dynamics contraction (m)
    fit: list = field(default_factory=list)  # the same, calibrated
    notes: list = field(default_factory=list)
    #: per record {channel: full dynamics - quasi-static} the final fit used, or None
    corrections: list = field(default=None, repr=False)
    #: {name: engine.Parameter} of the fitted parameters (their priors and bounds)
    priors: dict = field(default_factory=dict, repr=False)
    #: {name: z} of values shifted beyond the description that a calibration with each
    #: record's drift removed brings back within SHIFT_Z spreads, taking back most of the
    #: shift (its z; diagnosis.nominal.set_aside_drift_shifts): a sensor's drift bent
    #: them, not an effect; :meth:`findings` leaves them out (decisions G78)
    drift_shifts: dict = field(default_factory=dict, repr=False)

    def plausibility(self):
        """Return [Plausibility]: each value beside its prior and physical reference."""
        from tca_ros.calibration.physical_priors import plausibility
        fitted = {k: v.value for k, v in self.report.estimates.items()}
        return plausibility(self.priors, fitted, self.start, aside=self.drift_shifts)

    @property
    def environments(self):
        """Return {environment: heat-loss scale (-) relative to still air} fitted."""
        return environment_scales(self.report.values)

    def derived(self):
        """Return {name: engine.Estimate} of eq. (1)'s time constant (s) and steady rise (K/W).

        tau = C / G and rise = 1 / G of the fitted heat capacity C and loss G, with
        standard errors from their posterior covariance; 'determined' when the
        relative standard error is below the prior's of either alone (the
        records, not the priors, fixed it). Empty unless both were fitted.
        """
        est = self.report.estimates
        if 'heat_capacity' not in est or 'heat_loss' not in est:
            return {}
        names = list(est)
        i, j = names.index('heat_capacity'), names.index('heat_loss')
        c, g = est['heat_capacity'], est['heat_loss']
        sc, sg = c.stderr / c.value, g.stderr / g.value
        rho = self.report.correlation[i, j] if self.report.correlation is not None else 0.0
        rho = float(rho) if np.isfinite(rho) else 0.0
        s_tau = np.sqrt(max(sc ** 2 + sg ** 2 - 2.0 * rho * sc * sg, 0.0))
        prior = min(self.priors['heat_capacity'].spread, self.priors['heat_loss'].spread)
        tau = c.value / g.value
        return {'thermal_time_constant': engine.Estimate(
                    'thermal_time_constant', 's', tau, tau * s_tau, c.prior / g.prior,
                    bool(s_tau < engine.IDENTIFIABLE_RATIO * prior)),
                'steady_rise': engine.Estimate(
                    'steady_rise', 'K/W', 1.0 / g.value, sg / g.value, 1.0 / g.prior,
                    g.determined)}

    def findings(self, implausible=False):
        """Return [(name, z, catalogue effects)] of values beyond their stated uncertainty.

        A calibrated value more than SHIFT_Z prior spreads from the description (and
        still plausible; an implausible one is reported as such) is a finding: the
        effects are those of physical_priors.stands_for. ``implausible``: the values
        past their physical limits too (what they stand for, for the diagnosis).
        The room the thermometer reads at rest, beyond SHIFT_Z from the model's
        (:meth:`room_reading`), is one too, named ROOM, standing for an ambient offset.
        A shift a sensor's drift made (``drift_shifts``) is none.
        """
        from tca_ros.calibration.physical_priors import SHIFT_Z, stands_for
        tau_z = self.time_constant_z()
        out = [(r.name, r.z, stands_for(r.name, r.z, tau_z)) for r in self.plausibility()
               if r.name not in self.drift_shifts
               and ((r.shifted and not r.implausible) or (implausible and r.implausible))]
        room = self.room_reading()
        if room is not None and abs(room[2]) > SHIFT_Z:
            out.append((ROOM, room[2], ('ambient_offset',)))
        return out

    def room_reading(self):
        """Return (read degC, model's room degC, z) of the thermometer at rest, or None.

        A muscle at rest is at the room's temperature: the logged temperature
        before the first power (warm_start.resting_temperature) measures it. z is
        its difference from the room of the calibrated params (the described
        ambient, plus an ambient offset a joint calibration fitted) over the
        stated uncertainty of the ambient and the thermometer's accuracy
        (candidates.THERMOMETER_TOLERANCE_K) together. Beyond SHIFT_Z it is a
        finding on a measured value, not a calibrated one (:meth:`findings`,
        decisions G73). None without a thermometer, or when a record begins warm.
        """
        from tca_ros.calibration.candidates import THERMOMETER_TOLERANCE_K
        from tca_ros.calibration.physical_priors import prior_spreads
        from tca_ros.calibration.warm_start import resting_temperature
        from tca_ros.model.effects import true_ambient
        read = resting_temperature(self.records, self.start.thermal.ambient_temperature)
        if read is None:
            return None
        room = true_ambient(self.params.thermal, self.params.effects)
        spread = math.hypot(prior_spreads(self.start)[ROOM], THERMOMETER_TOLERANCE_K)
        return read, room, (read - room) / spread

    def time_constant_z(self):
        """Return the shift of tau = C / G (eq. 1) from the description's, in prior spreads.

        None unless both the heat capacity and the heat loss were fitted.
        """
        if 'heat_capacity' not in self.priors or 'heat_loss' not in self.priors:
            return None
        v, pr = self.report.values, self.priors
        shift = (np.log(v['heat_capacity'] / pr['heat_capacity'].prior)
                 - np.log(v['heat_loss'] / pr['heat_loss'].prior))
        return float(shift / np.hypot(pr['heat_capacity'].spread, pr['heat_loss'].spread))

    def combinations(self):
        """Return [(a, b, 'product'|'ratio', relative spread)] the records fix jointly only."""
        from tca_ros.calibration.physical_priors import degenerate_combinations
        names = list(self.report.estimates)
        return degenerate_combinations(self.report.estimates, self.priors,
                                       self.report.correlation, names)

    def to_json(self):
        """Return a JSON-ready summary."""
        return {
            'model': self.model, 'channels': self.channels,
            'nominal_power': self.nominal_power,
            'parameters': {k: v.as_dict() for k, v in self.report.estimates.items()},
            'records': [{'source': r.source, 'nrmse_start': a, 'nrmse_calibrated': b}
                        for r, a, b in zip(self.records, self.start_nrmse, self.nrmse)],
            'success': self.report.success, 'message': self.report.message,
            'simulations': self.report.nfev, 'notes': self.notes,
        }


def channels_of(records):
    """Return the channels present in every record (displacement first)."""
    out = ['displacement']
    for c in ('temperature', 'resistance', 'force'):
        if all(getattr(r, c) is not None for r in records):
            out.append(c)
    return out


def prepare_start(params, records, model=None):
    """Return (start params, notes): mass, load and measured header values applied.

    Header ``length_m`` (loaded length at ambient, m) rescales l_t; header
    ``resistance_ohm`` (ohm at ambient) sets R0.
    """
    params, warning = held_strength(params, records)
    notes = [warning] if warning else []
    params = record_params(params, records[0])
    lengths = [float(r.meta['length_m']) for r in records if 'length_m' in r.meta]
    if lengths:
        length = float(np.median(lengths))
        params = match_loaded_length(params, length, float(records[0].load[0]), model)
        notes.append(f'fiber.length set to {params.fiber.length:.4g} m so the loaded length '
                     f'at ambient is the measured {length:.4g} m (header length_m)')
    ohms = [float(r.meta['resistance_ohm']) for r in records if 'resistance_ohm' in r.meta]
    if ohms:
        params = params.with_values(**{'electrical.resistance': float(np.median(ohms))})
        notes.append(f'electrical.resistance set to the measured {np.median(ohms):.4g} ohm '
                     '(header resistance_ohm)')
    return params, notes


def calibrate(records, params, model=None, fit=None, progress=False, max_nfev=None,
              check=True, supply='power', masks=None, start_values=None, like=None,
              physics=True, drift=False):
    """Calibrate ``params`` (start TcaParams) jointly on ``records``; return a Calibration.

    ``fit``: names to fit (default :func:`default_fit`, restricted to what the
    records can inform); ``physics``: True adds PHYSICS_FIT to the default fit: the
    actuation lag and the curvature; False none, the diagnosis's nominal model,
    whose catalogue holds the lag as an effect to find; or a collection of
    PHYSICS_FIT names; ``check``: score start and
    result with the full dynamics (18);
    ``masks``: per record a boolean array of the samples fitted (default all;
    the records are simulated whole either way, e.g. a diagnosis's training
    blocks); ``start_values``: {name: value} the fit starts from (default the
    priors; clipped to each parameter's bounds), e.g. an earlier calibration's;
    ``like``: an earlier Calibration of the same records and masks, whose defect
    corrections are used as they are in a single fit (no first estimate, no
    full-dynamics run: a diagnosis's joint calibrations start next to its
    nominal calibration); ``drift``: fit the displacement and force less a linear
    drift from each record's zero (engine.without_drift), the nuisance a
    diagnosis's verdict removes from the residual it judges.
    """
    if not records:
        raise CalibrationError('records: none given')
    model = model or params.model
    if params.coil.shape != 'helix':
        raise CalibrationError(
            f'coil.shape = {params.coil.shape!r}: calibration needs a helical TCA '
            '(its search runs on the quasi-static reduction, whose static maps are '
            "the uniform helix's; the conical TCA simulates but is not calibrated)")
    if any(is_isometric(r) for r in records):  # every record gets a force channel
        records = [with_tension(r) for r in records]
    channels = channels_of(records)
    nominal = is_nominal_power(records)
    start, notes = prepare_start(params, records, model)
    r0 = start.electrical.resistance
    priors = calibration_priors(start, nominal, 'resistance' in channels, r0, supply,
                                damping_bound(start, model))
    names = list(fit) if fit else default_fit(records, physics)
    warm = [r for r in records if starts_warm(r, start.thermal.ambient_temperature)]
    if not fit and len(records) == 1 and warm:
        names.append('initial_temperature_rise')
        notes.append('the logged temperature falls before any power: the record begins '
                     'warm, thermal.initial_temperature_rise fitted')
    elif len(records) > 1 and warm:
        notes.append(f'{warm[0].source or "a record"}: the logged temperature falls before '
                     'any power, so it begins warm; a calibration over several records takes '
                     'each at rest (fit it alone to estimate its start)')
    unknown = [n for n in names if n not in DEFAULT_FIT + OPTIONAL_FIT + EFFECT_PARAMETERS]
    if unknown:
        raise CalibrationError(f'--fit {unknown[0]!r}: unknown; allowed: '
                               + ', '.join(DEFAULT_FIT + OPTIONAL_FIT)
                               + ', or a catalogue effect parameter ('
                               + ', '.join(EFFECT_PARAMETERS) + ')')
    if 'friction_force' in names and 'effects.friction_force' in names:
        raise CalibrationError("--fit 'effects.friction_force': the same parameter as "
                               "'friction_force'; name it once")
    if len(records) > 1 and 'initial_temperature_rise' in names:
        raise CalibrationError(f"--fit 'initial_temperature_rise': one value cannot stand for "
                               f'the starts of {len(records)} records; fit it on one record')
    priors.update(effect_priors(names, start))
    environments = environment_priors(records)  # a condition, fitted whatever ``fit`` says
    priors.update(environments)
    names += [n for n in environments if n not in names]
    parameters = [priors[n] for n in names if n in priors]
    if not nominal:
        notes.append('power varies beyond on/off: taken as measured, '
                     'delivered_power_ratio not fitted')
    masks = [None] * len(records) if masks is None else [np.asarray(m, bool) for m in masks]
    by_record = {id(r): m for r, m in zip(records, masks)}
    selected = None if masks[0] is None else (lambda r: by_record[id(r)])
    # every record counts equally relative to the others of its rig (metres or newtons)
    peaks = [peak_response(r, m) for r, m in zip(records, masks)]
    medians = {k: float(np.median([p for p, r in zip(peaks, records)
                                   if is_isometric(r) == k]))
               for k in {is_isometric(r) for r in records}}
    weights = [p / medians[is_isometric(r)] for p, r in zip(peaks, records)]
    median_peak = medians.get(False, medians.get(True))
    corrections = like.corrections if like is not None else None
    objective = engine.Objective(records, channels,
                                 predictor(start, model, channels, supply, corrections),
                                 weights=weights, mask=selected, drift=drift)
    bar = Progress(progress, total=(len(parameters) + 1) * 24, stage='calibration')
    initial = {'displacement': 0.05 * median_peak, 'temperature': 2.0,
               'force': 0.05 * medians.get(True, 0.01),
               'resistance': 0.01 * r0}
    if max_nfev is None:  # the added physics couples to the rest: more iterations
        max_nfev = BASE_NFEV + PHYSICS_NFEV * sum(p.name in PHYSICS_FIT for p in parameters)
    options = dict(initial_scale=initial, max_nfev=max_nfev, progress=bar,
                   scale_floor={'displacement': DISPLACEMENT_SCALE_FLOOR,
                                'force': FORCE_SCALE_FLOOR})
    start_values = dict(start_values or {})
    if 'expansion_plateau_temperature' in names:
        start_values.setdefault('expansion_plateau_temperature', plateau_start(start, records))
    first = {p.name: min(max(start_values[p.name], p.low), p.high) for p in parameters
             if p.name in start_values}
    report = engine.fit(objective, parameters, start=first, **options)
    if like is None:
        # defect correction: refit with the full dynamics' difference at the estimate
        # added, so the result fits the model the user runs, not its reduction
        try:
            corrections = defect_corrections(apply_calibration(start, report.values),
                                             records, model, channels, supply,
                                             environment_scales(report.values))
        except (ValueError, ArithmeticError, RuntimeError) as exc:
            notes.append('the full dynamics cannot simulate the first estimate, so it is '
                         f'not defect-corrected ({str(exc).splitlines()[0]})')
    if corrections is not None and like is None:
        objective = engine.Objective(records, channels,
                                     predictor(start, model, channels, supply, corrections),
                                     weights=weights, mask=selected, drift=drift)
        first_nfev = report.nfev
        report = engine.fit(objective, parameters, start=report.values, **options)
        report.nfev += first_nfev
    bar.close()
    calibrated = apply_calibration(start, report.values)
    result = Calibration(start=start, params=calibrated, report=report, model=model,
                         supply=supply,
                         channels=channels, nominal_power=nominal, records=list(records),
                         notes=notes, corrections=corrections,
                         priors={p.name: p for p in parameters})
    if check:
        for params, fits, scores in ((start, result.start_fit, result.start_nrmse),
                                     (calibrated, result.fit, result.nrmse)):
            for r, p in zip(records, full_predictions(params, records, model,
                                                      ['displacement', 'force'], supply,
                                                      result.environments)):
                fits.append(p['displacement'])
                if is_isometric(r):
                    force = p['force'] - p['force'][0]
                    scores.append(float(np.sqrt(np.mean((measured(r) - force) ** 2)))
                                  / peak_response(r))
                else:
                    scores.append(normalised_rmse(r, p['displacement']))
    return result
