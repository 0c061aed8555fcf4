"""From the calibrated nominal model to the extension a diagnosis reports.

The greedy effect search (search.py) on the calibrated nominal model, then its
second opinions: the joint calibration of the best candidates with all the
nominal parameters (joint.py, confirmed on the whole record where the held-out
part shows only estimation error), the findings' effects tested as their cause
(findings.py) and a named effect's family rivals (docs/diagnosis_method.md,
"Joint calibration" and "Findings").
"""
from dataclasses import dataclass

from tca_ros.calibration.candidates import contradicted_by_measurement, parameters_at_bounds
from tca_ros.calibration.physical_priors import prior_spreads
from tca_ros.diagnosis.described import admitted_effects
from tca_ros.diagnosis.effect_size import below_floor, below_floor_note, NOMINAL_VERDICT
from tca_ros.diagnosis.family_rivals import decisive_despite_structure, family_rivals
from tca_ros.diagnosis.findings import explain_findings, finding_effects, findings_rival, \
    found_text, own_readings, unexplained_findings
from tca_ros.diagnosis.joint import beats_nominal, joint_extension, WITHIN_DESCRIPTION
from tca_ros.diagnosis.joint_text import beside_slack_note, described_note, joint_notes, \
    set_aside_note, undone_note
from tca_ros.diagnosis.most_of_structure import most_of_structure_text, \
    takes_most_of_structure
from tca_ros.diagnosis.one_load import gain_took_up_softening, predictable_below_floor, \
    RIVAL as ONE_LOAD_RIVAL, softening_on_one_load
from tca_ros.diagnosis.search import MIN_GAIN_PERCENT, search_effects
from tca_ros.diagnosis.thermometer import thermometer_refutes
from tca_ros.diagnosis.verdict import channel_stats, decide_verdict, holds_one_load, \
    needs_explaining, NOTHING_TO_EXPLAIN, pooled_heldout_rmse
from tca_ros.diagnosis.verdict_text import found_sentence
from tca_ros.model.params_schema import SPECS


@dataclass
class Nominal:
    """The calibrated nominal model of a diagnosis: its problems, simulations and scores."""

    problems: list  # FitProblem per record
    problem: object  # the FitProblem, or a FitProblemSet of several records
    start_values: dict  # the search's start (the recalibration's values)
    sims: list  # SimulationResult per record at the record rate
    cal: object  # Calibration, or None
    candidates: list  # the catalogue candidates searched

    def __post_init__(self):  # noqa: D105 -- the held-out and whole-record scores
        self.stats = channel_stats(self.problems, self.sims)
        # an effect may show in the training part only (creep settled before the split)
        self.whole_stats = channel_stats(self.problems, self.sims, whole=True)
        self.rmse = pooled_heldout_rmse(self.problems, self.sims, self.problem.channels)
        # the reference of the 1 % rule (joint.lowers_heldout_rms): drift removed
        self.drift_free_rmse = pooled_heldout_rmse(self.problems, self.sims,
                                                   self.problem.channels, detrend=True)

    def judged(self, effects, values, extendeds, confirmed=None):
        """Return (held-out RMSE, residual stats, verdict, explanation) of an extension.

        ``confirmed``: a joint fit's (whole-record stats, gain) (JointFit.confirmed).
        """
        rmse = pooled_heldout_rmse(self.problems, extendeds, self.problem.channels)
        stats = channel_stats(self.problems, extendeds,
                              [p.parameters(values) for p in self.problems])
        return (rmse, stats) + decide_verdict(effects, self.stats, stats, self.whole_stats,
                                              confirmed)

    def adopted(self, fit):
        """Return (effects, values, sims, judgement) of a JointFit taken as the extension."""
        effects = list(fit.claimed)
        return effects, fit.values, fit.sims, self.judged(effects, fit.values, fit.sims,
                                                          fit.confirmed)

    def adopted_despite(self, fit):
        """Return adopted()'s tuple and whether ``fit`` is found with structure beside it.

        ``fit``: a rival named though it leaves structure
        (family_rivals.decisive_despite_structure): an 'unexplained' verdict names it
        with its reason (``fit.despite``) and says what remains.
        """
        effects, values, sims, judgement = self.adopted(fit)
        if judgement[2] != 'unexplained':
            return effects, values, sims, judgement, False
        sentence = found_sentence(effects, judgement[1], fit.despite)
        return effects, values, sims, judgement[:3] + (sentence,), True


def run_search(nominal, notes):
    """Return (effects, values, extended sims, rounds) of the greedy effect search.

    No search when the inputs predict nothing of the nominal model's residual
    (the structure test's F-test, held-out part and whole record); a residual
    they predict significantly is searched though it is below the practical
    floor (G96): small is not noise, and the search's acceptance decides. An
    extension that does not beat the calibrated nominal by the search's own rule
    is dropped with a note.
    """
    problems, start_values = nominal.problems, nominal.start_values
    effects, values, rounds = [], dict(start_values), []
    if (needs_explaining(nominal.stats, nominal.whole_stats)
            or predictable_below_floor(nominal.stats, nominal.whole_stats)):
        effects, values, rounds = search_effects(nominal.problem, nominal.candidates)
    else:  # what the nominal model leaves is noise by the verdict's test: no search
        notes.append(NOTHING_TO_EXPLAIN)
    values = values if effects else dict(start_values)  # not the round-one polish
    extendeds = [p.simulate_full(values) for p in problems] if effects else nominal.sims
    added = len([k for k in values if k not in start_values])
    if effects and not beats_nominal(problems, nominal.sims, extendeds, added,
                                     nominal.drift_free_rmse):
        # each effect was accepted against the round's base (the nominal with its
        # calibration refitted); the whole extension must beat the calibrated
        # nominal itself by the search's own rule, or it is no improvement to report
        notes.append(f'{" + ".join(effects)} fitted, but not kept: the extended model '
                     'does not predict the held-out part better than the calibrated '
                     'nominal model (penalised held-out gain <= 0, or held-out RMS gain '
                     f'below {MIN_GAIN_PERCENT:g} %)')
        effects, values, extendeds = [], dict(start_values), nominal.sims
    return effects, values, extendeds, rounds


#: how a below-floor search's note ends when the diagnosis goes on without it (opinions)
UNSEARCHED = ('; the diagnosis goes on as if nothing had been searched below the floor '
              '(decisions G96)')


def opinions(nominal, calibrate_with, effects, values, extendeds, rounds, notes):
    """Return :func:`second_opinions` of the search's outcome, a search below the floor undone.

    A search that ran only because the inputs predict the calibrated nominal model's
    residual below the practical floor (run_search, G96) counts when the diagnosis
    ends with an effect named. When it ends with none (its effect too small to name,
    at a bound, ...), the diagnosis is the unsearched nominal model's (the findings'
    effects, a softening on one load: what the search's effect would otherwise have
    pre-empted), with the note on what the search fitted below the floor.
    """
    start = len(notes)
    outcome = second_opinions(nominal, calibrate_with, effects, values, extendeds, rounds,
                              notes)
    if not effects or outcome[0] or needs_explaining(nominal.stats, nominal.whole_stats):
        return outcome
    said = [n.replace(NOMINAL_VERDICT, UNSEARCHED) for n in notes[start:]
            if n.startswith('fitted but not named')]
    del notes[start:]
    notes.extend(said)
    return second_opinions(nominal, calibrate_with, [], dict(nominal.start_values),
                           nominal.sims, [], notes)


def at_bounds(judgement, effects, values, nominal, extendeds, witnessed=True):
    """Return ``judgement`` (RMSE, stats, verdict, sentence), 'unexplained' if no cause.

    An 'explained' whose effects stand in for another cause (:func:`standing_in`: a
    parameter at the end of its physical range, a value a measurement refutes) is no
    explanation.
    """
    if judgement[2] != 'explained':
        return judgement
    why = standing_in(effects, values, nominal, extendeds, witnessed)
    return judgement if why is None else judgement[:2] + ('unexplained', why)


def standing_in(effects, values, nominal, extendeds, witnessed=True):
    """Return why ``effects`` stand in for another cause (the verdict's sentence), or None.

    A parameter at the end of its physical range (candidates.parameters_at_bounds),
    a value a measurement refutes (an ambient offset the thermometer at rest does not
    read, candidates.contradicted_by_measurement) or, unless ``witnessed`` is False
    (effects named on the findings' evidence, joint.joint_calibrations), a
    heat-balance effect whose ``extendeds`` predict the thermometer worse than
    ``nominal``'s simulations (thermometer.thermometer_refutes): such effects are
    named nowhere, however much structure they take away.
    """
    candidates = nominal.candidates
    pinned = parameters_at_bounds(effects, values, candidates)
    if pinned:
        return ('the effects found leave no structure, but '
                + ', '.join(f'{n} = {v:.4g} {SPECS[n].unit}' for n, v, _ in pinned)
                + ' sits at the end of its physical range: the data ask for more than the '
                'effect can be, so it stands in for a cause that is not in the catalogue '
                'and is not named')
    refuted = contradicted_by_measurement(effects, values, candidates)
    if refuted:
        return ('the effects found leave no structure, but '
                + ', '.join(f'{n} = {v:.4g} {SPECS[n].unit} is outside {lo:.4g} to {hi:.4g} '
                            f'from {what}' for n, v, lo, hi, what in refuted)
                + ': it stands in for another cause and is not named')
    refuted = thermometer_refutes(effects, values, nominal.problems, nominal.sims, extendeds,
                                  candidates) if witnessed else []
    if refuted:
        return ('the effects found leave no structure, but '
                + ', '.join(f'{n} = {v:.4g}' for n, v, _ in refuted)
                + f' is refuted by {refuted[0][2]}: it stands in for another cause and is '
                'not named')
    return None


def second_opinions(nominal, calibrate_with, effects, values, extendeds, rounds, notes):
    """Return (effects, values, extended sims, judgement, found) after the search's checks.

    ``judgement`` is Nominal.judged's (RMSE, stats, verdict, explanation); ``found``
    True when the effects are named though structure remains (verdict
    'unexplained': a findings' effect found with structure left, findings.py). A record
    the search leaves unexplained gets the joint stage (joint.py), which also tries
    the effects the calibration's findings name; a record the calibrated nominal
    model leaves adequate while its calibration moved values beyond the description
    gets those effects tested as the finding's cause (findings.py); an explanation
    with a parameter at the end of its range is not one; a single effect of a
    family, or a pair, gets its rivals said (family_rivals.py); an effect named on
    the residual's evidence whose own part of the prediction is within 0.5 % of the
    swing is not named (effect_size.py).
    """
    # an explanation with a parameter at the end of its range is none: the joint stage
    # and the findings' effects get their chance at what it stands in for
    judgement = at_bounds(nominal.judged(effects, values, extendeds), effects, values,
                          nominal, extendeds)
    cal, joint, found = nominal.cal, None, False
    on_findings = set()  # effects named on the findings' evidence: values the fit moved
    named_by_findings = finding_effects(cal)
    one_load = holds_one_load([p.record for p in nominal.problems])
    if judgement[2] == 'unexplained' and cal is not None and rounds:
        # the search's nominal refit is narrow: calibrate its first round's best
        # candidates together with the nominal parameters (joint.py)
        extra = list(named_by_findings)
        if one_load and ONE_LOAD_RIVAL not in extra and gain_took_up_softening(cal):
            # on one load a gain moved down may have taken up a softening: the search's
            # screen (a softening added on top of that gain) cannot see it (one_load.py)
            extra.append(ONE_LOAD_RIVAL)
        joint, rivals, near, described, undone, aside, beside = joint_extension(
            calibrate_with, nominal.problems, nominal.sims, cal, nominal.candidates, rounds,
            nominal.drift_free_rmse, extra=extra)
        if beside and (joint is None or beside[0][0].criterion > joint.criterion):
            notes.append(beside_slack_note(beside))
        if undone and (joint is None or undone[0].criterion > joint.criterion):
            notes.append(undone_note(undone))
        if aside:  # an explanation set aside: a rival the reader is told of either way
            notes.append(set_aside_note(aside))
        if described is not None:  # the muscle as described explains it best: no finding
            notes.append(described_note(described))
            named_by_findings = []
        lead = decisive_despite_structure(joint, rivals, near)
        if lead is not None:  # decisively the better rival, though not all of the cause
            notes.extend(joint_notes(joint, rivals, effects, near))
            notes.append(f'{lead.name} is named instead of {joint.name}: {lead.despite}')
            effects, values, extendeds, judgement, found = nominal.adopted_despite(lead)
            joint = lead
        elif joint is not None:
            notes.extend(joint_notes(joint, rivals, effects, near))
            effects, values, extendeds, judgement = nominal.adopted(joint)
    if joint is None and judgement[2] != 'explained' and named_by_findings:
        # the calibration moved stated values: their effects tested as the cause, whether
        # the moved values leave nothing structured (adequate) or not (unexplained: a
        # power loss predicts the held-out part as the shifted heat loss does, so the
        # joint stage's held-out rule cannot take it; the priors can)
        taken, said = explain_findings(calibrate_with, nominal.problems, nominal.sims, cal,
                                       nominal.candidates)
        notes.extend(said)
        if taken is not None:
            joint = taken.fit
            effects, values, extendeds, judgement = nominal.adopted(joint)
            on_findings = set(effects)
            if taken.over_described is not None and judgement[2] == 'unexplained':
                # named on the description's evidence; the verdict says both
                found = True
                judgement = judgement[:3] + (found_sentence(effects, judgement[1],
                                                            found_text(taken)),)
    if joint is None and judgement[2] == 'adequate' and cal is not None and cal.findings():
        # adequate only by leaving the description: no effect the findings stand for
        # explains them, or they stand for none (a value moved the way no effect moves
        # it, G82)
        judgement = judgement[:2] + ('unexplained', unexplained_findings(cal))
    if (judgement[2] == 'adequate' and not effects and cal is not None
            and one_load
            and predictable_below_floor(nominal.stats, nominal.whole_stats)):
        # adequate by the practical floor while the inputs still predict the residual:
        # on one load the calibrated gain may hide a softening modulus (one_load.py)
        taken, said, refuted = softening_on_one_load(calibrate_with, nominal.problems,
                                                     nominal.sims, cal, nominal.candidates,
                                                     nominal.stats)
        notes.extend(said)
        if taken is not None:
            joint = taken
            effects, values, extendeds, judgement = nominal.adopted(taken)
        elif refuted is not None:  # beaten decisively on held-out data, by no effect (G97)
            judgement = judgement[:2] + ('unexplained', refuted)
    rmse, stats, verdict, explanation = at_bounds(judgement, effects, values, nominal,
                                                  extendeds, witnessed=not on_findings)
    if (verdict == 'explained' and joint is None and cal is not None and named_by_findings
            and not set(effects) & set(own_readings(cal))):
        # the search explained the records with effects none of the findings stand for
        # (a room only as a heat loss's second reading, G90): the findings' own effects,
        # calibrated jointly, are its rivals (findings.py)
        added = len([k for k in values if k not in nominal.start_values])
        taken, said = findings_rival(calibrate_with, nominal.problems, nominal.sims, cal,
                                     nominal.candidates, effects, extendeds, added)
        notes.extend(said)
        if taken is not None:
            joint = taken.fit
            effects, values, extendeds, judgement = nominal.adopted(joint)
            on_findings = set(effects)
            rmse, stats, verdict, explanation = judgement
    if verdict == 'explained' and joint is None and cal is not None:
        # a member within what the description states is the muscle as described (G69)
        effects, said = described_members(nominal, effects, values)
        if said:
            notes.extend(said)
            rmse, stats, verdict, explanation = nominal.judged(effects, values, extendeds)
    if verdict == 'explained' and joint is None and len(effects) in (1, 2) and cal is not None:
        # effects of families the records may not tell apart: the rivals (one member
        # swapped for each of its rivals) calibrated jointly; one decisively better
        # replaces them, the others are said
        taken, said = family_rivals(calibrate_with, nominal.problems, nominal.sims, cal,
                                    nominal.candidates, tuple(effects),
                                    nominal.drift_free_rmse)
        notes.extend(said)
        if taken is not None:
            if taken.despite is not None:  # decisively the better rival, structured (G66)
                effects, values, extendeds, judgement, found = nominal.adopted_despite(taken)
            else:
                effects, values, extendeds, judgement = nominal.adopted(taken)
            rmse, stats, verdict, explanation = judgement
    tested = [e for e in effects if e not in on_findings]
    small = below_floor(nominal.problems, nominal.stats, tested, values, extendeds,
                        nominal.sims if len(effects) == 1 else None)
    if small:  # an effect whose own part of the prediction the verdict would ignore
        kept = [e for e in effects if e not in dict(small)]
        notes.append(below_floor_note(small, kept))
        if kept:
            effects = kept
        else:
            effects, values, extendeds, found = [], dict(nominal.start_values), nominal.sims, False
            rmse, stats, verdict, explanation = nominal.judged(effects, values, extendeds)
    if (verdict == 'unexplained' and effects and not found and needs_explaining(stats)
            and takes_most_of_structure(nominal.stats, stats)
            and standing_in(effects, values, nominal, extendeds, not on_findings) is None):
        # a cause, though not all of it: what remains is a tenth of what was (G91)
        found = True
        explanation = found_sentence(effects, stats, most_of_structure_text(
            nominal.stats, stats, len(effects)))
    return effects, values, extendeds, (rmse, stats, verdict, explanation), found


def described_members(nominal, effects, values):
    """Return (effects, notes): the search's ``effects`` less those the description admits.

    ``values``: the extension's dotted values. A member whose size moves its twin no
    more than SHIFT_Z prior spreads from the description (described.admitted_effects: a
    power loss within the stated delivered power, an ambient offset within the
    stated room, a radiation or a convection exponent within the stated heat loss)
    is the described muscle's own slack, as in a joint fit (JointFit.claimed): kept
    in the model, not named.
    Only beside a member that is named: a search whose every effect the description
    admits keeps its names (decisions G69).
    """
    cal = nominal.cal
    if cal is None or len(effects) < 2:
        return effects, []
    admitted = admitted_effects(effects, nominal.problems[0].parameters(values), cal.start,
                                prior_spreads(cal.start),
                                'temperature' in nominal.problem.channels)
    if not admitted or len(admitted) == len(effects):
        return effects, []
    return [e for e in effects if e not in admitted], [
        f'{" + ".join(admitted)} of the search\'s extension is {WITHIN_DESCRIPTION}: the '
        'muscle as described, not named beside '
        f'{" + ".join(e for e in effects if e not in admitted)}']
