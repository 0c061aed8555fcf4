"""What the calibration absorbed, tested as the effect it may stand for (issue 25).

The description's stated uncertainties are the calibration's priors
(calibration/physical_priors.py). A calibrated value more than SHIFT_Z prior
spreads from the description is a **finding** (Calibration.findings): the
calibration moved a value the maker stated to take up the record's signature,
and the finding names the catalogue effects it can stand for
(physical_priors.stands_for). When the calibrated nominal model then leaves
nothing structured (verdict adequate), the findings are the only evidence of an
effect, and held-out data alone cannot tell a power loss from a steady rise
moved to match it: the two predict the same. So each effect a finding names is
calibrated jointly with the nominal parameters (joint.joint_calibrations: the
description's priors on the nominal values, a nearly flat one on the effect's),
and it **explains the finding** when

1. every value found shifted returns within SHIFT_Z prior spreads, not only those
   whose findings name it (a value it cannot move that way, left shifted, is not
   explained by it), none jointly beyond JOINT_Z either
   (physical_priors.jointly_shifted), and all within their physical limits (a value
   past them counts as a finding here);
2. the calibration's objective, data (on the nominal calibration's channel scales
   and effective sample count) plus priors, falls by more than k ln n_eff
   (k the effect's parameters, n_eff the calibration's effective samples: BIC);
3. it predicts the held-out part no worse than the shifted nominal model beyond
   one such penalty, D >= -k ln n (verdict.heldout_deviance, D the held-out
   deviance gain under the verdict's noise model over n samples), unless its
   findings are all the room the thermometer reads at rest: that measurement is
   the evidence, and the nominal model, whose heat loss takes up the room, may
   predict the held-out part better (decisions G92);
4. it leaves no structure by the verdict's test and no parameter at the end of
   its range.

The effect with the largest fall of the objective is named; the others that pass
are said as rivals.

When none passes, one may still be **found with structure left**
(:func:`found_despite_structure`): conditions 3 and 4 judge the effect against
the shifted nominal model, which the description rules out. An effect that (1)
returns the values, (2) lowers the objective by more than DECISIVE_DEVIANCE beyond
its penalty and by more than DECISIVE_DEVIANCE beyond every other effect the
findings name, has no parameter at a bound, and (3') predicts the held-out part
better than the nominal model the description admits (calibrated with the values
whose findings name it held at the description; penalty (k + m) ln n, m those
values) is named; the verdict then says that structure remains beside it.

A finding none of its effects explains leaves the record unexplained: the nominal
model fits it only with values the description rules out (docs/diagnosis_method.md,
"Findings").
"""
from dataclasses import dataclass
import math

from tca_ros.calibration.calibration import ROOM
from tca_ros.calibration.candidates import STATED_OFFSETS
from tca_ros.calibration.physical_priors import JOINT_Z, NO_EFFECT_MOVES_IT, SHIFT_Z
from tca_ros.diagnosis.joint import changed_values, DECISIVE_DEVIANCE, joint_calibrations, \
    lowers_heldout_rms, WITHIN_DESCRIPTION
from tca_ros.diagnosis.joint_groups import calibratable
from tca_ros.diagnosis.rivals import rival_experiment_notes
from tca_ros.diagnosis.verdict import heldout_deviance, pooled_heldout_rmse

HEAT_LOSS = 'heat_loss'  # the calibration's name of the conductance h A_0 (W/K)
ROOM_EFFECT = next(iter(STATED_OFFSETS))  # the ambient offset: the room moved (K)


@dataclass
class FindingTest:
    """One effect a finding names, calibrated jointly: how far it explains the finding."""

    fit: object  # joint.JointFit
    fall: float  # fall of the calibration objective, penalty k ln n_eff subtracted (-)
    deviance: float  # held-out deviance gain D over the calibrated nominal (-)
    returned: bool  # every value found shifted is back within SHIFT_Z spreads
    passes: bool  # all four conditions of the module docstring
    names: tuple = ()  # the calibration names whose findings name this effect
    #: penalised held-out gain over the nominal model the description admits, when
    #: found with structure left (found_despite_structure), else None
    over_described: float = None
    holds: bool = False  # condition 3: held-out deviance D >= -k ln n
    paid: bool = False  # condition 2 (a measured finding's: the data cost no more)
    n_heldout: int = 0  # the held-out samples n of D

    @property
    def name(self):
        """Return the effect's name."""
        return self.fit.name

    @property
    def measured(self):
        """Return True when its findings are all on measured values (the room, G73)."""
        return on_measurement(self.names)


def on_measurement(names):
    """Return True when the finding ``names`` are all measured, not calibrated (ROOM)."""
    return bool(names) and all(n == ROOM for n in names)


def finding_effects(cal, room_from_heat_loss=True):
    """Return the catalogue effects the findings of Calibration ``cal`` name, largest |z| first.

    The findings and the values past their physical limits (an implausible value
    stands in for physics the model lacks: a stiffness of 0.3 x the preset's for a
    modulus that softens). Empty without a calibration or without either.
    ``room_from_heat_loss`` False leaves out an ambient offset that only a heat-loss
    finding names (:func:`own_readings`).
    """
    if cal is None:
        return []
    out = []
    for name, _, effects in sorted(cal.findings(implausible=True), key=lambda f: -abs(f[1])):
        out += [e for e in effects if e not in out and (
            room_from_heat_loss or not (name == HEAT_LOSS and e == ROOM_EFFECT))]
    return out


def own_readings(cal):
    """Return finding_effects(cal) less a room read only from a heat-loss shift (G90).

    A room other than described moves the calibrated heat loss through the convex
    stroke-temperature relation, a second reading of that shift beside the heat-loss
    shapes and the power loss that move the heat balance itself. An ambient offset
    the search names is then no reading that makes those effects' joint fits
    needless: they stay its rivals (:func:`findings_rival`), as before G90.
    """
    return finding_effects(cal, room_from_heat_loss=False)


def _returned(joint, names):
    """Return True when calibrated ``names`` are no finding any more, and plausible.

    ``joint``: the Calibration of an effect and the nominal parameters together.
    Each value is within SHIFT_Z spreads and none left the description together
    with others (physical_priors.jointly_shifted, decisions G80). The room the
    thermometer reads at rest returns when the joint calibration's room (an
    ambient offset fitted) is within SHIFT_Z of it (Calibration.room_reading).
    """
    rows = {r.name: r for r in joint.plausibility()}
    if ROOM in names and ROOM in [n for n, _, _ in joint.findings()]:
        return False
    return all(not rows[n].shifted and not rows[n].implausible for n in names if n in rows)


def weigh_finding_effect(fit, cal, problems, nominals):
    """Return the FindingTest of a JointFit ``fit`` (one effect) against the nominal ``cal``.

    ``problems`` and ``nominals``: the diagnosis's FitProblems and the calibrated
    nominal model's record-rate simulations.
    """
    joint = fit.calibration
    found = cal.findings(implausible=True)
    names = [n for n, _, effects in found if set(fit.effects) & set(effects)]
    # every finding must return, not only those naming the effect: a value the effect
    # cannot move that way, left beyond the description, is not explained by it (G82)
    returned = _returned(joint, [n for n, _, _ in found])
    ref = cal.report
    penalty = fit.n_params * math.log(max(ref.n_effective, math.e))
    fall = (ref.data_cost() + ref.prior_cost
            - joint.report.data_cost(ref) - joint.report.prior_cost - penalty)
    deviance, n = heldout_deviance(problems, nominals, fit.sims)
    holds = deviance >= -fit.n_params * math.log(max(n, 2))
    # a measured value is its own evidence: the fit need only cost the data nothing and,
    # leaving no structure, need not out-predict a nominal model whose heat loss took
    # up the room the thermometer reads (decisions G92)
    paid = fall + penalty >= 0.0 if on_measurement(names) else fall > 0.0
    passes = bool(names and returned and paid and fit.explained and not fit.barred
                  and (holds or on_measurement(names)))
    return FindingTest(fit=fit, fall=float(fall), deviance=float(deviance),
                       returned=returned, passes=passes, names=tuple(names), holds=holds,
                       paid=paid, n_heldout=n)


def finding_tests(calibrate_with, problems, nominals, cal, candidates, leave_out=()):
    """Return the FindingTests of the effects ``cal``'s findings name, each calibrated jointly.

    Only effects a calibration can fit (not coil contact) and not in ``leave_out``;
    None when there is none ([] when each such calibration failed). Arguments as
    :func:`explain_findings`.
    """
    by_name = {n: c for n, c in calibratable(candidates).items() if c.starts}
    groups = [(by_name[n],) for n in finding_effects(cal) if n in by_name
              and n not in leave_out]
    if not groups:
        return None
    fits = joint_calibrations(calibrate_with, problems, nominals, cal, candidates, groups,
                              gate=False, witnessed=False)
    return [weigh_finding_effect(f, cal, problems, nominals) for f in fits]


def explain_findings(calibrate_with, problems, nominals, cal, candidates):
    """Return (the FindingTest named or None, notes) of the effects ``cal``'s findings name.

    ``calibrate_with``, ``problems``, ``nominals``, ``candidates``: as
    joint.joint_calibrations. Each named effect a calibration can fit (not coil
    contact) is calibrated jointly with the nominal parameters and tested
    (weigh_finding_effect); the passing one with the largest fall is returned.
    """
    tests = finding_tests(calibrate_with, problems, nominals, cal, candidates)
    if tests is None:
        return None, []
    tests.sort(key=lambda t: -t.fall)
    passing = [t for t in tests if t.passes]
    shifted = ', '.join(f'{n} ({z:+.1f} spreads)'
                        for n, z, _ in cal.findings(implausible=True))
    if not passing:
        tried = ', '.join(f'{t.name} (objective fall {t.fall:+.1f}, held-out deviance '
                          f'{t.deviance:+.1f}{"" if t.returned else ", values not returned"})'
                          for t in tests) or 'none could be calibrated'
        found = (found_despite_structure(calibrate_with, problems, cal, tests)
                 or found_on_measurement(tests))
        if found is None:
            return None, [f'findings {shifted}: the effects they can stand for, calibrated '
                          f'jointly, do not explain them: {tried}']
        return found, [f'findings {shifted}: no effect they can stand for passes every '
                       f'condition ({tried}); {found.name} is found with structure left '
                       f'(docs/diagnosis_method.md, "Findings"): {found_text(found)}']
    best = passing[0]
    # an effect sized within what the description states explains the findings as the
    # muscle described (a room at the edge of its stated spread): kept, not named
    taken = (f'its size {WITHIN_DESCRIPTION}, the muscle as described: not named'
             if best.fit.admitted else 'named')
    predicts = (f'predicts the held-out part as well (deviance {best.deviance:+.1f})'
                if best.holds else
                'leaves no structure; the calibrated nominal model predicts the held-out '
                f'part better (deviance {best.deviance:+.1f}), and the room the '
                'thermometer read at rest is the evidence (G92)')
    notes = [f'findings {shifted}: {best.name}, calibrated jointly with the nominal '
             f'parameters, brings them back within {SHIFT_Z:g} prior spreads, lowers the '
             f"calibration's objective (data + priors) by {best.fall:.1f} beyond its "
             f'penalty and {predicts}: {taken} (docs/diagnosis_method.md, "Findings")']
    if len(passing) > 1:
        notes.append('also explaining the findings: ' + ', '.join(
            f'{t.name} (objective fall {t.fall:.1f})' for t in passing[1:])
            + '; these records tell them apart only by that fall')
        # those within DECISIVE_DEVIANCE of its fall: the experiment that separates them
        close = [t.fit for t in passing[1:] if t.fall >= best.fall - DECISIVE_DEVIANCE]
        notes += rival_experiment_notes(best.fit, close, equal=lambda fit: True)
    return best, notes


def found_despite_structure(calibrate_with, problems, cal, tests):
    """Return the FindingTest found with structure left (module docstring), or None.

    ``tests``: every FindingTest of the findings' effects, none passing. The lead
    must return its values, not sit at a bound, lower the objective by more than
    DECISIVE_DEVIANCE beyond its penalty and by more than DECISIVE_DEVIANCE beyond
    every other effect tested that explains the findings as the description asks
    (returns the values: a friction whose stick-slip fits the training part and
    leaves the values beyond the description does not, decisions G94), and predict
    the held-out part better than the nominal model the description admits
    (:func:`described_nominal`) by the search's rule with the penalty (k + m) ln n (m
    the values held). Its ``over_described`` is set to that penalised gain.
    """
    ok = sorted((t for t in tests if t.returned and t.names and not t.fit.barred),
                key=lambda t: -t.fall)
    if not ok or not ok[0].fall > DECISIVE_DEVIANCE:
        return None
    best = ok[0]
    rest = [t.fall for t in tests if t is not best and t.returned]
    if rest and not best.fall - max(rest) > DECISIVE_DEVIANCE:
        return None
    sims = described_nominal(calibrate_with, problems, cal, best.names)
    if sims is None:
        return None
    deviance, n = heldout_deviance(problems, sims, best.fit.sims)
    gain = deviance - (best.fit.n_params + len(best.names)) * math.log(max(n, 2))
    reference = pooled_heldout_rmse(problems, sims, problems[0].channels, detrend=True)
    if not (gain > 0.0 and lowers_heldout_rms(problems, best.fit.sims, reference)):
        return None
    best.over_described = float(gain)
    return best


def found_on_measurement(tests):
    """Return the FindingTest of a measured finding's effect, found with structure left.

    The room the thermometer reads at rest is a measurement, not a value the
    calibration moved (Calibration.room_reading): an ambient offset that brings
    the model's room back to it (returned, not refuted by the reading), costs
    the data nothing and predicts the held-out part no worse than the nominal
    model beyond its penalty (``holds``) is named, with the structure left
    beside it (decisions G73). The nominal model the description admits is the
    calibrated one (no calibrated value is held), so ``over_described`` is the
    held-out deviance less k ln n. None when no such test.
    """
    ok = [t for t in tests if t.measured and t.returned and t.holds and t.paid
          and not t.fit.barred]
    if not ok:
        return None
    best = max(ok, key=lambda t: t.fall)
    best.over_described = float(best.deviance
                                - best.fit.n_params * math.log(max(best.n_heldout, 2)))
    return best


def described_nominal(calibrate_with, problems, cal, held):
    """Return the record-rate sims of the nominal model the description admits, or None.

    The nominal parameters calibrated on the training part as ``cal`` was, with
    the calibration names ``held`` kept at the description's values (their prior
    centres): the best nominal model that leaves no finding on them.
    ``calibrate_with`` as joint.joint_calibrations.
    """
    fit = [n for n in cal.report.estimates if n not in held]
    start = {n: v for n, v in cal.report.values.items() if n not in held}
    try:
        admitted, _, _ = calibrate_with(fit, start, cal)
        if admitted is None:
            return None
        values = changed_values(admitted.params, cal.params)
        return [p.simulate_full(values) for p in problems]
    except (ValueError, ArithmeticError):  # the calibration or the full dynamics failed
        return None


def found_text(test):
    """Return the clause giving a FindingTest's evidence when found with structure left."""
    if test.measured:
        return ('the thermometer at rest reads a room the description does not state; '
                'calibrated jointly with the nominal parameters it brings the room of the '
                'model back to that reading and predicts the held-out part as well as the '
                f'nominal model within its penalty (held-out deviance {test.deviance:+.1f})')
    return (f'calibrated jointly with the nominal parameters it brings '
            f'{", ".join(test.names)} back within {SHIFT_Z:g} prior spreads, lowers the '
            f"calibration's objective (data + priors) by {test.fall:.1f} beyond its penalty, "
            f'more than any other effect they stand for that returns them (G94) by over '
            f'{DECISIVE_DEVIANCE:g}, and '
            f'predicts the held-out part better than the nominal model held at the '
            f'description (penalised held-out gain {test.over_described:.1f}) and '
            f'{"worse than" if test.deviance < 0.0 else "as well as"} the shifted nominal '
            f'model (held-out deviance {test.deviance:+.1f})')


def unexplained_findings(cal):
    """Return the verdict sentence of findings no catalogue effect explained (``cal``'s).

    A finding no catalogue effect can stand for (a value moved the way no effect moves
    it, physical_priors.stands_for) is said as such.
    """
    found = cal.findings()
    shifted = ', '.join(f'{n} {z:+.1f} prior spreads' for n, z, _ in found)
    none = [n for n, _, effects in found if not effects]
    why = ('none of the catalogue effects they can stand for explains the move'
           if len(none) < len(found) else 'no catalogue effect moves them that way')
    if none and len(none) < len(found):
        why += f' ({", ".join(none)}: {NO_EFFECT_MOVES_IT})'
    return ('the calibrated nominal model leaves no structure, but only with values moved '
            f'beyond the uncertainty the description states ({shifted}; a finding is '
            f'beyond {SHIFT_Z:g}, or beyond {JOINT_Z:g} with others as unlikely together), '
            f'and {why}: the muscle differs from its description there, or an effect '
            'outside the catalogue acts')


def findings_rival(calibrate_with, problems, nominals, cal, candidates, found, sims, added):
    """Return (a FindingTest that replaces the search's ``found`` effects or None, notes).

    The search explained the records with ``found`` (record-rate ``sims``, ``added``
    effect parameters), none of them an effect ``cal``'s findings stand for: its
    refit stays near the description (G31), so the explanation and the findings
    may be two readings of one signature. Each effect the findings name is
    calibrated jointly and weighed (:func:`weigh_finding_effect`); one that passes
    replaces ``found`` when its penalised held-out deviance gain over the calibrated
    nominal beats the search's by more than DECISIVE_DEVIANCE (decisions G57).
    Arguments as :func:`explain_findings`.
    """
    tests = [t for t in finding_tests(calibrate_with, problems, nominals, cal, candidates,
                                      leave_out=found) or () if t.passes]
    if not tests:
        return None, []
    deviance, n = heldout_deviance(problems, nominals, sims)
    log_n = math.log(max(n, 2))
    ours = deviance - added * log_n
    best = max(tests, key=lambda t: t.deviance - t.fit.n_params * log_n)
    theirs = best.deviance - best.fit.n_params * log_n
    shifted = ', '.join(f'{name} ({z:+.1f} spreads)'
                        for name, z, _ in cal.findings(implausible=True))
    said = (f'{" + ".join(found)} explains the records (penalised held-out gain {ours:.1f} '
            f'over the calibrated nominal), and the findings {shifted} are explained by '
            f'{best.name}, calibrated jointly (penalised held-out gain {theirs:.1f})')
    if theirs - ours > DECISIVE_DEVIANCE:
        return best, [f'{said}: {best.name} predicts the held-out part decisively better '
                      f'(by over {DECISIVE_DEVIANCE:g}) and replaces it (decisions G57)']
    return None, [f'{said}: not decisively better (by over {DECISIVE_DEVIANCE:g} needed); '
                  f'{" + ".join(found)} kept, {best.name} its rival']
