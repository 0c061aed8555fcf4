"""Diagnose a record: nominal residuals, candidate ranking, extended model, gain.

``diagnose`` is what ``tca_sim diagnose DATA --config ... [--report DIR]`` runs;
``format_summary`` is its one-screen stdout summary.
"""
import dataclasses
from dataclasses import dataclass, field
import math
import os
import time as wallclock

import numpy as np

from tca_ros.diagnosis.candidates import build_candidates
from tca_ros.diagnosis.data import read_record, record_config
from tca_ros.diagnosis.fitting import FitProblem, Progress, search_effects
from tca_ros.diagnosis.residuals import residual_stats, STRUCTURE_RATIO

VERDICTS = ('explained', 'adequate', 'unexplained')
UNITS = {'displacement': 'm', 'temperature': 'K'}
#: Rough count of simulations of a diagnosis, for the progress bar.
EXPECTED_SIMULATIONS = 200
PEAK_PERCENTILE = 99.5  # % of measured contraction taken as its peak (noise-robust)
INITIAL_WINDOW_S = 1.0  # s at the start of a record taken as ambient equilibrium


class DiagnosisError(ValueError):
    """The nominal model cannot be simulated on the record (CLI exit status 1).

    A ValueError, as the simulator's own errors are, but not a DataError: the CLI
    maps it to exit status 1 (fit failed), DataError to 2 (bad input).
    """


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
    split_time: float  # s, start of the held-out part
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
            'helpful': list(self.helpful),
            'model': self.model,
            'calibrated': ({k: v.as_dict() for k, v in
                            self.calibration.report.estimates.items()}
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


def gain(before, after):
    """Return 100 (1 - after / before) (%), the relative RMSE reduction."""
    return 100.0 * (1.0 - after / before) if before > 0.0 else 0.0


def heldout_rmse(record, sim, split, channels):
    """Return {channel: RMSE} of ``sim`` against ``record`` from sample ``split`` on."""
    return {c: float(np.sqrt(np.mean((getattr(record, c)[split:]
                                      - getattr(sim, c)[split:]) ** 2))) for c in channels}


def channel_stats(problem, sim):
    """Return {channel: ResidualStats} of ``sim`` on the held-out part (record rate)."""
    r, s = problem.record, problem.full_split
    temp = r.temperature if r.temperature is not None else sim.temperature
    return {c: residual_stats(c, UNITS[c], getattr(r, c)[s:], getattr(sim, c)[s:],
                              problem.sigma[c], problem.sample_rate, temp[s:])
            for c in problem.channels}


def decide_verdict(effects, nominal_stats, extended_stats):
    """Return (verdict, one-sentence explanation) from the residual structure.

    'adequate': nothing added and the nominal residual is within noise;
    'explained': effects added and the extended residual is within noise;
    'unexplained': structure beyond STRUCTURE_RATIO noise sigmas remains.
    """
    stats = extended_stats if effects else nominal_stats
    worst = max(stats.values(), key=lambda st: st.ratio)
    ratios = ', '.join(f'{st.channel} {st.ratio:.2f}' for st in stats.values())
    if not worst.structured:
        if effects:
            return 'explained', (f'held-out residual RMS within noise after adding '
                                 f'{" + ".join(effects)} (RMS/sigma: {ratios})')
        return 'adequate', (f'no candidate improves the held-out fit significantly and the '
                            f'nominal residual is within noise (RMS/sigma: {ratios})')
    what = ('after adding ' + ' + '.join(effects)) if effects else 'and no candidate helps'
    caution = ('; the effects added improve the fit but do not explain the data, so do not '
               'read them as its cause') if effects else ''
    return 'unexplained', (f'unexplained structure remains {what}: held-out residual RMS '
                           f'above {STRUCTURE_RATIO:g} noise sigma (RMS/sigma: {ratios})'
                           f'{caution}')


def diagnose(data_path, config=None, report_dir=None, model=None, progress=True,
             physics_rate=None, fit_rate=None, train_fraction=None, calibrate_first=True,
             calibrated=None, supply='power'):
    """Diagnose a measured record against the nominal model; return a DiagnosisResult.

    Parameters
    ----------
    data_path : str
        CSV (``# key: value`` header) or rosbag2 recording (see data.py).
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
        Leading share of the record used for fitting (default 0.7).
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
    from tca_ros.diagnosis.data import read_bag_record
    from tca_ros.model.params import load_params
    from tca_ros.diagnosis import fitting

    start = wallclock.perf_counter()
    is_bag = os.path.isdir(data_path) or str(data_path).endswith('.mcap')
    if is_bag:
        if config is None:
            from tca_ros.diagnosis.data import DataError
            raise DataError(f'{data_path}: row 1, column {"tca"!r}: a rosbag2 recording '
                            'carries no config name; pass --config')
        base = load_params(config)
        record = read_bag_record(data_path, tca=config, mass_kg=base.dynamics.mass)
    else:
        record = read_record(data_path)
    config = config or record_config(record)
    nominal_source = calibrated or config
    model = model or load_params(nominal_source).model
    # the extended params file must name the model its effects were fitted with
    params = load_params(nominal_source, model=model,
                         **{'dynamics.mass': record.mass,
                            'dynamics.load': float(record.load[0])})
    fraction = train_fraction or fitting.TRAIN_FRACTION
    cal, notes = None, []
    if calibrated:
        notes.append(f'nominal parameters from the calibrated params file {calibrated}')
    elif calibrate_first:
        cal, params, note = _calibrate_training_part(record, params, model, fraction, supply,
                                                     progress)
        notes.append(note)
    bar = Progress(progress, EXPECTED_SIMULATIONS)
    problem = FitProblem(record, params, model=model, physics_rate=physics_rate,
                         fit_rate=fit_rate or fitting.FIT_RATE_HZ,
                         train_fraction=fraction, progress=bar)
    bar.label = 'nominal'
    try:
        nominal = problem.set_base({})
    except (ValueError, ArithmeticError) as exc:  # StabilityError is a ValueError
        bar.close()
        raise DiagnosisError(f'{data_path}: the nominal model cannot simulate this record '
                             f'with model={model} ({exc})') from None
    initial = None
    if record.temperature is not None:
        head = record.time <= record.time[0] + INITIAL_WINDOW_S
        initial = float(np.median(record.temperature[head]))
    train = slice(0, problem.full_split)
    measured_peak = float(np.percentile(record.displacement[train], PEAK_PERCENTILE))
    candidates = build_candidates(params, model, float(record.load[0]),
                                  float(nominal.displacement[train].max()),
                                  initial_temperature=initial, measured_peak=measured_peak)
    untestable = [c.name for c in candidates if not c.starts]
    try:
        effects, values, rounds = search_effects(problem, candidates)
        bar.label = 'extended'
        extended = problem.simulate_full(values) if effects else nominal
    except (ValueError, ArithmeticError) as exc:  # a candidate the stepper cannot run
        raise DiagnosisError(f'{data_path}: the effect search failed with model={model} '
                             f'({str(exc).splitlines()[0]})') from None
    finally:
        bar.close()
    channels = problem.channels
    nominal_rmse = heldout_rmse(record, nominal, problem.full_split, channels)
    extended_rmse = heldout_rmse(record, extended, problem.full_split, channels)
    nominal_stats = channel_stats(problem, nominal)
    extended_stats = channel_stats(problem, extended)
    verdict, explanation = decide_verdict(effects, nominal_stats, extended_stats)
    helpful = []
    if verdict == 'unexplained' and effects:
        # what helps is shown, but an effect that leaves structure is not a cause
        helpful, effects = list(effects), []
    result = DiagnosisResult(
        record=record, config=config, model=model, params=params,
        extended_params=problem.parameters(values), effects=effects, helpful=helpful,
        calibration=cal, notes=notes,
        extended_values=values, rounds=rounds, nominal=nominal, extended=extended,
        nominal_rmse=nominal_rmse, extended_rmse=extended_rmse,
        nominal_stats=nominal_stats, extended_stats=extended_stats,
        sigma=dict(problem.sigma), split_time=float(record.time[problem.full_split]),
        verdict=verdict, explanation=explanation, elapsed=0.0,
        n_simulations=bar.count, untestable=untestable)
    result.elapsed = wallclock.perf_counter() - start
    if report_dir:
        from tca_ros.diagnosis.report import write_report
        write_report(result, report_dir)
    return result


def _calibrate_training_part(record, params, model, fraction, supply, progress):
    """Return (Calibration or None, params, note): the nominal model fitted on training."""
    from tca_ros.diagnosis.calibration import calibrate, CalibrationError, record_params
    from tca_ros.model.kinetostatics import make_kinetostatic_model
    from tca_ros.model.quasistatic import QuasiStaticUnsupported
    split = int(np.searchsorted(record.time, record.time[0] + fraction * record.duration))
    head = dataclasses.replace(
        record, time=record.time[:split], power=record.power[:split],
        load=record.load[:split], displacement=record.displacement[:split],
        temperature=None if record.temperature is None else record.temperature[:split],
        resistance=None if record.resistance is None else record.resistance[:split])
    try:
        cal = calibrate([head], params, model=model, check=False, supply=supply,
                        progress=progress)
    except (CalibrationError, QuasiStaticUnsupported, ValueError, ArithmeticError) as exc:
        return None, params, f'calibration skipped ({str(exc).splitlines()[0]})'
    calibrated = record_params(cal.params, record).with_values(model=model)
    try:  # the stepper's model must exist for the calibrated values (the rod table)
        make_kinetostatic_model(calibrated, model)
    except (ValueError, ArithmeticError, RuntimeError) as exc:
        return None, params, (f'calibration not used: the {model} model cannot represent '
                              f'its result ({str(exc).splitlines()[0]})')
    fitted = [e.name for e in cal.report.estimates.values() if e.determined]
    note = ('nominal parameters calibrated on the training part: '
            + (', '.join(fitted) if fitted else 'none determined'))
    return cal, calibrated, note


def _format_value(name, value):
    unit = {'effects.creep_compliance': ('mm/N', 1e3), 'effects.extra_softening':
            ('MPa/K', 1e-6)}.get(name)
    short = name.split('.', 1)[1]
    if unit:
        return f'{short}={value * unit[1]:.3g} {unit[0]}'
    from tca_ros.model.params import SPECS
    return f'{short}={value:.3g} {SPECS[name].unit}'.rstrip(' -')


def _format_rmse(channel, value):
    return f'{value * 1e6:7.1f} um' if channel == 'displacement' else f'{value:7.2f} K '


def format_summary(result):
    """Return the one-screen stdout summary of a DiagnosisResult."""
    r = result.record
    channels = list(result.nominal_rmse)
    lines = [
        f'diagnose {r.source}: {r.duration:.1f} s at {r.sample_rate:.4g} Hz '
        f'({r.time.size} samples; measured: {", ".join(channels)})',
        f'config {result.config} (mass {r.mass * 1e3:.1f} g), model {result.model}; '
        f'train 0-{result.split_time:.0f} s, held out {result.split_time:.0f}-'
        f'{r.time[-1]:.0f} s',
        'sensor noise (2nd differences): ' + ', '.join(
            f'{c} {_format_rmse(c, s).strip()}' for c, s in result.sigma.items()),
        '',
        'candidates, each alone vs nominal (held-out RMSE; gain; penalised test):',
    ]
    base = result.rounds[0].base_rmse if result.rounds else result.nominal_rmse
    for i, s in enumerate(result.candidates, start=1):
        params = ', '.join(_format_value(k, v) for k, v in s.fit.params.items())
        temp = (f'{_format_rmse("temperature", s.heldout_rmse["temperature"])}'
                if 'temperature' in s.heldout_rmse else '')
        mark = 'significant' if s.significant else ('' if s.refined else 'screened')
        disp = s.heldout_rmse['displacement']
        lines.append(f'  {i}. {s.name:<20s} {_format_rmse("displacement", disp)}'
                     f' {gain(base["displacement"], disp):+7.1f} % {temp} {mark:<11s} {params}')
    if result.rounds and result.rounds[0].restarted:
        lines.append(f'  the greedy path from the best single candidate ended with structure '
                     f'left; restarted from the runner-up {result.rounds[0].accepted}, whose '
                     'path has the lower held-out BIC')
    if result.untestable:
        lines.append(f'  not testable in this record: {", ".join(result.untestable)} '
                     '(coil contact: no allowed stop lies within the nominal stroke)')
    for rnd in result.rounds[1:]:
        best = rnd.scores[0] if rnd.scores else None
        if best:
            lines.append(f'  round {len(rnd.base_effects) + 1} (base + '
                         f'{" + ".join(rnd.base_effects)}): best {best.name}, held-out score '
                         f'{rnd.base_score:.2f} -> {best.heldout_score:.2f} sigma, '
                         f'{"added" if rnd.accepted else "not significant"}')
    lines.append('')
    if result.effects:
        lines.append('effects found: ' + ', '.join(result.effects))
        lines.append('  ' + '; '.join(_format_value(k, v)
                                      for k, v in result.extended_values.items()))
    else:
        lines.append('effects found: none')
    if result.helpful:
        lines.append('improve the fit but leave structure (not a cause): '
                     + ', '.join(result.helpful))
    for note in result.notes:
        lines.append(f'note: {note}')
    for c in channels:
        before = _format_rmse(c, result.nominal_rmse[c]).strip()
        after = _format_rmse(c, result.extended_rmse[c]).strip()
        lines.append(f'held-out RMSE {c}: nominal {before} -> extended {after} '
                     f'(gain {result.channel_gain(c):.1f} %)')
    lines.append(f'verdict: {result.verdict}: {result.explanation}')
    if result.report_path:
        lines.append(f'report: {result.report_path}; extended params: '
                     f'{result.extended_params_path}; {result.json_path}')
    lines.append(f'{result.n_simulations} simulations, {result.elapsed:.1f} s')
    return '\n'.join(lines)
