"""Write a diagnosis: report.md, PNG figures, diagnosis.json, extended_params.yaml.

Identical inputs give identical files: no time stamps, no wall times, PNGs
written without metadata.
"""
import json
import math
import os

import numpy as np

from tca_ros.calibration.physical_priors import JOINT_Z, SHIFT_Z
from tca_ros.diagnosis import plots
from tca_ros.diagnosis.parameter_names import nominal_value
from tca_ros.diagnosis.summary import effects_text, heldout_text, nominal_lines
from tca_ros.diagnosis.verdict import gain
from tca_ros.model.tca_params import muscle_at_rest
from tca_ros.params.files import dump_params

FIGURE_DPI = 110


def _save(fig, path):
    fig.savefig(path, dpi=FIGURE_DPI, metadata={'Software': None})


def write_figures(result, report_dir):
    """Write the PNG figures; return their file names."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    r = result.record
    nom, ext = result.nominal, result.extended
    split = result.heldout_spans
    names = []
    rows = 2 if r.temperature is not None else 1
    fig, axes = plt.subplots(rows, 1, figsize=(9, 3.2 * rows + 1.2), sharex=True,
                             squeeze=False)
    plots.plot_fit(r.time, r.displacement, nom.displacement, ext.displacement, split,
                   ax=axes[0, 0])
    axes[0, 0].set_title('measured vs nominal vs extended')
    if r.temperature is not None:
        plots.plot_fit(r.time, r.temperature, nom.temperature, ext.temperature, split,
                       ax=axes[1, 0], scale=1.0, ylabel='temperature (degC)')
    fig.tight_layout()
    _save(fig, os.path.join(report_dir, 'fit.png'))
    plt.close(fig)
    names.append('fit.png')

    res_nom = r.displacement - nom.displacement
    res_ext = r.displacement - ext.displacement
    sigma = result.sigma['displacement']
    temp = r.temperature if r.temperature is not None else nom.temperature
    fig, axes = plt.subplots(3, 2, figsize=(11, 11))
    plots.plot_residual_time(r.time, res_nom, res_ext, sigma, split, ax=axes[0, 0])
    axes[0, 0].set_title('displacement residual over time')
    plots.plot_residual_branches(temp, res_nom, r.sample_rate, ax=axes[0, 1])
    axes[0, 1].set_title('nominal residual vs temperature')
    plots.plot_residual_branches(temp, res_ext, r.sample_rate, ax=axes[1, 1],
                                 label='extended')
    axes[1, 1].set_title('extended residual vs temperature')
    plots.plot_residual_load(r.load, res_nom, ax=axes[1, 0])
    plots.plot_residual_load(r.load, res_ext, ax=axes[1, 0], label='extended',
                             color='tab:blue')
    axes[1, 0].set_title('residual vs load')
    plots.plot_cross_correlation(r.displacement, nom.displacement, ext.displacement,
                                 r.sample_rate, ax=axes[2, 0])
    axes[2, 0].set_title('lag cross-correlation')
    plots.plot_residual_spectrum(res_nom, res_ext, sigma, r.sample_rate, ax=axes[2, 1])
    axes[2, 1].set_title('spectral whiteness')
    fig.tight_layout()
    _save(fig, os.path.join(report_dir, 'residuals.png'))
    plt.close(fig)
    names.append('residuals.png')

    if r.temperature is not None:
        fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
        t_nom = r.temperature - nom.temperature
        t_ext = r.temperature - ext.temperature
        plots.plot_residual_time(r.time, t_nom, t_ext, result.sigma['temperature'], split,
                                 ax=axes[0], scale=1.0, ylabel='temperature residual (K)')
        plots.plot_residual_spectrum(t_nom, t_ext, result.sigma['temperature'],
                                     r.sample_rate, ax=axes[1], scale=1.0, unit='K')
        fig.tight_layout()
        _save(fig, os.path.join(report_dir, 'temperature_residuals.png'))
        plt.close(fig)
        names.append('temperature_residuals.png')

    if result.candidates:
        base = result.rounds[0].base_rmse['displacement']
        fig, ax = plt.subplots(figsize=(8, 0.45 * len(result.candidates) + 1.2))
        plots.plot_ranking([s.name for s in result.candidates],
                           [gain(base, s.heldout_rmse['displacement'])
                            for s in result.candidates],
                           [s.significant for s in result.candidates], ax=ax)
        ax.set_title('candidates, each alone (green: significant)')
        fig.tight_layout()
        _save(fig, os.path.join(report_dir, 'ranking.png'))
        plt.close(fig)
        names.append('ranking.png')
    return names


def _fmt(value, digits=4):
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return 'n/a'
    return f'{value:.{digits}g}'


def _stats_table(result):
    lines = ['| channel | model | RMS | input-predictable | rest (noise) | p (inputs) | '
             'structured | white sigma | mean | lag-1 acf | '
             'Ljung-Box p (1 Hz) | flatness | power < 0.1 Hz | heating mean | cooling mean '
             '| peak lag (s) |',
             '|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|']
    for label, stats in (('nominal', result.nominal_stats), ('extended', result.extended_stats)):
        for c, st in stats.items():
            t = st.structure
            test = (f'{_fmt(t.predictable_rms)} | {_fmt(t.noise_rms)} | {t.p_value:.2g} | '
                    if t is not None else '- | - | - | ')
            lines.append(f'| {c} ({st.unit}) | {label} | {_fmt(st.rms)} | {test}'
                         f'{"yes" if st.structured else "no"} | {_fmt(st.noise_sigma)} '
                         f'| {_fmt(st.mean)} | {st.lag_one:.2f} | '
                         f'{st.ljung_box_p:.2g} | {st.flatness:.2f} | '
                         f'{100 * st.low_frequency_fraction:.1f} % | {_fmt(st.heating_mean)} | '
                         f'{_fmt(st.cooling_mean)} | {st.best_lag_s:+.2f} |')
    return lines


def _param_cell(name, value, stderr, unit, nominal):
    """Return 'name = value +- stderr unit'; a nominal entry by its calibration name."""
    named = nominal_value(name, value, nominal)
    if named is None:
        return f'{name.split(".", 1)[1]} = {_fmt(value)} +- {_fmt(stderr)} {unit}'
    label, v, unit = named
    scale = v / value if value else 1.0
    err = None if stderr is None else stderr * scale
    return f'{label} = {_fmt(v)} +- {_fmt(err)} {unit}'


def _candidate_table(scores, base_rmse, nominal):
    has_t = 'temperature' in base_rmse
    head = '| rank | effect | fitted parameters (+- stderr) | held-out RMSE displacement | gain |'
    rule = '|---|---|---|---|---|'
    if has_t:
        head += ' held-out RMSE temperature | gain |'
        rule += '---|---|'
    head += ' penalised gain | significant | fit |'
    rule += '---|---|---|'
    lines = [head, rule]
    for i, s in enumerate(scores, start=1):
        params = '; '.join(_param_cell(k, v, s.fit.stderr.get(k), s.fit.units[k], nominal)
                           for k, v in s.fit.params.items())
        row = (f'| {i} | {s.name} | {params} | {s.heldout_rmse["displacement"] * 1e6:.2f} um | '
               f'{gain(base_rmse["displacement"], s.heldout_rmse["displacement"]):+.1f} % |')
        if has_t:
            row += (f' {s.heldout_rmse["temperature"]:.3f} K | '
                    f'{gain(base_rmse["temperature"], s.heldout_rmse["temperature"]):+.1f} % |')
        crit = s.criterion if math.isfinite(s.criterion) else float('nan')
        row += (f' {crit:.1f} | {"yes" if s.significant else "no"} | '
                f'{("refined: " + s.fit.message) if s.refined else "screened only"} |')
        lines.append(row)
    return lines


def write_markdown(result, report_dir, figures):
    """Write report.md; return its path."""
    r = result.record
    lines = [
        '# TCA diagnosis report', '',
        f'- data: `{r.source}` ({r.duration:.1f} s at {r.sample_rate:.4g} Hz, '
        f'{r.time.size} samples; measured: {", ".join(result.nominal_rmse)})',
        f'- muscle: {_muscle_md(result)}, moving mass {r.mass * 1e3:.2f} g, '
        f'kinetostatic model `{result.model}`',
        f'- {heldout_text(result)}',
        '- sensor noise from robust second differences: ' + ', '.join(
            f'{c} {_fmt(s)} {"m" if c == "displacement" else "K"}'
            for c, s in result.sigma.items()),
        '', f'## Verdict: **{result.verdict}**', '', result.explanation + '.', '',
        'Effects found, in order: ' + (effects_text(result, lambda e: f'`{e}`')
                                       if result.effects else 'none') + '.', '',
        '| held-out RMSE | nominal | extended | gain |', '|---|---|---|---|']
    for c in result.nominal_rmse:
        unit, scale = ('um', 1e6) if c == 'displacement' else ('K', 1.0)
        lines.append(f'| {c} | {result.nominal_rmse[c] * scale:.3f} {unit} | '
                     f'{result.extended_rmse[c] * scale:.3f} {unit} | '
                     f'{result.channel_gain(c):+.1f} % |')
    if result.extended_values:
        lines += ['', 'Extended parameters (`extended_params.yaml`):', '']
        lines += [_value_item(k, v, result.params) for k, v in result.extended_values.items()]
    if result.calibration is not None or result.calibrated_values:
        lines += ['', '## Nominal parameters', '',
                  'Named and valued as `tca_sim calibrate` prints them (start: the '
                  'description; z: the shift in prior spreads; a shift beyond '
                  f'{SHIFT_Z:g} spreads is a finding, and so are shifts beyond {JOINT_Z:g} '
                  'that are as unlikely together).', '', '```text',
                  *nominal_lines(result), '```']
    lines += ['', '![measured vs nominal vs extended](fit.png)', '',
              '## Candidates', '',
              'Each candidate fitted alone on the training part, scored on the held-out part '
              '(round 1). Penalised gain: D - k ln(n), D = sum over channels of '
              'n ln(S_nominal / S_candidate), S the held-out residual sums of squares after '
              'an offset and a drift are removed and an AR noise model prewhitens them (the '
              "verdict's noise model); significant when positive and the RMS gain is at "
              'least 1 %.',
              '']
    if result.rounds:
        lines += _candidate_table(result.rounds[0].scores, result.rounds[0].base_rmse,
                                  result.params)
    if result.untestable:
        lines += ['', 'Not testable in this record: ' + ', '.join(result.untestable)
                  + ' (coil contact: no stop angle between the nominal alpha_min and alpha* '
                  'lies within the stroke the nominal model reaches in the training part).']
    if result.rounds and result.rounds[0].restarted:
        lines += ['', 'The greedy path from the best single candidate ended with structured '
                  'residuals; the search restarted from the runner-up '
                  f'`{result.rounds[0].accepted}`, whose path has the lower held-out BIC '
                  '(n ln(S/n) + k ln n). The rounds below follow that path.']
    for rnd in result.rounds[1:]:
        lines += ['', f'### Round {len(rnd.base_effects) + 1}: base = nominal + '
                  f'{" + ".join(rnd.base_effects)}', '']
        lines += _candidate_table(rnd.scores, rnd.base_rmse, result.params)
    if 'ranking.png' in figures:
        lines += ['', '![candidate ranking](ranking.png)']
    lines += ['', '## Residual diagnostics (held-out part)', '',
              'A channel is structured when the inputs still predict its residual: an F-test '
              '(p < 0.001) of input-driven terms (model output, its square and rate, the '
              'temperature rise, the power through faster and slower lags, the direction '
              'of its last motion) against an '
              'offset, a drift and an AR noise model, and a predictable part larger than '
              'the rest of the residual and than 0.2 % of the swing (noise.py; the noise '
              'may be coloured). Ljung-Box on residuals decimated to 1 Hz; spectral '
              'flatness about 0.56 for white noise; heating/cooling means differ under '
              'hysteresis; a positive peak lag points to a sensor or thermal lag.', '']
    lines += _stats_table(result)
    lines += ['', '![residual diagnostics](residuals.png)']
    if 'temperature_residuals.png' in figures:
        lines += ['', '![temperature residuals](temperature_residuals.png)']
    params_file = os.path.basename(result.extended_params_path or 'extended_params.yaml')
    lines += ['', '## Use the extended model', '',
              '```bash', f'ros2 run tca_ros tca_node --ros-args --params-file {params_file}',
              f'tca_sim simulate --config {params_file} --input profile.csv', '```', '']
    path = os.path.join(report_dir, 'report.md')
    with open(path, 'w', encoding='utf-8') as fh:
        fh.write('\n'.join(lines))
    return path


def _muscle_md(result):
    """Return the muscle's config (and calibrated file) in markdown."""
    text = f'config `{result.config}`'
    if result.config_from_header:
        text += " (from the record's '# tca:' header)"
    if result.calibrated_file:
        text += f', nominal parameters from `{result.calibrated_file}`'
    return text


def _value_item(name, value, nominal):
    """Return a list item of an extended value: calibration name and params-file entry."""
    named = nominal_value(name, value, nominal)
    if named is None:
        return f'- `{name}` = {_fmt(value, 5)}'
    label, v, unit = named
    return f'- `{label}` = {_fmt(v, 4)} {unit} (`{name}` = {_fmt(value, 5)})'.replace(' - (', ' (')


def _json_safe(value):
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def write_report(result, report_dir):
    """Write every output of a diagnosis into ``report_dir``; set the paths on result."""
    os.makedirs(report_dir, exist_ok=True)
    params_path = os.path.join(report_dir, 'extended_params.yaml')
    header = (f'Extended params written by tca_sim diagnose from {result.record.source}\n'
              f'{result.muscle}; effects found: '
              f'{", ".join(result.effects) or "none"}; verdict {result.verdict}\n'
              f'effect parameters fitted with model={result.model}; dynamics.mass and '
              'dynamics.load taken from the record')
    muscle, start_note = muscle_at_rest(result.extended_params)
    dump_params(muscle, params_path, header=header + start_note)
    result.extended_params_path = params_path
    figures = write_figures(result, report_dir)
    result.figures = figures
    result.report_path = write_markdown(result, report_dir, figures)
    result.json_path = os.path.join(report_dir, 'diagnosis.json')
    with open(result.json_path, 'w', encoding='utf-8') as fh:
        json.dump(_json_safe(result.to_json()), fh, indent=2)
        fh.write('\n')
    return result.report_path
