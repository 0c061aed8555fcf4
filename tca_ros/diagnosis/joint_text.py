"""What a diagnosis report says of the joint stage (joint.py).

The fit taken, its rivals, the muscle as described, and the fits set aside.

Each sentence names the fit and the figure it rests on (docs/diagnosis_method.md,
"Joint calibration").
"""
from tca_ros.diagnosis.joint import WITHIN_DESCRIPTION
from tca_ros.diagnosis.rivals import DECISIVE_DEVIANCE, rival_experiment_notes, unresolved_note
from tca_ros.model.params_schema import SPECS


def described_note(fit):
    """Return the note on a fit the description admits that explained the records best."""
    sizes = ', '.join(f'{name.split(".")[-1]} = {value:.3g}' for name, value in fit.values.items()
                      if name.startswith('effects.'))
    moved = fit.calibration.findings() if fit.calibration is not None else []
    beyond = ('; its calibration still moves ' + ', '.join(
        f'{name} {z:+.1f} prior spreads' for name, z, _ in moved)
        + ' beyond the description, which no effect named here explains' if moved else '')
    return (f'{fit.name} ({sizes}), calibrated jointly with all the nominal parameters, '
            'explains the records decisively better than any effect (penalised held-out '
            f'gain {fit.criterion:.1f}), and its size is {WITHIN_DESCRIPTION}: the muscle '
            f'is as described there, and no effect is named{beyond} '
            '(docs/diagnosis_method.md, "Joint calibration")')


def joint_notes(joint, rivals, searched, near=()):
    """Return the report's notes on a JointFit taken over the search's ``searched`` effects.

    ``rivals``: the others that explain too (best_joint); ``near``: those only the
    structure test set apart (unresolved_rivals). Each is said with the experiment
    that would separate it from the one taken (rivals.py): each rival within
    DECISIVE_DEVIANCE of the fit taken on the figure that chose it, the penalised
    held-out gain less what it moves the described values by (JointFit.weighed, G84),
    is one these records leave open (G89).
    """
    left = f' with {" + ".join(searched)}' if searched else ''
    pair = len(joint.effects) > 1
    notes = [f'the search left the records unexplained{left}; {joint.name}, calibrated '
             'jointly with all the nominal parameters on the training part, '
             f'{"explain" if pair else "explains"} it (docs/diagnosis_method.md, '
             f'"Joint calibration": {"pairs" if pair else "singles"})']
    if joint.admitted:
        notes.append(f'{" + ".join(joint.admitted)} of that fit is {WITHIN_DESCRIPTION}: the '
                     'muscle as described, not named')
    if rivals and not any(f.cost for f in (joint, *rivals)):
        notes.append('also explained, calibrated jointly: ' + ', '.join(
            f'{f.name} (penalised held-out gain {f.criterion:.1f} against '
            f'{joint.criterion:.1f})' for f in rivals)
            + '; these records tell them apart only by that gain')
    elif rivals:  # weighed with what each moves the described values by (G84)
        notes.append('also explained, calibrated jointly: ' + ', '.join(
            f'{f.name} ({_weighed(f)} against {_weighed(joint)})' for f in rivals)
            + '; these records tell them apart only by that gain and by how far each moves '
            'what the description states (a power loss the delivered power, an ambient offset '
            'the room, radiation or convection the heat loss), z^2 in its prior spreads')
    return notes + unresolved_note(joint, near) + rival_experiment_notes(
        joint, [*rivals, *near], equal=lambda f: f.weighed >= joint.weighed - DECISIVE_DEVIANCE)


def _weighed(fit):
    """Return 'penalised held-out gain G less z^2 C of the described values = W' (-)."""
    return (f'penalised held-out gain {fit.criterion:.1f} less {fit.cost:.1f} for the '
            f'described values it moves = {fit.weighed:.1f}')


def undone_note(fits):
    """Return the note on JointFits set aside for undoing their own effect (G83).

    ``fits``: JointOutcome.undone (not empty), best first: each explained the
    records, but only with a value its own effect moves the other way left beyond
    the description.
    """
    return '; '.join(
        f'{f.name}, calibrated jointly with all the nominal parameters, explains the records '
        f'(penalised held-out gain {f.criterion:.1f}) only with '
        + ', '.join(f'{name} {z:+.1f} prior spreads' for name, z, _ in f.undone)
        + ', a shift ' + ' and '.join(sorted({e for _, _, es in f.undone for e in es}))
        + ' makes the other way' for f in fits) + (
        ': the effect fitted larger than the records ask, its excess taken back by a '
        'nominal value, is not their cause and is not named (docs/diagnosis_method.md, '
        '"Joint calibration": undone)')


def set_aside_note(fits):
    """Return the note on JointFits set aside for a value at a bound or refuted (G61, G86).

    ``fits``: JointOutcome.aside (not empty), best first: each explained the
    records and predicted the held-out part better than the nominal model, but
    only with a parameter of its effect at the end of its physical range (an
    emissivity of 1, a lag at its longest) or with a value a measurement refutes
    (a room the thermometer at rest does not read, a temperature the thermometer
    reads worse).
    """
    return '; '.join(
        f'{f.name}, calibrated jointly with all the nominal parameters, explains the records '
        f'(penalised held-out gain {f.criterion:.1f}) only with ' + ', '.join(
            [f'{name} = {value:.4g}{_unit(name)}, the end of its physical range'
             for name, value, _ in f.pinned]
            + [f'{name} = {value:.4g}{_unit(name)}, refuted by {what}'
               for name, value, what in f.refuted]) for f in fits) + (
        ': an effect that needs more than it can be, or that a measurement contradicts, '
        'stands in for another cause and is not named (docs/diagnosis_method.md, '
        '"Effects at a bound, or refuted by a measurement")')


def beside_slack_note(beside):
    """Return the note on pairs whose partner stood only beside the description's slack.

    ``beside``: JointOutcome.beside (not empty), best first: (pair, {member:
    penalised held-out gain calibrated alone}); each pair explained the records,
    one member within what the description states (joint.stands_alone, G66, G95).
    """
    def alone(gains):
        return ', '.join(f'{e} {g:.1f}' for e, g in gains.items()) or 'none calibrated'
    return '; '.join(
        f'{f.name}, calibrated jointly with all the nominal parameters, explains the records '
        f'(penalised held-out gain {f.criterion:.1f}; alone: {alone(gains)}), '
        + ' and '.join(f.admitted) + ' within what the description states'
        for f, gains in beside) + (
        ": beside the description's own slack a partner is named only when it helped alone "
        f'and the pair predicts the held-out part more than {DECISIVE_DEVIANCE:g} better than '
        'the admitted member alone; not named (docs/diagnosis_method.md, "Joint '
        'calibration": pairs)')


def _unit(name):
    """Return ' <unit>' of a dotted parameter name, or '' for a number without one."""
    unit = SPECS[name].unit
    return '' if unit in ('-', '') else f' {unit}'
