"""Rival effects: which the records may not tell apart, and the measurement that would.

Families of catalogue effects one record may explain alike (FAMILIES, HELD_BEHIND),
the rivals the verdict's structure test alone sets apart (unresolved_rivals), and
the experiment that would separate two rivals (issue 25). When the joint stage
(joint.py) finds another catalogue effect explaining the records about as well as
the one it names, the report says they are rivals and which experiment would tell
them apart. Each rival's joint calibration (the nominal
parameters and its effect's, on the same records) is a muscle that fits the records;
the calibration's experiment engine (calibration/experiments.py) simulates every
candidate experiment with both and keeps the one whose predictions differ most
against its sensor's noise. Measured with the catalogue's model (effects.py): a sensor
lag delays the displacement reading and a second thermal lag the actuating
temperature, neither the measured temperature, so a temperature channel cannot tell
them apart; a load step can (the coil's elastic response is immediate behind a
thermal lag, delayed by a sensor lag).
"""
from tca_ros.calibration.experiments import separating_experiment
from tca_ros.diagnosis.search import LAG_EFFECTS

#: held-out deviance by which a family rival's joint fit must beat the named effect's own
#: joint fit to replace it (Kass & Raftery's "very strong" evidence, 2 ln B > 10)
DECISIVE_DEVIANCE = 10.0
#: effects one record may not tell apart, tried together: the lags (each delays the
#: response), the play operators (on the temperature or on the elongation: the same band
#: of stroke under a constant load) and the heat-loss shapes (each bends the steady rise)
FAMILIES = (LAG_EFFECTS, ('hysteresis', 'friction'),
            ('ambient_offset', 'nonlinear_convection', 'radiation'))
#: families whose members are also each other's rivals (family_rivals): at a reversal of
#: the heating a lag rounds the stroke and a play operator holds it until its band is
#: crossed; sampled slower than that (1 Hz), both read as the stroke behind the nominal
HELD_BEHIND = (LAG_EFFECTS, ('hysteresis', 'friction'))
#: on one load, the rival of an effect named beside an actuation gain moved down: a
#: modulus that softens with temperature, which that gain may have taken up (one_load.py)
ONE_LOAD_SOFTENING = 'modulus_softening'


def rivals_of(name):
    """Return the effects (set, without ``name``) that may explain a record as ``name`` does."""
    groups = [f for f in FAMILIES if name in f]
    if any(name in f for f in HELD_BEHIND):
        groups += list(HELD_BEHIND)
    return {n for f in groups for n in f} - {name}


def unresolved_rivals(named, fits, lowers_rms):
    """Return the rivals of JointFit ``named`` that only the structure test sets apart.

    The JointFits of its rivals (:func:`swapped_rival`: one effect swapped for a rival of
    it, in a single or a pair) that pass every rule of
    joint.best_joint but the structure test (no parameter at a bound, a positive
    penalised held-out gain, ``lowers_rms(fit)`` True: the search's RMS rule), with a
    gain not decisively below the named fit's (within DECISIVE_DEVIANCE, or above
    it), best first. They predict the held-out part as well; what sets them apart is
    which side of the verdict's floor each leaves its residual, a threshold on a
    statistic they may share almost equally (seed 9121, a second thermal lag with a
    thermometer, its jittered steps held a sample late: the sensor lag's whole-record
    fit left 0.94 x the floor, the second lag's 1.05 x, penalised held-out gains 539.0
    and 540.4).
    """
    if named is None:
        return []
    near = [f for f in fits if swapped_rival(named.effects, f.effects)
            and not f.explained and not f.barred and f.criterion > 0.0
            and f.criterion >= named.criterion - DECISIVE_DEVIANCE and lowers_rms(f)]
    return sorted(near, key=lambda f: -f.criterion)


def swapped_rival(named, other):
    """Return True when effects ``other`` are ``named`` with one member swapped for a rival.

    Both are tuples of effect names: one effect and a rival of it (rivals_of), or a
    pair with one member replaced by one of that member's rivals.
    """
    if len(other) != len(named):
        return False
    changed = [(a, b) for a, b in zip(named, other) if a != b]
    return len(changed) == 1 and changed[0][1] in rivals_of(changed[0][0])


def unresolved_note(named, near):
    """Return the report's note on ``unresolved_rivals`` (a list: empty without any)."""
    if not near:
        return []
    return [f'{named.name} is a rival of ' + ', '.join(
        f'{f.name} (penalised held-out gain {f.criterion:.1f} against {named.criterion:.1f})'
        for f in near) + ': calibrated jointly, each predicts the held-out part as well or '
        "better, and only the verdict's structure test, which the rivals fail, sets them "
        'apart']


class RivalNote(str):
    """A report note on two rivals these records do not tell apart; a str like every note.

    ``named`` and ``rival``: the effect names (tuples) of the JointFit taken and of
    its rival. :func:`undecided_rivals` reads them back from a diagnosis's notes, so
    the verdict says 'X or Y' where the records leave the choice open.
    """

    named = ()
    rival = ()


def rival_note(text, named, rival):
    """Return ``text`` as a RivalNote of JointFits ``named`` and ``rival``."""
    note = RivalNote(text)
    note.named, note.rival = tuple(named.effects), tuple(rival.effects)
    return note


def undecided_rivals(effects, notes):
    """Return {effect: [rivals]}: the named ``effects``' rivals the records leave open.

    From the RivalNotes among ``notes`` whose named fit is ``effects`` (the effects
    the diagnosis names, in any order): a rival that differs from them by one member
    swapped for one of its family rivals (:func:`rivals_of`) or for modulus softening
    (ONE_LOAD_SOFTENING, which a calibrated gain hides on one load: G55, G88) is
    listed under that member.
    Empty when the records told every rival apart. The note on a fit the diagnosis
    later replaced (a rival taken instead, an effect below the floor dropped) is not
    read: its named effects are no longer the diagnosis's.
    """
    out = {}
    for note in notes:
        if not isinstance(note, RivalNote) or set(note.named) != set(effects):
            continue
        swapped = [(a, b) for a in note.named if a not in note.rival
                   for b in note.rival if b not in note.named]
        if len(swapped) == 1 and (swapped[0][1] in rivals_of(swapped[0][0])
                                  or swapped[0][1] == ONE_LOAD_SOFTENING):
            a, b = swapped[0]
            if b not in out.setdefault(a, []):
                out[a].append(b)
    return out


def rival_experiment(named, rival):
    """Return the Experiment separating two JointFits, or None (no calibration to simulate).

    ``named`` and ``rival`` are joint.JointFit, each with its joint Calibration (the
    values the records fit with that effect); the experiments are built on the
    named fit's records and noise (m of displacement, K of a thermocouple).
    """
    if named.calibration is None or rival.calibration is None:
        return None
    cal = named.calibration
    values = [named.calibration.report.values, rival.calibration.report.values]
    return separating_experiment(cal, values, (named.name, rival.name), 'effects')


def rival_experiment_notes(named, rivals, equal=None):
    """Return the report's notes: per equal rival, the experiment that separates it.

    Only the rivals the records do not tell apart from ``named`` get one; by
    default those with a penalised held-out gain within DECISIVE_DEVIANCE of the
    named fit's, or above it (one decisively below is told apart by these
    records); ``equal(rival)`` decides instead when given. Each note names both
    effects, the experiment, and how far apart the two jointly calibrated muscles are
    there and on the records (RMS, against the sensor noise; it separates them at
    experiments.SEPARATES noise units).
    """
    if equal is None:
        def equal(rival):
            return rival.criterion >= named.criterion - DECISIVE_DEVIANCE
    notes = []
    for rival in rivals:
        if not equal(rival):
            continue
        e = rival_experiment(named, rival)
        if e is None:
            continue
        notes.append(rival_note(f'{named.name} and {rival.name} are rivals: calibrated '
                                f'jointly, each fits these records; {e.sentence()}',
                                named, rival))
    return notes
