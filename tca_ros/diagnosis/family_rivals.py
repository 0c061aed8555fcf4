"""Rivals calibrated jointly: a named effect's family, and the rival the deviance prefers.

The members of an effect's family (rivals.FAMILIES) can explain one record about
equally. :func:`family_rivals` calibrates the effect the search named and each of its
rivals jointly with the nominal parameters (joint.joint_calibrations) and says which
the records do not tell apart; :func:`decisive_despite_structure` names the rival that
predicts the held-out part decisively better though it leaves structure, on this path
and in the joint stage (docs/diagnosis_method.md, "Family rivals of a named effect" and
"Decisive despite structure").
"""
from tca_ros.diagnosis.joint import joint_calibrations, lowers_heldout_rms
from tca_ros.diagnosis.joint_groups import calibratable
from tca_ros.diagnosis.one_load import gain_took_up_softening
from tca_ros.diagnosis.rivals import DECISIVE_DEVIANCE, ONE_LOAD_SOFTENING, \
    rival_experiment_notes, rivals_of, unresolved_note, unresolved_rivals
from tca_ros.diagnosis.verdict import holds_one_load


def family_rivals(calibrate_with, problems, nominals, cal, candidates, found, nominal_rmse):
    """Return (a rival JointFit that replaces ``found`` or None, notes) of its family.

    The members of an effect's family (FAMILIES: the lags, the play operators, the
    heat-loss shapes) can explain one record about equally: without a temperature
    channel a sensor lag, a second thermal lag and a dead time all delay the stroke.
    The named effect and each rival are calibrated jointly with the nominal
    parameters (joint_calibrations); the rivals that pass best_joint's rule are
    listed with both penalised held-out gains, so the report says what the records
    do not tell apart. A rival replaces the search's effect only when its
    penalised held-out gain exceeds the named effect's own joint one by more than
    DECISIVE_DEVIANCE: the search refits the nominal parameters narrowly, so its
    pick can be the lag that the shifted damping let in, not the one the records ask
    for (a 0.22 s sensor lag at 2 Hz was named dead time, gains 766 against 266).
    The other rivals within DECISIVE_DEVIANCE of the one that replaces it are its
    own rivals, said with the experiment that would separate them.
    ``found``: the effect's name, or the names of a pair the search named; a pair's
    rivals are the pairs with one member swapped for one of its rivals (G49). On one
    load, an effect whose joint fit keeps an actuation gain the calibration moved down
    has modulus softening as a rival too (:func:`softening_swaps`, G88), whatever its
    family.
    """
    by_name = {n: c for n, c in calibratable(candidates).items() if c.starts}
    named = (found,) if isinstance(found, str) else tuple(found)
    swaps = [named[:i] + (rival,) + named[i + 1:] for i, effect in enumerate(named)
             for rival in by_name if rival in rivals_of(effect) and rival not in named]
    softening = softening_swaps(problems, cal, named, by_name)
    if not (swaps or softening) or any(n not in by_name for n in named):
        return None, []

    def calibrated(groups):
        return joint_calibrations(calibrate_with, problems, nominals, cal, candidates,
                                  [tuple(by_name[n] for n in group) for group in groups])
    fits = calibrated([named] + swaps)
    found = ' + '.join(named)
    own = next((f for f in fits if f.name == found), None)
    if softening and keeps_gain_down(own):  # the softening the kept gain may hide (G88)
        fits = fits + calibrated(softening)
    passing = sorted((f for f in fits if f.name != found and f.explained and not f.barred
                      and f.criterion > 0.0
                      and lowers_heldout_rms(problems, f.sims, nominal_rmse)),
                     key=lambda f: -f.criterion)
    near = unresolved_rivals(own, fits,
                             lambda f: lowers_heldout_rms(problems, f.sims, nominal_rmse))
    refuted = refuted_notes(f for f in fits if f.name != found)
    lead = decisive_despite_structure(own, passing, near)
    if lead is not None:
        return lead, [f'{found} was named by the search; {lead.name} is named: '
                      + lead.despite] + refuted
    if not passing:
        return None, refuted + unresolved_note(own, near) + rival_experiment_notes(own, near)
    gains = ', '.join(f'{f.name} (penalised held-out gain {f.criterion:.1f})'
                      for f in passing)
    if own is not None and passing[0].criterion > own.criterion + DECISIVE_DEVIANCE:
        best = passing[0]
        return best, [f'{found} was named by the search; calibrated jointly with all the '
                      f'nominal parameters, {gains} against {own.criterion:.1f} for '
                      f'{found}: {best.name} is named, its gain larger by more than '
                      f'{DECISIVE_DEVIANCE:g} (docs/diagnosis_method.md, "Family rivals")'
                      ] + refuted + rival_experiment_notes(best, passing[1:])
    against = f' against {own.criterion:.1f} for {found}' if own is not None else ''
    notes = [f'{found} is named by the search; also explained, calibrated jointly: '
             f'{gains}{against}: these records tell them apart only by that gain'] + refuted
    if own is None:
        return None, notes
    return None, notes + unresolved_note(own, near) + rival_experiment_notes(own, passing + near)


def softening_swaps(problems, cal, named, by_name):
    """Return the groups ``named`` with one member swapped for modulus softening, or [].

    On one load a softening modulus bends the stroke-temperature relation as a lower
    actuation gain does (one_load.py). When the calibration moved the gain down by
    more than GAIN_DOWN_Z prior spreads, an effect the search names beside that
    lowered gain may be standing in for the softening the gain took up; the softening
    is then its rival (decisions G88), calibrated only if the named effect's own
    joint fit keeps the gain down too (:func:`keeps_gain_down`).
    """
    if (cal is None or not problems or ONE_LOAD_SOFTENING in named
            or ONE_LOAD_SOFTENING not in by_name
            or not holds_one_load([p.record for p in problems])
            or not gain_took_up_softening(cal)):
        return []
    return [named[:i] + (ONE_LOAD_SOFTENING,) + named[i + 1:] for i in range(len(named))]


def keeps_gain_down(fit):
    """Return True when JointFit ``fit`` left the actuation gain over GAIN_DOWN_Z spreads down.

    An effect whose joint calibration returns the gain to the description has
    explained the move; one that keeps it down leaves it for a softening to explain.
    """
    return fit is not None and fit.calibration is not None \
        and gain_took_up_softening(fit.calibration)


def decisive_despite_structure(named, passing, near):
    """Return the rival that replaces ``named`` though it leaves structure (its ``despite`` set).

    ``named``: the JointFit taken; ``passing``: the others that explain the
    records too; ``near``: the rivals that pass every rule but the structure test
    (rivals.unresolved_rivals, best first). The best of ``near`` is taken when its
    penalised held-out gain beats ``named``'s and every passing fit's by more than
    DECISIVE_DEVIANCE. The structure test asks whether a model is all of the cause;
    which of two explains the records better is the held-out deviance's to say,
    and a smoother fit that leaves its residual under the floor is not the truer
    one (a 0.22 s dead time at 1 Hz left structure with a gain of 282.5 where a
    sensor lag left none at 164.2; in the four confusion-benchmark cases where
    the gap passed 10, the rival was the hidden effect: decisions G66).
    """
    if named is None or not near:
        return None
    bar = max([named.criterion] + [f.criterion for f in passing]) + DECISIVE_DEVIANCE
    if not near[0].criterion > bar:
        return None
    near[0].despite = rival_text(near[0], named)
    return near[0]


def rival_text(fit, named):
    """Return the clause giving why JointFit ``fit`` replaced ``named`` with structure left."""
    return (f'calibrated jointly with all the nominal parameters, it predicts the held-out '
            f'part better than {named.name}, which leaves no structure, by more than '
            f'{DECISIVE_DEVIANCE:g} (penalised held-out gains {fit.criterion:.1f} and '
            f'{named.criterion:.1f}: docs/diagnosis_method.md, "Decisive despite structure")')


def refuted_notes(fits):
    """Return a note on the JointFits of ``fits`` that a measurement refutes, or [].

    Such a fit (an ambient offset the thermometer at rest does not read:
    candidates.contradicted_by_measurement, kept in JointFit.refuted) is never taken,
    however well it predicts; the note says why a rival the reader may expect is not.
    """
    said = [f'{f.name} ({n} = {v:.4g}, against {what})' for f in fits
            for n, v, what in f.refuted]
    if not said:
        return []
    return ['not taken, refuted by a measurement: ' + ', '.join(said)]
