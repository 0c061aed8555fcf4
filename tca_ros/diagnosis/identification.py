"""Diagnose a record: nominal residuals, candidate ranking, extended model, gain.

``diagnose`` is what ``tca_sim diagnose DATA --config ... [--report DIR]`` runs;
``summary.format_summary`` is its one-screen stdout summary.
"""
from dataclasses import dataclass, field
import math
import os
import time as wallclock

import numpy as np

from tca_ros.calibration.candidates import ABSORBED, absorbed_candidates
from tca_ros.calibration.conditions import held_strength
from tca_ros.calibration.progress import Progress
from tca_ros.calibration.where import where_notes
from tca_ros.diagnosis.detectability import detectability_note
from tca_ros.diagnosis.extension import Nominal, opinions, run_search
from tca_ros.diagnosis.heat_loss_note import heat_loss_note
from tca_ros.diagnosis.holdout import AUTO, choose_validation, DEFAULT_VALIDATION
from tca_ros.diagnosis.joint import JOINT_NFEV
from tca_ros.diagnosis.nominal import calibrate_training_part, candidates_of, DiagnosisError, \
    nominal_with_fallback, read_any, record_nominal, set_aside_drift_shifts
from tca_ros.diagnosis.parameter_names import NOMINAL_NAMES
from tca_ros.diagnosis.rivals import undecided_rivals
from tca_ros.diagnosis.search import MIN_GAIN_PERCENT
from tca_ros.diagnosis.verdict import gain, holds_one_load, needs_explaining, ONE_LOAD_NOTE
from tca_ros.diagnosis.verdict_text import not_taken_note, rivals_clause
from tca_ros.records.data import DataError, record_config

VERDICTS = ('explained', 'adequate', 'unexplained')
#: Rough count of simulations of a diagnosis, for the progress bar.
EXPECTED_SIMULATIONS = 200


@dataclass
class DiagnosisResult:
    """Everything a diagnosis found; ``to_json`` gives diagnosis.json (issue 5 schema)."""

    record: object  # Record
    config: str
    model: str
    params: object  # nominal TcaParams (mass and load from the record)
    extended_params: object  # TcaParams with the found effects
    effects: list  # names, in the order found
    extended_values: dict  # dotted name -> value of the found effects
    rounds: list  # SearchRound per greedy round
    nominal: object  # SimulationResult at the record rate
    extended: object  # SimulationResult at the record rate
    nominal_rmse: dict  # channel -> held-out RMSE (m, K)
    extended_rmse: dict
    nominal_stats: dict  # channel -> ResidualStats on the held-out part
    extended_stats: dict
    sigma: dict  # channel -> sensor noise estimate (m, K)
    verdict: str
    explanation: str
    elapsed: float  # s of wall time
    n_simulations: int
    extended_params_path: str = None
    report_path: str = None
    json_path: str = None
    figures: list = field(default_factory=list)
    untestable: list = field(default_factory=list)  # candidates this record cannot test
    helpful: list = field(default_factory=list)  # improve the fit, not named as cause
    calibration: object = None  # Calibration of the nominal parameters, or None
    notes: list = field(default_factory=list)
    records: list = field(default_factory=list)  # paths diagnosed together
    heldout_spans: list = field(default_factory=list)  # [(start, end)] s held out (1st record)
    validation: str = DEFAULT_VALIDATION  # layout of the held-out part (holdout.py)
    config_from_header: bool = False  # config named by the record's '# tca:' header
    calibrated_file: str = None  # params file of `tca_sim calibrate` taken as the nominal
    #: {calibration name: (value, unit)} of the calibrated params file, else empty
    calibrated_values: dict = field(default_factory=dict)
    #: {named effect: [its rivals]}: rivals that explain these records as well, which
    #: only another experiment tells apart (rivals.undecided_rivals); the verdict is
    #: 'effect or rival'
    rivals: dict = field(default_factory=dict)

    @property
    def muscle(self):
        """Return how the outputs name the muscle: its params file, and where it came from."""
        origin = " (from the record's '# tca:' header)" if self.config_from_header else ''
        text = f'config {self.config}{origin}'
        if self.calibrated_file:
            text += f', nominal parameters from {self.calibrated_file}'
        return text

    @property
    def success(self):
        """Return True: the nominal model simulated and the search ran to its end.

        A candidate whose fit fails is reported as not significant, never added;
        a nominal model that cannot simulate the record raises DiagnosisError.
        """
        return self.verdict in VERDICTS

    @property
    def candidates(self):
        """Return the first round's CandidateScores (each alone vs nominal), best first."""
        return self.rounds[0].scores if self.rounds else []

    @property
    def gain_percent(self):
        """Return the held-out displacement RMSE gain (%) of extended over nominal."""
        return gain(self.nominal_rmse['displacement'], self.extended_rmse['displacement'])

    def channel_gain(self, channel):
        """Return the held-out RMSE gain (%) of one channel."""
        return gain(self.nominal_rmse[channel], self.extended_rmse[channel])

    def to_json(self):
        """Return the diagnosis.json document (issue 5 schema) as a dict."""
        nominal = self.rounds[0].base_rmse['displacement'] if self.rounds else math.nan
        return {
            'effects': list(self.effects),
            'rivals': {k: list(v) for k, v in self.rivals.items()},
            'helpful': list(self.helpful),
            'records': list(self.records),
            'model': self.model,
            'calibrated': ({k: v.as_dict() for k, v in
                            {**self.calibration.report.estimates,
                             **self.calibration.derived()}.items()}
                           if self.calibration is not None else None),
            'candidates': [{'name': s.name, 'params': dict(s.fit.params),
                            'heldout_rmse': s.heldout_rmse['displacement'],
                            'gain_percent': gain(nominal, s.heldout_rmse['displacement'])}
                           for s in self.candidates],
            'nominal_heldout_rmse': self.nominal_rmse['displacement'],
            'extended_heldout_rmse': self.extended_rmse['displacement'],
            'gain_percent': self.gain_percent,
            'extended_params': self.extended_params_path,
            'verdict': self.verdict,
        }


def diagnose(data_path, config=None, report_dir=None, model=None, progress=True,
             physics_rate=None, fit_rate=None, train_fraction=None, calibrate_first=True,
             calibrated=None, supply='power', validation=AUTO):
    """Diagnose a measured record against the nominal model; return a DiagnosisResult.

    Parameters
    ----------
    data_path : str or list of str
        CSV (``# key: value`` header) or rosbag2 recording (see data.py, data_bag.py); a list
        diagnoses several records of one muscle together (one calibration on
        their training parts, shared effect parameters, pooled held-out scores).
    config : str, optional
        Nominal params file (path or shipped name); default the record's ``tca``.
    report_dir : str, optional
        Write report.md, PNG figures, diagnosis.json and extended_params.yaml here.
    model : str, optional
        Kinetostatic model of the fits (rod | cst | love); default the config's.
    progress : bool
        Draw a progress bar on stderr.
    physics_rate, fit_rate : float, optional
        Physics rate (Hz, default max(200 Hz, sample rate)) and fit-grid rate (Hz).
    train_fraction : float, optional
        Share of the record used for fitting (default 0.7); the rest is held out.
    validation : str
        Layout of the held-out part (holdout.py): 'blocks' (three blocks of ten,
        the last one and two inside, so a one-step record trains and is judged on
        heating and cooling alike), 'tail' (the last part), or 'auto' (default:
        'tail' when a tail's training part holds two coolings in every record,
        else 'blocks'; holdout.choose_validation).
    calibrate_first : bool
        Calibrate the nominal parameters a maker cannot measure on the training
        part (calibration.py) before searching effects, so that effects are
        judged against the best nominal model and what a recalibration absorbs is
        not reported as an effect.
    calibrated : str, optional
        A params file from `tca_sim calibrate` to take as the nominal model
        instead (no calibration here); its geometry replaces the config's.
    supply : str
        'power' or 'voltage': what the power column is (calibration.py).

    Raises
    ------
    DataError
        Malformed data (the CLI exits with status 2).
    ParameterError
        Bad config (exit 2).
    DiagnosisError
        The nominal simulation fails on this record (exit 1).
    """
    from tca_ros.diagnosis import fitting
    from tca_ros.model.static_maps import clear_map_cache
    start = wallclock.perf_counter()
    from_header = config is None
    clear_map_cache()  # identical inputs give identical numbers (the maps grow on demand)
    paths, records, config, model, base = _read(data_path, config, calibrated, model)
    record = records[0]
    base, warning = held_strength(base, records)
    params_of = start_params = [record_nominal(base, r) for r in records]
    fraction = train_fraction or fitting.TRAIN_FRACTION
    validation = choose_validation(records, fraction, validation)
    cal, drifted, notes = None, None, [warning] if warning else []
    notes += [f'{os.path.basename(p)}: {n}' for p, r in zip(paths, records) for n in r.reading]
    if len(records) > 1:
        notes.append(f'{len(records)} records of one muscle diagnosed together: one '
                     'calibration, shared effect parameters, each record split in time')
    if calibrated:
        notes.append(f'nominal parameters from the calibrated params file {calibrated}')
    elif calibrate_first:
        cal, params_of, note = calibrate_training_part(records, params_of, model, fraction,
                                                       supply, progress, validation)
        notes.append(note)
        cal, drifted = set_aside_drift_shifts(cal, records, start_params, model, fraction,
                                              supply, validation)
    bar = Progress(progress, EXPECTED_SIMULATIONS * len(records), stage='effect search')
    options = dict(model=model, physics_rate=physics_rate,
                   fit_rate=fit_rate or fitting.FIT_RATE_HZ, train_fraction=fraction,
                   progress=bar, validation=validation)
    try:
        problems, problem, start_values, nominals, cal, params_of = nominal_with_fallback(
            records, params_of, cal, bool(calibrated), base, options, notes, paths)
    except (DataError, DiagnosisError):
        bar.close()
        raise
    if cal is not None and drifted:  # after the calibration's own note (the fallback's)
        notes.append(drifted)
    params = params_of[0]
    candidates, absorbed = absorbed_candidates(
        candidates_of(records, params, model, problems, nominals), problem.recalibration)
    if absorbed:
        notes.append(f'not searched: {", ".join(absorbed)} (the refitted '
                     f'{", ".join(NOMINAL_NAMES[ABSORBED[a]][0] for a in absorbed)} is the '
                     'same parameter)')
    nominal = Nominal(problems, problem, start_values, nominals, cal, candidates)
    try:
        effects, values, extendeds, rounds = run_search(nominal, notes)
    except (ValueError, ArithmeticError) as exc:  # a candidate the stepper cannot run
        raise DiagnosisError(f'{data_path}: the effect search failed with model={model} '
                             f'({str(exc).splitlines()[0]})') from None
    finally:
        bar.close()

    def calibrate_with(fit, start_values, like):
        """Calibrate ``fit`` on the training part (joint.py's calibrations)."""
        return calibrate_training_part(records, start_params, model, fraction, supply,
                                       False, validation, fit=fit, max_nfev=JOINT_NFEV,
                                       start_values=start_values, like=like)

    def on_whole_records(fit, start_values, like):
        """Calibrate ``fit`` on the whole records (joint.confirm_on_whole).

        Less each record's sensor drift (calibrate's ``drift``): the confirmation
        judges the whole-record residual with that drift removed, so the fit it
        judges does not bend its values to the drift either.
        """
        return calibrate_training_part(records, start_params, model, None, supply,
                                       False, validation, fit=fit, max_nfev=JOINT_NFEV,
                                       start_values=start_values, like=like, drift=True)
    calibrate_with.whole = on_whole_records
    effects, values, extendeds, judgement, found = opinions(
        nominal, calibrate_with, effects, values, extendeds, rounds, notes)
    extended_rmse, extended_stats, verdict, explanation = judgement
    unaccepted = None if effects else not_taken_note(rounds, MIN_GAIN_PERCENT)
    if unaccepted:  # the candidate table shows its gain: say why it is not a finding
        notes.append(unaccepted)
    if nominal.cal is None:  # a nominal not calibrated on these records: their environment?
        notes.extend(heat_loss_note(params, values, problem.recalibration))
    if holds_one_load(records) and (verdict != 'unexplained'
                                    or not needs_explaining(extended_stats)):
        # no structure left (the verdict may still be a finding's): say what one load hides
        notes.append(ONE_LOAD_NOTE)
    if 'displacement' in problem.channels:
        notes.extend(repeat_notes(
            [p.record for p in problems],
            [p.record.displacement - s.displacement for p, s in zip(problems, extendeds)],
            [p.full_heldout_index for p in problems]))
    if verdict == 'unexplained':  # where to look: one moment, or everywhere
        notes.extend(where_notes([p.record for p in problems], extendeds,
                                 needs_explaining(extended_stats)))
    notes.extend(detectability_note(problems, nominals, nominal.stats, nominal.whole_stats,
                                    effects))
    helpful = []
    if verdict == 'unexplained' and effects and not found:
        # what helps is shown, but an effect that leaves structure is not a cause (unless
        # the description's findings name it decisively: found, with structure beside it)
        helpful, effects = list(effects), []
    rivals = undecided_rivals(effects, notes)  # the named effects' open rivals
    explanation += rivals_clause(rivals)
    result = DiagnosisResult(
        record=record, config=config, model=model, params=params,
        extended_params=problem.parameters(values), effects=effects, helpful=helpful,
        calibration=nominal.cal, notes=notes, records=[str(p) for p in paths],
        extended_values=values, rounds=rounds, nominal=nominals[0], extended=extendeds[0],
        nominal_rmse=nominal.rmse, extended_rmse=extended_rmse,
        nominal_stats=nominal.stats, extended_stats=extended_stats,
        sigma=dict(problems[0].sigma),
        heldout_spans=[(float(record.time[a]), float(record.time[b - 1]))
                       for a, b in problems[0].full_runs], validation=validation,
        verdict=verdict, explanation=explanation, elapsed=0.0,
        n_simulations=bar.count, untestable=[c.name for c in candidates if not c.starts],
        config_from_header=from_header, calibrated_file=calibrated,
        calibrated_values=_file_values(calibrated, params, config, model),
        rivals=rivals)
    result.elapsed = wallclock.perf_counter() - start
    if report_dir:
        from tca_ros.diagnosis.report import write_report
        write_report(result, report_dir)
    return result


def repeat_notes(records, residuals, samples):
    """Return a note comparing the held-out displacement RMSE (m) with the repeat spread.

    Records of one muscle at one condition (calibration.validation.condition_of)
    are repeats: the difference of each from the mean of the others (m) is what
    no model of the inputs can predict. Both RMS values are pooled over the same
    samples, ``samples[i]`` (index array) of the records that have repeats, with
    ``residuals[i]`` the model's displacement residual (m) of record i: the
    held-out blocks of a step lie where the runs differ most, so a spread taken
    over whole records would understate it there. A residual of that size is the
    records' resolution, not a model error to name.
    """
    from tca_ros.calibration.validation import repeat_means
    model_part, repeat_part = [], []
    for r, residual, index, mean in zip(records, residuals, samples, repeat_means(records)):
        if mean is not None:
            model_part.append(np.asarray(residual)[index])
            repeat_part.append((r.displacement - mean)[index])
    if not model_part:
        return []
    left = float(np.sqrt(np.mean(np.concatenate(model_part) ** 2)))
    floor = float(np.sqrt(np.mean(np.concatenate(repeat_part) ** 2)))
    relation = 'below' if left < floor else 'above'
    return [f'the held-out displacement RMSE of the {len(model_part)} records with repeats '
            f'({left * 1e3:.3g} mm) is {relation} the spread between repeated runs on the same '
            f'samples ({floor * 1e3:.3g} mm, each record against the mean of its repeats at its '
            'condition): ' + ('a model error smaller than that spread cannot be resolved by '
                              'these records' if left < floor
                              else 'the model misses more than the runs differ by')]


def _file_values(calibrated, params, config, model):
    """Return {calibration name: (value, unit)} of a calibrated params file, or {}."""
    if not calibrated:
        return {}
    from tca_ros.diagnosis.parameter_names import calibrated_values
    from tca_ros.params.files import load_params
    return calibrated_values(params, load_params(config, model=model))


def _read(data_path, config, calibrated, model):
    """Return (paths, records, config, model, base params) of a diagnosis's inputs.

    The base params are the calibrated file's or the config's, with the model the
    fits run (the extended params file must name the model its effects were fitted
    with).
    """
    from tca_ros.params.files import load_params
    paths = ([data_path] if isinstance(data_path, (str, os.PathLike))
             else list(data_path))
    records = [read_any(p, config) for p in paths]
    config = config or record_config(records[0])
    nominal_source = calibrated or config
    model = model or load_params(nominal_source).model
    return paths, records, config, model, load_params(nominal_source, model=model)
