"""Calibrate the nominal model jointly with a candidate or a pair: the search's second opinion.

Calibrate-first fits the nominal parameters on the training part before any
effect is tried, and an effect in the data is then partly taken up by them: a
creeping coil calibrates as a coil seven times too soft (seed 9014), a second
thermal lag as a large damping. The greedy search (search.py) refits only the
gain, the delivered power, the specific heat and the damping with each
candidate, within narrow factors of their calibrated values, so it cannot give
back what the stiffness or the time constant absorbed. When its result leaves
structure, the best candidates of its first round (joint_order) are each
calibrated here together with all the nominal parameters, with the
calibration's own priors and bounds
(calibration.calibrate with the effect's parameters in ``fit``), on the same
training part. A candidate is taken only when its joint calibration passes the
search's acceptance against the calibrated nominal model (the penalised held-out
gain under the verdict's noise model, at least MIN_GAIN_PERCENT), leaves no
structure by the verdict's test and has no parameter at the end of its range:
a cleaner explanation than the search's, or none (docs/diagnosis_method.md,
"Joint calibration").
When none is taken, the single fits that helped are calibrated again each with a
partner (pair_order), under the same rules (the same section, "Pairs").
"""
from dataclasses import dataclass, field
import math
from typing import NamedTuple

from tca_ros.calibration.candidates import contradicted_by_measurement, parameters_at_bounds
from tca_ros.calibration.physical_priors import prior_spreads, undone_findings
from tca_ros.diagnosis.described import admitted_effects, description_cost
from tca_ros.diagnosis.joint_groups import joint_order, pair_order
from tca_ros.diagnosis.rivals import DECISIVE_DEVIANCE, unresolved_rivals
from tca_ros.diagnosis.search import MIN_GAIN_PERCENT
from tca_ros.diagnosis.thermometer import thermometer_refutes
from tca_ros.diagnosis.verdict import channel_stats, heldout_gain_over, needs_explaining, \
    pooled_heldout_rmse
from tca_ros.model.tca_params import to_flat_dict

#: what an admitted effect's size is (admitted_effects), as the notes say it
WITHIN_DESCRIPTION = ('within what the description states (the delivered power, the room, '
                      'the heat loss and, without a thermometer, T_z: uncertainty.*)')
JOINT_NFEV = 10  # least-squares iterations of each pass of a joint calibration


@dataclass
class JointFit:
    """One candidate (or a pair) calibrated jointly with the nominal parameters."""

    name: str  # the effect, or 'a + b' for a pair
    values: dict  # dotted name -> value: what differs from the calibrated nominal
    n_params: int  # the candidates' own parameters
    sims: list  # per record, the full dynamics (18) at the record's samples
    criterion: float  # penalised held-out gain over the calibrated nominal (-)
    explained: bool  # the verdict's test finds no structure left
    #: (name, value, bound) of its parameters at the end of their range
    pinned: list
    effects: tuple = ()  # the catalogue names, in the order found (default: (name,))
    calibration: object = None  # the joint Calibration (its priors and FitReport)
    #: (whole-record stats, criterion) when confirmed on the whole record (confirm_on_whole)
    confirmed: tuple = None
    #: its effects whose size the description admits as a nominal value (twin_shift)
    admitted: tuple = ()
    #: why it is named though it leaves structure (decisive_despite_structure), or None
    despite: str = None
    #: (name, value, what) of its values a measurement refutes
    #: (candidates.contradicted_by_measurement)
    refuted: list = field(default_factory=list)
    #: (name, z, effects) of the findings it leaves that its own effects move the
    #: other way (physical_priors.undone_findings)
    undone: list = field(default_factory=list)
    #: sum z^2 of the described values its effects move (described.description_cost)
    cost: float = 0.0

    def __post_init__(self):  # noqa: D105 -- a single effect names itself
        self.effects = tuple(self.effects) or (self.name,)

    @property
    def barred(self):
        """Return True when a value is at a bound, refuted or undone: taken nowhere (G83)."""
        return bool(self.pinned or self.refuted or self.undone)

    @property
    def weighed(self):
        """Return criterion - cost (-): the held-out gain less the described moves' (G84)."""
        return self.criterion - self.cost

    @property
    def claimed(self):
        """Return its effects less those the description admits: what taking it names."""
        return tuple(e for e in self.effects if e not in self.admitted)


def beats_nominal(problems, nominals, extendeds, added, nominal_rmse):
    """Return True when the extension passes the search's acceptance against the nominal.

    As each candidate is accepted (search._greedy): a positive penalised held-out
    gain under the verdict's noise model (verdict.heldout_gain_over) and a
    drift-free held-out RMS gain of at least MIN_GAIN_PERCENT
    (:func:`lowers_heldout_rms`), here on the record-rate simulations of both
    whole models. ``nominal_rmse``: the nominal's pooled held-out RMSE, drift
    removed ({channel: m or K}; Nominal.drift_free_rmse).
    """
    return (heldout_gain_over(problems, nominals, extendeds, added) > 0.0
            and lowers_heldout_rms(problems, extendeds, nominal_rmse))


def lowers_heldout_rms(problems, extendeds, nominal_rmse):
    """Return True when ``extendeds`` cut the drift-free held-out RMS by MIN_GAIN_PERCENT.

    Channels weighted by their noise sigma; ``nominal_rmse`` is the reference's
    pooled held-out RMSE with the verdict's drift removed ({channel: m or K};
    verdict.pooled_heldout_rmse with ``detrend``), and so is the extension's:
    a gain that only fits a sensor's drift is not a gain (decisions G46).
    """
    sigma, channels = problems[0].sigma, problems[0].channels
    after = pooled_heldout_rmse(problems, extendeds, channels, detrend=True)
    score = [math.sqrt(sum((rmse[c] / sigma[c]) ** 2 for c in channels))
             for rmse in (nominal_rmse, after)]
    return score[1] <= (1.0 - MIN_GAIN_PERCENT / 100.0) * score[0]


def changed_values(params, reference):
    """Return {dotted name: value} of the scalar entries where ``params`` differs."""
    new, old = to_flat_dict(params), to_flat_dict(reference)
    return {k: v for k, v in new.items()
            if isinstance(v, float) and k in old and v != old[k]}


def joint_calibrations(calibrate_with, problems, nominals, cal, candidates, groups,
                       gate=True, singles=(), witnessed=True):
    """Return the JointFits of the candidate ``groups`` (each a tuple: one effect or a pair).

    ``calibrate_with(fit, start_values, like)`` runs the training-part
    calibration (nominal.calibrate_training_part) and returns (Calibration or
    None, [params per record], note); ``cal`` is the calibrated nominal's
    Calibration, whose defect corrections each joint calibration reuses (one
    fit each), ``nominals`` its simulations. With ``gate``, a joint calibration
    that does not fit the training part MIN_GAIN_PERCENT better than the nominal
    one cannot pass on the held-out part and is not simulated at the record rate
    (a finding's effect may fit it only as well, with the nominal values back
    where the description has them: findings.py). ``singles``: the JointFits of
    single effects a pair must do better than (:func:`pays_beyond_its_members`);
    a pair that does not is dropped before its structure is tested. With
    ``witnessed``, a heat-balance effect the thermometer reads worse than the
    nominal model is refuted (thermometer.py); a finding's effect is not
    (findings.py): the nominal it is compared with has taken it up by moving the
    very values the effect returns, and fits the temperature with them.
    """
    fitted = list(cal.report.estimates)
    spreads = prior_spreads(cal.start)
    enough = (1.0 - MIN_GAIN_PERCENT / 100.0) ** 2 * training_misfit(cal.report, cal.report)
    out = []
    for group in groups:
        own = [s.name for cand in group for s in cand.spaces]
        starts = {s.name: cand.starts[len(cand.starts) // 2][i]
                  for cand in group for i, s in enumerate(cand.spaces)}
        try:
            joint, _, _ = calibrate_with(fitted + own, {**cal.report.values, **starts}, cal)
        except (ValueError, ArithmeticError):
            continue
        if joint is None or (gate and not training_misfit(joint.report, cal.report) <= enough):
            continue
        values = changed_values(joint.params, cal.params)
        try:
            sims = [p.simulate_full(values) for p in problems]
        except (ValueError, ArithmeticError):  # the full dynamics cannot run it
            continue
        names = tuple(c.name for c in group)
        criterion = heldout_gain_over(problems, nominals, sims, len(own))
        if not pays_beyond_its_members(names, criterion, singles):
            continue
        stats = channel_stats(problems, sims, [p.parameters(values) for p in problems])
        # a value at the end of its range, or one a measurement refutes (an ambient
        # offset the thermometer at rest does not read, a heat-balance effect the
        # thermometer reads worse), explains nothing (G61, G69, G86)
        pinned = parameters_at_bounds(list(names), values, candidates)
        refuted = [(n, v, what) for n, v, _, _, what in
                   contradicted_by_measurement(list(names), values, candidates)]
        if witnessed:
            refuted += thermometer_refutes(names, values, problems, nominals, sims, candidates)
        thermometer = 'temperature' in problems[0].channels
        admitted = admitted_effects(names, joint.params, cal.start, spreads, thermometer)
        # a value its own effect moves the other way, left beyond the description (G83)
        undone = undone_findings(joint, names)
        confirmed = None
        whole = getattr(calibrate_with, 'whole', None)
        if (needs_explaining(stats) and criterion > DECISIVE_DEVIANCE and whole is not None
                and not pinned):  # a barred fit is taken nowhere (an undone or a refuted
            # one is confirmed, so the report can say what it set aside)
            confirmed = confirm_on_whole(whole, problems, cal, fitted + own, joint)
        out.append(JointFit(
            name=' + '.join(names), values=values, n_params=len(own), sims=sims,
            criterion=criterion, explained=not needs_explaining(stats) or bool(confirmed),
            pinned=pinned, refuted=refuted, effects=names, calibration=joint,
            confirmed=(confirmed, criterion) if confirmed else None, admitted=admitted,
            undone=undone,
            cost=description_cost(names, joint.params, cal.start, spreads, thermometer)))
    return out


def confirm_on_whole(whole, problems, cal, fit, joint):
    """Return the whole-record stats of ``fit`` calibrated on the whole records, or None.

    A joint fit on the training part that predicts the held-out part decisively
    better than the nominal model (penalised gain > DECISIVE_DEVIANCE: with the
    held-out structure set aside, the gain is the only guard against an effect that
    fits nothing, e.g. a convection exponent of 0.014 at a gain of 0.6) may still
    leave input-correlated residual there: its parameters' estimation error,
    extrapolated (a power loss fitted on 70 % of a record left 1.1-1.2 x the
    structure floor where the plant's own parameters leave none).
    ``whole(fit, start_values, like)`` calibrates the same parameters on every
    sample (start: the training fit ``joint``); None when that fails or its
    residual on the whole record is still structured by the verdict's test, else
    {channel: ResidualStats} of it. The
    held-out gain is the evidence against overfitting; this is the adequacy test
    of the effect's model (docs/diagnosis_method.md, "Confirmed on the whole
    record").
    """
    try:
        again, _, _ = whole(fit, dict(joint.report.values), cal)
        if again is None:
            return None
        values = changed_values(again.params, cal.params)
        sims = [p.simulate_full(values) for p in problems]
    except (ValueError, ArithmeticError):
        return None
    stats = channel_stats(problems, sims, [p.parameters(values) for p in problems],
                          whole=True)
    return None if needs_explaining(stats) else stats


def training_misfit(report, reference):
    """Return the sum over records and channels of (training RMSE / scale)^2 (-).

    ``report``: an engine FitReport; the scales are ``reference``'s channel scales
    (a calibration's residual RMS per channel), so two fits compare on one scale.
    """
    scale = reference.channel_scale
    return sum((rmse[c] / scale[c]) ** 2 for rmse in report.record_rmse for c in rmse)


def best_joint(fits, problems, nominals, nominal_rmse):
    """Return (the JointFit that explains the data best or None, the others that also do).

    Taken only when it beats the calibrated nominal by the search's rule, leaves
    no structure, is not barred (no parameter at the end of its range, none a
    measurement refutes, no value its own effect moves the other way: G83) and claims an effect
    the description does not admit (JointFit.claimed: a pair of a dead time and an
    offset within the stated room names the dead time, decisions G66; a fit the
    description admits in full names nothing, :func:`described_lead`); among
    those, the largest penalised held-out gain less what its effects move the
    described values by (JointFit.weighed: a room 8.2 K off where it is stated to
    2.2 K, gain 84.3, loses to a softening at 81.9 that moves nothing described:
    decisions G84). The others that pass too are returned, best first, so the
    report can say the records do not tell them apart.
    """
    lowers = rms_rule(problems, nominal_rmse)
    ok = [f for f in fits if not f.barred and f.claimed and explains(f, lowers)]
    ok.sort(key=lambda f: f.weighed, reverse=True)
    return (ok[0], ok[1:]) if ok else (None, [])


def rms_rule(problems, nominal_rmse):
    """Return fit -> True when the fit's sims lower the held-out RMS of ``nominal_rmse``.

    :func:`lowers_heldout_rms` on ``problems``, the search's RMS rule as
    :func:`explains` takes it.
    """
    def lowers(fit):
        return lowers_heldout_rms(problems, fit.sims, nominal_rmse)
    return lowers


def explains(fit, lowers_rms):
    """Return True when a JointFit explains the records and beats the calibrated nominal.

    It leaves no structure (``explained``) and passes the search's acceptance:
    a positive penalised held-out gain (``criterion`` is heldout_gain_over of its
    sims: beats_nominal without computing it again) and ``lowers_rms(fit)``
    (:func:`lowers_heldout_rms` against the nominal). Whether it is barred, and what
    it claims, each caller asks.
    """
    return fit.explained and fit.criterion > 0.0 and lowers_rms(fit)


def joint_extension(calibrate_with, problems, nominals, cal, candidates, rounds, nominal_rmse,
                    extra=()):
    """Return the JointOutcome: the JointFit taken or None, its rivals and unresolved rivals.

    Singles first, then pairs: the search's first-round candidates (joint_order, with
    the ``extra`` effect names) are calibrated jointly one at a time; when none is
    taken, or the single taken leaves a finding (:func:`leaves_finding`), the pairs of
    pair_order, a pair replacing such a single only when it leaves none; best_joint
    decides each time, and unresolved_rivals lists the family members it set apart only
    by the structure test. When a fit the description admits explains the records
    decisively best (:func:`described_lead`), nothing is taken and the outcome holds it.
    A fit that leaves a value its own effect moves the other way (JointFit.undone, G83)
    is taken nowhere; the outcome lists those that pass every other rule, for the
    report, and so those that explain the records but for a value at the end of its
    range or refuted by a measurement (JointFit.pinned, JointFit.refuted). Arguments as
    joint_calibrations and best_joint; ``rounds`` are the search's SearchRounds.
    """
    fits = joint_calibrations(calibrate_with, problems, nominals, cal, candidates,
                              [(c,) for c in joint_order(rounds, candidates, extra=extra)])
    every, beside = list(fits), []
    joint, rivals = best_joint(fits, problems, nominals, nominal_rmse)
    if joint is None or leaves_finding(joint):
        # one effect helps but leaves structure, or explains the records only with a
        # value moved beyond the description: it and a partner
        pairs = joint_calibrations(calibrate_with, problems, nominals, cal, candidates,
                                   pair_order(rounds, candidates, fits, extra), singles=fits)
        beside = [p for p in pairs if not stands_alone(p, fits)]
        pairs = [p for p in pairs if stands_alone(p, fits)]
        pair, pair_rivals = best_joint(pairs, problems, nominals, nominal_rmse)
        if joint is None or (pair is not None and not leaves_finding(pair)):
            joint, rivals, fits = pair, pair_rivals, pairs
        every += pairs
    lowers = rms_rule(problems, nominal_rmse)
    # what best_joint would have taken but for a value its effects move the other way,
    # and what explains the records but for a value at the end of its range or refuted
    undone = sorted((f for f in every if f.undone and not (f.pinned or f.refuted)
                     and f.claimed and explains(f, lowers)),
                    key=lambda f: f.criterion, reverse=True)
    aside = sorted((f for f in every if (f.pinned or f.refuted) and not f.undone
                    and f.claimed and explains(f, lowers)),
                   key=lambda f: f.criterion, reverse=True)
    # pairs that explain the records but name a partner only beside the description's slack
    alone = gains_alone(every)
    beside = [(p, {e: alone[e] for e in p.effects if e in alone})
              for p in sorted(beside, key=lambda f: f.criterion, reverse=True)
              if p.claimed and not p.barred and explains(p, lowers)]
    described = described_lead(every, joint, lowers)
    if described is not None:
        return JointOutcome(None, [], [], described, undone, aside, beside)
    return JointOutcome(joint, rivals, unresolved_rivals(joint, fits, lowers), None, undone,
                        aside, beside)


class JointOutcome(NamedTuple):
    """What the joint stage found (joint_extension)."""

    joint: object  # the JointFit taken, or None
    rivals: list  # the others that explain the records too (best_joint)
    near: list  # those only the structure test set apart (rivals.unresolved_rivals)
    #: a fit the description admits that explains the records decisively best
    #: (:func:`described_lead`): then nothing is taken
    described: object = None
    #: the fits best_joint would have taken but for a value their effects move the
    #: other way (JointFit.undone, G83), best first
    undone: list = ()
    #: the fits that explain the records but for a value at the end of its physical
    #: range or refuted by a measurement (JointFit.pinned, .refuted), best first
    aside: list = ()
    #: (pair, {member: penalised held-out gain calibrated alone}) of the pairs that
    #: explain the records but whose partner beside an admitted member did not stand
    #: alone (:func:`stands_alone`), best first
    beside: list = ()


def described_lead(fits, taken, lowers_rms):
    """Return the admitted JointFit that explains the records decisively best, or None.

    ``fits``: every JointFit of the stage; ``taken``: best_joint's pick (or None);
    ``lowers_rms(fit)``: the search's RMS rule. A fit whose effects the description
    all admits (``admitted``: a power loss within the stated delivered power, an
    ambient offset within the stated room and T_z) passes every other rule of best_joint and
    beats ``taken``'s penalised held-out gain by more than DECISIVE_DEVIANCE: the
    muscle as described explains the records better than any effect, so none is
    named (a 7.1 K offset where T_z is stated to 20 K, gain 274, against a 1.1 mN
    friction at 17.3 on a two-load sensor nonlinearity: decisions G66).
    """
    ok = [f for f in fits if set(f.admitted) == set(f.effects) and not f.barred
          and explains(f, lowers_rms)]
    if not ok:
        return None
    best = max(ok, key=lambda f: f.criterion)
    if taken is not None and not best.criterion > taken.criterion + DECISIVE_DEVIANCE:
        return None
    return best


def stands_alone(pair, singles):
    """Return True unless a pair's claim rests on a partner beside an admitted member.

    ``pair``: a JointFit of two effects; ``singles``: the single JointFits. A pair
    with a member the description admits (``admitted``) names the other
    (JointFit.claimed) only when that one, calibrated alone, had a positive
    penalised held-out gain: the lead it was paired from. A partner chosen to
    complement a fit of the description's own slack has not shown it helps (a
    0.031 s sensor lag beside a -7.1 K offset within the stated room and T_z, on the
    two-load sensor nonlinearity 9059: decisions G66). Nor has one whose pair
    predicts the held-out part no more than DECISIVE_DEVIANCE better than the
    admitted member calibrated alone: the muscle as described, its slack used,
    which described_lead weighs against an effect by the same margin (a softening
    of 1.5 MPa/K beside a radiation within the stated heat loss, 53.6 against the
    radiation's 47.2: decisions G95).
    """
    if not pair.admitted:
        return True
    alone = gains_alone(singles)
    helped = {name for name, criterion in alone.items() if criterion > 0.0}
    described = [alone[name] for name in pair.admitted if name in alone]
    return (bool(set(pair.claimed) & helped)
            and pair.criterion > max(described, default=-math.inf) + DECISIVE_DEVIANCE)


def pays_beyond_its_members(effects, criterion, singles):
    """Return True when a group's penalised held-out gain exceeds each member's own.

    ``effects``: the group's effect names, ``criterion`` its penalised held-out
    gain; ``singles``: JointFits of single effects. A member not calibrated alone
    sets no bar. The criterion is D - k ln(n) (verdict.heldout_gain_over), so a
    pair above its member single has a partner whose held-out deviance gain pays
    its own parameters' penalty. A partner that only clears the structure test the single
    failed, while predicting the held-out part no better, names an effect the data
    do not ask for (a dead time of 0.87 s took nonlinear convection beside it at a
    lower gain, 1219 against 1255: decisions G64).
    """
    bar = [gain for name, gain in gains_alone(singles).items() if name in effects]
    return criterion > max(bar, default=-math.inf)


def gains_alone(fits):
    """Return {effect: its best penalised held-out gain} over the single-effect JointFits."""
    out = {}
    for f in fits:
        if len(f.effects) == 1:
            out[f.effects[0]] = max(f.criterion, out.get(f.effects[0], -math.inf))
    return out


def leaves_finding(fit):
    """Return True when a JointFit's calibration leaves a value beyond its stated spread.

    An explanation that needs a nominal value more than SHIFT_Z prior spreads from
    the description (calibration.findings) fits the records with a muscle that is
    not the one described: a partner may be what the shift stands for (G53).
    """
    return fit.calibration is not None and bool(fit.calibration.findings())
