"""The one-screen stdout summary of a diagnosis (DiagnosisResult of identification.py)."""
import math
import os

from tca_ros.calibration.calibration_report import prior_kinds
from tca_ros.diagnosis.parameter_names import format_nominal, plausibility_lines
from tca_ros.diagnosis.verdict import gain


def _format_value(name, value, params=None):
    """Return 'name=value unit': a nominal entry by its calibration name, an effect's dotted."""
    nominal = format_nominal(name, value, params) if params is not None else None
    if nominal:
        return nominal
    unit = {'effects.creep_compliance': ('mm/N', 1e3), 'effects.extra_softening':
            ('MPa/K', 1e-6)}.get(name)
    short = name.split('.', 1)[1]
    if unit:
        return f'{short}={value * unit[1]:.3g} {unit[0]}'
    from tca_ros.model.params_schema import SPECS
    return f'{short}={value:.3g} {SPECS[name].unit}'.rstrip(' -')


def nominal_lines(result):
    """Return the lines of the nominal parameters, named and valued as `tca_sim calibrate` does.

    From the calibration of the training part (value, start, z in prior spreads,
    findings where a value left its description), or the calibrated params file.
    """
    if result.calibration is not None:
        return (['nominal parameters calibrated on the training part (as `tca_sim calibrate` '
                 'names them; start: the description; z in prior spreads):']
                + plausibility_lines(result.calibration)
                # which values the description gave as measured, estimated or guessed
                + prior_kinds(result.calibration))
    if result.calibrated_values:
        return [f'nominal parameters from {result.calibrated_file}: ' + ', '.join(
            f'{k} {v:.4g} {unit}'.rstrip(' -') for k, (v, unit) in
            result.calibrated_values.items())]
    return []


def heldout_text(result):
    """Return e.g. 'held out 15-23, 37-44, 52-59 s (blocks; the rest trains)' (s)."""
    spans = ', '.join(f'{a:.0f}-{b:.0f}' for a, b in result.heldout_spans)
    return f'held out {spans} s ({result.validation}; the rest trains)'


def _format_rmse(channel, value):
    return f'{value * 1e6:7.1f} um' if channel == 'displacement' else f'{value:7.2f} K '


def format_summary(result):
    """Return the one-screen stdout summary of a DiagnosisResult."""
    r = result.record
    channels = list(result.nominal_rmse)
    lines = [
        f'diagnose {r.source}: {r.duration:.1f} s at {r.sample_rate:.4g} Hz '
        f'({r.time.size} samples; measured: {", ".join(channels)})',
        *([f'  with {len(result.records) - 1} more record(s) of the same muscle: '
           + ', '.join(os.path.basename(p) for p in result.records[1:])]
          if len(result.records) > 1 else []),
        f'{result.muscle}; mass {r.mass * 1e3:.1f} g, model {result.model}; '
        f'{heldout_text(result)}',
        'sensor noise (2nd differences): ' + ', '.join(
            f'{c} {_format_rmse(c, s).strip()}' for c, s in result.sigma.items()),
        *nominal_lines(result),
        '',
        'candidates, each alone vs nominal (held-out RMSE; gain; penalised held-out gain; '
        'the temperature RMSE where measured):',
    ]
    base = result.rounds[0].base_rmse if result.rounds else result.nominal_rmse
    for i, s in enumerate(result.candidates, start=1):
        params = ', '.join(_format_value(k, v, result.params) for k, v in s.fit.params.items())
        temp = (f'{_format_rmse("temperature", s.heldout_rmse["temperature"])}'
                if 'temperature' in s.heldout_rmse else '')
        mark = 'significant' if s.significant else ('' if s.refined else 'screened')
        disp = s.heldout_rmse['displacement']
        lines.append(f'  {i}. {s.name:<20s} {_format_rmse("displacement", disp)}'
                     f' {gain(base["displacement"], disp):+7.1f} % {_format_criterion(s)}'
                     f' {temp} {mark:<11s} {params}')
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
    own = {k: v for k, v in result.extended_values.items() if _is_effect(k)}
    if result.effects:
        lines.append('effects found: ' + effects_text(result))
        lines.append('  ' + '; '.join(_format_value(k, v) for k, v in own.items()))
    else:
        lines.append('effects found: none')
    refit = {k: v for k, v in result.extended_values.items() if not _is_effect(k)}
    if refit and (result.effects or result.helpful):
        lines.append('  nominal parameters refitted with them: '
                     + '; '.join(_format_value(k, v, result.params) for k, v in refit.items()))
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


def effects_text(result, mark=str):
    """Return the named effects with their open rivals: 'a (or b: these records ...), c'.

    ``mark`` formats a name (the report's markdown wraps it in backticks).
    """
    out = []
    for effect in result.effects:
        others = result.rivals.get(effect, [])
        out.append(mark(effect) + (f' (or {" or ".join(map(mark, others))}: these records '
                                   'cannot tell which)' if others else ''))
    return ', '.join(out)


def _format_criterion(score):
    """Return a candidate's penalised held-out gain D - k ln n (-), 'n/a' when none."""
    crit = score.criterion
    return f'{crit:+8.1f}' if math.isfinite(crit) else f'{"n/a":>8s}'


def _is_effect(name):
    """Return True for an effect's own parameter (dotted), False for a nominal one."""
    return name.startswith('effects.') or name.startswith('coil.')
