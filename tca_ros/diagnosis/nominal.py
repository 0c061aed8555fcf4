"""The nominal model a diagnosis judges effects against, and its fitting problems.

Read the records, set each one's mass and initial load, calibrate the nominal
parameters on the training parts (calibration.py, masked by holdout.py), build
one FitProblem per record, and the catalogue candidates with starts from the
records. Used by identification.diagnose.
"""
import os

import numpy as np

from tca_ros.calibration.candidates import build_candidates, recalibration_spaces
from tca_ros.calibration.physical_priors import prior_spreads
from tca_ros.calibration.warm_start import resting_temperature
from tca_ros.diagnosis.fitting import FitProblem
from tca_ros.diagnosis.holdout import DEFAULT_VALIDATION
from tca_ros.records.data import DataError, read_record
from tca_ros.records.record_ops import decimated

PEAK_PERCENTILE = 99.5  # % of measured contraction taken as its peak (noise-robust)
CALIBRATION_RATE_HZ = 10.0  # the calibrate-first step fits block means at about this rate
WARM_START_NOTE_K = 1.0  # K: a fitted initial rise from here on is said in the notes
#: share of a finding's shift (its z) a calibration less the sensor's drift may leave at
#: most for the drift to have made it (set_aside_drift_shifts): most of it, not a hair
DRIFT_LEAVES = 0.5


class DiagnosisError(ValueError):
    """The nominal model cannot be simulated on the record (CLI exit status 1).

    A ValueError, as the simulator's own errors are, but not a DataError: the CLI
    maps it to exit status 1 (fit failed), DataError to 2 (bad input).
    """


def nominal_with_fallback(records, params_of, cal, from_file, base, options, notes, paths):
    """Return (problems, problem, start values, nominal sims, cal, params per record).

    The nominal problems (:func:`nominal_problems`) with the calibrated
    ``params_of`` (``cal`` the Calibration, or ``from_file`` for a calibrated
    params file: either keeps the nominal parameters free in the search). When
    the training part's calibration drove a record outside the model's range
    (e.g. beyond the melt on the held-out part), the diagnosis goes on against
    the description ``base``: ``cal`` becomes None and the last of ``notes``
    (the calibration's) says why. Raises DataError for records whose channels
    differ, DiagnosisError when not even the description can simulate them.
    """
    model = options['model']
    try:
        return nominal_problems(records, params_of, cal is not None or from_file, options,
                                paths, cal.environments if cal is not None else None,
                                described=base) + (cal, params_of)
    except DataError:
        raise
    except (ValueError, ArithmeticError) as exc:  # StabilityError is a ValueError
        if cal is None:
            raise DiagnosisError(f'{paths[0]}: the nominal model cannot simulate this '
                                 f'record with model={model} ({exc})') from None
        params_of = [record_nominal(base, r) for r in records]
        notes[-1] = (f'calibration not used: its nominal model cannot simulate the whole '
                     f'record ({str(exc).splitlines()[0]})')
    try:
        return nominal_problems(records, params_of, False, options, paths) + (None, params_of)
    except (ValueError, ArithmeticError) as again:
        raise DiagnosisError(f'{paths[0]}: the nominal model cannot simulate this '
                             f'record with model={model} ({again})') from None


def nominal_problems(records, params_of, recalibrated, options, paths, scales=None,
                     described=None):
    """Return (problems, problem or set, start values, nominal simulations).

    ``recalibrated``: the nominal parameters stay free in the search
    (candidates.recalibration_spaces), within the stated uncertainty of the
    description ``described`` (TcaParams) where given; ``scales``: {environment:
    heat-loss scale} a calibration fitted: a record's environment (``# environment:``)
    scales its heat loss as the calibration's predictions do
    (conditions.in_environment; an environment not fitted takes its prior's, a fan's
    2.5x). Raises ValueError (a DataError for records whose channels differ) or
    ArithmeticError when the nominal model cannot simulate a record.
    """
    from tca_ros.calibration.conditions import in_environment
    from tca_ros.diagnosis.problem_set import FitProblemSet
    problems = [FitProblem(r, in_environment(p, r, scales), **options)
                for r, p in zip(records, params_of)]
    try:
        problem = problems[0] if len(problems) == 1 else FitProblemSet(problems)
    except ValueError as exc:
        raise DataError(f'{paths[1]}: row 1, column {"temperature"!r}: {exc}') from None
    start_values = {}
    if recalibrated:  # the nominal parameters stay free in the search
        spreads = prior_spreads(described) if described is not None else None
        spaces, start_values = recalibration_spaces(params_of[0], described, spreads)
        problem.recalibration = spaces
        for p in problems:
            p.recalibration = spaces
    problem.set_base(start_values)
    for p in problems:
        p.scale_channels_by(start_values)
    nominals = [p.simulate_full(start_values) for p in problems]
    return problems, problem, start_values, nominals


def read_any(path, config):
    """Return the Record of a CSV or a rosbag2 recording (a bag needs ``config``)."""
    from tca_ros.params.files import load_params
    from tca_ros.records.data import read_bag_record
    if os.path.isdir(path) or str(path).endswith('.mcap'):
        if config is None:
            raise DataError(f'{path}: row 1, column {"tca"!r}: a rosbag2 recording '
                            'carries no config name; pass --config')
        return read_bag_record(path, tca=config, mass_kg=load_params(config).dynamics.mass)
    return read_record(path)


def record_nominal(params, record):
    """Return ``params`` with the record's mass (kg) and initial load (N)."""
    return params.with_values(**{'dynamics.mass': record.mass,
                                 'dynamics.load': float(record.load[0])})


def candidates_of(records, params, model, problems, nominals):
    """Return the catalogue candidates with data-driven starts from the records."""
    # a thermometer at rest reads the room (None: no thermometer, or a warm start)
    initial = resting_temperature(records, params.thermal.ambient_temperature)
    peaks = [float(np.percentile(r.displacement[p.full_train_mask], PEAK_PERCENTILE))
             for r, p in zip(records, problems)]
    model_peaks = [float(n.displacement[p.full_train_mask].max())
                   for n, p in zip(nominals, problems)]
    i = int(np.argmax(model_peaks))  # the record whose stroke a stop would cut first
    return build_candidates(params, model, float(records[i].load[0]), model_peaks[i],
                            initial_temperature=initial, measured_peak=peaks[i])


def calibrate_training_part(records, params_of, model, fraction, supply, progress,
                            validation=DEFAULT_VALIDATION, **calibrate_options):
    """Return (Calibration or None, [params per record], note): nominal fitted on training.

    Each record is simulated whole on a grid of about CALIBRATION_RATE_HZ; only
    its training samples (holdout.py) enter the fit, or every sample when
    ``fraction`` is None. ``calibrate_options``
    (fit, start_values, max_nfev) go to calibration.calibrate.
    """
    from tca_ros.calibration.calibration import calibrate, CalibrationError
    from tca_ros.calibration.predictions import record_params
    from tca_ros.diagnosis.holdout import make_holdout
    from tca_ros.model.kinetostatic_models import make_kinetostatic_model
    from tca_ros.model.quasistatic import QuasiStaticUnsupported
    coarse = [decimated(r, CALIBRATION_RATE_HZ) for r in records]
    masks = None  # fraction None: the whole records (a joint fit's confirmation, joint.py)
    if fraction is not None:
        holdout = make_holdout(fraction, validation)
        masks = [holdout.train_mask(c.time, r.duration) for c, r in zip(coarse, records)]
    try:
        calibrate_options.setdefault('physics', False)  # the catalogue holds the lag
        cal = calibrate(coarse, params_of[0], model=model, check=False, supply=supply,
                        progress=progress, masks=masks, **calibrate_options)
    except (CalibrationError, QuasiStaticUnsupported, ValueError, ArithmeticError) as exc:
        return None, params_of, f'calibration skipped ({str(exc).splitlines()[0]})'
    calibrated = [record_params(cal.params, r).with_values(model=model) for r in records]
    try:  # the stepper's model must exist for the calibrated values (the rod table)
        make_kinetostatic_model(calibrated[0], model)
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        return None, params_of, (f'calibration not used: the {model} model cannot represent '
                                 f'its result ({str(exc).splitlines()[0]})')
    fitted = [e.name for e in cal.report.estimates.values() if e.determined]
    note = ('nominal parameters calibrated on the training part: '
            + (', '.join(fitted) if fitted else 'none determined'))
    rise = cal.params.thermal.initial_temperature_rise
    if 'initial_temperature_rise' in fitted and rise >= WARM_START_NOTE_K:
        note += (f'; the record begins {rise:.3g} K above ambient (not at rest: '
                 'thermal.initial_temperature_rise)')
    return cal, calibrated, note


def set_aside_drift_shifts(cal, records, params_of, model, fraction, supply, validation):
    """Return (Calibration, note or None): ``cal`` less the findings a sensor's drift made.

    A value the training part's calibration moved beyond SHIFT_Z prior spreads is
    a finding, evidence of an effect (findings.py). That calibration fits the
    residual as it is (decisions G52), so a sensor's drift from the record's zero,
    which the verdict reads as noise, can bend a stated value too: a defect-free
    muscle described exactly, its encoder drifting 0.1-0.4 mm over the record
    (confusion benchmark 9804, 20 Hz), got its stiffness scale moved -3.8 spreads
    and a modulus softening named for it; less the drift it moves -0.2. The
    nominal parameters are calibrated again with each record's drift removed
    (calibrate's ``drift``); a finding whose value that brings back within SHIFT_Z
    spreads (and not jointly beyond JOINT_Z with others: physical_priors.jointly_shifted)
    and its physical limits, taking back most of the shift (at most
    DRIFT_LEAVES of its z left), is set aside (Calibration.drift_shifts), and the
    note says so. A value near the threshold that the drift moves by a hair stays a
    finding: the power loss of benchmark seed 9131 (no drift) moved the heat loss
    +2.004 spreads, +1.998 without a drift. The nominal model stays the first
    calibration's (decisions G52: a drift taken out everywhere takes up slow
    effects); the room the thermometer reads at rest is no value a drift moves and
    is kept.
    """
    from dataclasses import replace
    if cal is None:
        return cal, None
    shifted = {name: z for name, z, _ in cal.findings(implausible=True)
               if name in cal.report.estimates}
    if not shifted:
        return cal, None
    again, _, _ = calibrate_training_part(records, params_of, model, fraction, supply, False,
                                          validation, drift=True)
    if again is None:
        return cal, None
    redone = {r.name: r for r in again.plausibility()}
    back = {name: redone[name].z for name in shifted
            if name in redone and not redone[name].shifted
            and abs(redone[name].z) <= DRIFT_LEAVES * abs(shifted[name])
            and not redone[name].implausible}
    if not back:
        return cal, None
    said = ', '.join(f'{name} ({shifted[name]:+.1f} -> {back[name]:+.1f} spreads)'
                     for name in back)
    return replace(cal, drift_shifts=back), (
        f"not findings: {said}: calibrated again with each record's drift from its zero "
        "removed, the value returns within the description, so a sensor's drift bent it, "
        'not an effect (docs/diagnosis_method.md, "Findings")')
