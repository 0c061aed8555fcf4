"""A calibration reported: its one-screen summary, and a plot of every record.

The plot shows measured vs start vs calibrated contraction (full dynamics).
"""
import math
import os

import numpy as np

from tca_ros.calibration.calibration import ROOM
from tca_ros.calibration.candidates import THERMOMETER_TOLERANCE_K
from tca_ros.calibration.conditions import is_isometric
from tca_ros.calibration.predictions import full_predictions
from tca_ros.calibration.where import PRINTED, window_note
from tca_ros.model.quasistatic_effects import equilibrium_bound
from tca_ros.model.thermal import HeatBalance

COLUMNS = 4  # subplots per row
FIGURE_DPI = 100


def write_calibration_report(cal, report_dir):
    """Write ``records.png`` (one panel per record, mm over s); return its path.

    Plots the full-dynamics fits ``calibrate`` scored (simulated here when it ran
    without its check).
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    n = len(cal.records)
    rows = math.ceil(n / COLUMNS)
    cols = min(n, COLUMNS)
    fig, axes = plt.subplots(rows, cols, figsize=(4.0 * cols, 2.8 * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    start_fit, fit = cal.start_fit, cal.fit
    if not fit:
        start_fit, fit = ([p['displacement'] for p in full_predictions(
            params, cal.records, cal.model, ['displacement'], cal.supply)]
            for params in (cal.start, cal.params))
    for ax, record, before, after in zip(axes.flat, cal.records, start_fit, fit):
        for displacement, style, label in ((before, ':', 'start'), (after, '-', 'calibrated')):
            ax.plot(record.time, displacement * 1e3, style, lw=1.2, label=label)
        ax.plot(record.time, record.displacement * 1e3, 'k.', ms=2, label='measured')
        ax.set_title(os.path.basename(record.source or '?')[-40:], fontsize=8)
        ax.set_xlabel('time (s)')
        ax.set_ylabel('contraction (mm)')
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=7)
    fig.tight_layout()
    path = os.path.join(report_dir, 'records.png')
    fig.savefig(path, dpi=FIGURE_DPI)
    plt.close(fig)
    return path


def format_summary(cal):
    """Return the one-screen summary of a Calibration."""
    power = 'nominal (on/off)' if cal.nominal_power else 'measured'
    lines = [f'calibrated on {len(cal.records)} record(s), model {cal.model}, channels '
             + ', '.join(cal.channels) + f'; power {power}, supply {cal.supply}',
             f'{"parameter":<28s}{"start":>12s}{"calibrated":>13s}{"std err":>11s}  unit',
             ]
    for est in cal.report.estimates.values():
        flag = '' if est.determined else '  (not determined: mostly its prior)'
        lines.append(f'{est.name:<28s}{est.prior:>12.4g}{est.value:>13.4g}'
                     f'{est.stderr:>11.2g}  {est.unit}{flag}')
    lines += format_plausibility(cal)
    if cal.nrmse:
        lines.append('record                               nRMSE start  nRMSE calibrated')
        for r, a, b in zip(cal.records, cal.start_nrmse, cal.nrmse):
            name = (r.source or '?').rsplit('/', 1)[-1][-36:]
            lines.append(f'{name:<36s}{a:>12.1%}{b:>18.1%}')
        lines.append(f'{"median":<36s}{np.median(cal.start_nrmse):>12.1%}'
                     f'{np.median(cal.nrmse):>18.1%}')
    lines += [f'note: {n}' for n in where_fitted(cal.records, cal.fit)]
    lines += [f'note: {n}' for n in cal.notes]
    if not cal.report.success:
        lines.append(f'warning: the fit did not converge ({cal.report.message})')
    return '\n'.join(lines)


def where_fitted(records, fits):
    """Return the note (a list of at most one) on where the calibrated fit misses most.

    ``records``: the Records calibrated on; ``fits``: per record the calibrated
    full-dynamics contraction (m) on its samples (empty when not scored). Isometric
    records (a force, not a contraction) are not judged. The note says when one
    moment carries much of the displacement residual (where.window_note), which the
    calibration fitted as if it were the muscle.
    """
    if not fits or len(fits) != len(records) or any(is_isometric(r) for r in records):
        return []
    note = window_note(records, [r.displacement - np.asarray(f, float)
                                 for r, f in zip(records, fits)], 'displacement',
                       *PRINTED['displacement'])
    return [note + '; the calibration fitted that moment as muscle too: if it is not the '
            "muscle's, calibrate on the records without it"] if note else []


def format_plausibility(cal):
    """Return the lines of the plausibility report: value, prior, physical reference, z."""
    rows = cal.plausibility()
    if not rows:
        return []
    lines = ['plausibility: each value beside its prior (z in prior spreads) and its physical '
             'reference',
             f'{"parameter":<28s}{"value":>11s}{"prior":>11s}{"z":>7s}{"physical":>11s}'
             f'{"ratio":>7s}  limits']
    for row in rows:
        ref = f'{row.reference:>11.4g}' if row.reference == row.reference else f'{"-":>11s}'
        ratio = f'{row.ratio:>7.2f}' if row.ratio == row.ratio else f'{"-":>7s}'
        limits = '-'.join('..' if v != v else f'{v:.3g}' for v in (row.low, row.high))
        flag = '  IMPLAUSIBLE' if row.implausible else '  SHIFTED' if row.shifted else ''
        lines.append(f'{row.name:<28s}{row.value:>11.4g}{row.prior:>11.4g}{row.z:>7.1f}'
                     f'{ref}{ratio}  {limits} {row.unit}{flag}')
    lines += prior_kinds(cal)
    values = {r.name: r.value for r in rows}
    if 'heat_capacity' in values and 'heat_loss' in values:
        tau = values['heat_capacity'] / values['heat_loss']
        peak = max((float(np.max(r.power)) for r in cal.records), default=0.0)
        # eq. (1') at rest: the loss law of the description (a rise per watt that falls
        # as the loss grows with the rise) and the delivered power of the calibration
        hot = equilibrium_bound(peak, HeatBalance.of(cal.params))
        effects = cal.params.effects
        at = (f' (at {effects.convection_reference_dt:g} K; the loss grows as dT^'
              f'{effects.convection_exponent:.2g})' if effects.convection_exponent else '')
        lines.append(f'derived: thermal time constant {tau:.3g} s, steady rise '
                     f'{1.0 / values["heat_loss"]:.3g} K/W{at}, {hot:.0f} degC at the '
                     f'highest logged power {peak:.3g} W')
    for a, b, kind, spread in cal.combinations():
        to = f' (to {spread:.0%})' if spread == spread else ''
        lines.append(f'the records fix the {kind} of {a} and {b}{to}, not each: their '
                     'priors share the rest')
    from tca_ros.calibration.experiments import format_experiments, next_experiments
    lines += format_experiments(next_experiments(cal))
    from tca_ros.calibration.physical_priors import finding_causes_of
    for name, z, effects in cal.findings():
        if name == ROOM:
            lines.append(room_finding_line(cal) + ' (`tca_sim diagnose` tests it)')
            continue
        lines.append(f'finding: {name} moved z = {z:+.1f} prior spreads from the description '
                     '(beyond its stated uncertainty): the muscle differs there, or '
                     + finding_causes_of(cal, name, z, effects) + ' stands in'
                     + (' (`tca_sim diagnose` tests the effects)' if effects else ''))
    bad = [r.name for r in rows if r.implausible]
    if bad:
        lines.append('warning: implausible ' + ', '.join(bad) + ': outside the physical limits '
                     'of the thread and geometry; the fit uses them to stand in for physics the '
                     'model lacks')
    if 'resistance' not in cal.channels and 'temperature' not in cal.channels:
        lines.append('note: no temperature or resistance channel: temperatures are the '
                     "priors' (heat_loss, delivered_power_ratio), not measured")
    return lines


def room_finding_line(cal):
    """Return the line of the finding on the room (Calibration.room_reading): degC, z."""
    read, room, z = cal.room_reading()
    return (f'finding: the thermometer at rest reads {read:.4g} degC where the model has '
            f'the room at {room:.4g} degC: z = {z:+.1f} over the stated uncertainty of the '
            f'ambient and the {THERMOMETER_TOLERANCE_K:g} K of a thermometer together: the '
            'room differs from the description, or the thermometer is off; an '
            'ambient_offset stands for it')


MEASURED_U, GUESSED_U = 0.1, 1.0  # relative uncertainties (uncertainty.*) of the kinds


def prior_kinds(cal):
    """Return the line saying which values the description gave as measured or guessed.

    A tight prior (measured) reveals an effect as a finding; a loose one (guessed)
    lets the calibration absorb it without a word.
    """
    from tca_ros.calibration.physical_priors import LINEAR
    stated = cal.start.uncertainty
    kinds = {'measured': [], 'estimated': [], 'guessed': []}
    for name in cal.priors:
        u = getattr(stated, name, None)
        if u is None or name in LINEAR:
            continue
        kind = 'measured' if u <= MEASURED_U else 'guessed' if u >= GUESSED_U else 'estimated'
        kinds[kind].append(f'{name} ({u:.2g})')
    parts = [f'{k}: {", ".join(v)}' for k, v in kinds.items() if v]
    return ['priors from the description (uncertainty.*; measured ones reveal an effect, '
            'guessed ones absorb it): ' + '; '.join(parts)] if parts else []
