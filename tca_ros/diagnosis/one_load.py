"""A softening modulus on one load: the rival the calibrated actuation gain hides (issue 25).

On one load the stroke is a static function of the fibre temperature (eqs. 2-4 at a
fixed force), and a modulus that softens with temperature (effects.extra_softening,
E(T) = E - s (T - T_ref)) bends that function as a lower actuation gain does: the
calibration takes it up by moving the gain, the heat capacity and the heat loss a
little each. With the description stated to a few per cent those moves may stay
within the stated spreads (no finding), and the nominal model may leave less than
the structure test's practical floor (verdict ``adequate``): the search's screen adds
a softening on top of the gain that took it up and cannot see it, and a softening of
several MPa/K stays unnamed (confusion benchmark 9111: 7.2 MPa/K, the gain moved -1.4
spreads, 43 um predictable against an 83 um floor).

So when the records hold one load, the calibrated nominal model is adequate and yet
the inputs predict its residual significantly (the F-test of the structure test,
below the floor only), modulus softening is calibrated jointly with the nominal
parameters (joint.joint_calibrations) and weighed as a family rival is (G35):

* named when the calibrated actuation gain moved down by more than GAIN_DOWN_Z prior
  spreads (what a softening does to it: the coil that softens as it heats stretches
  under its load and loses stroke; a sensor reading high on large strokes moves it up,
  and a muscle as described barely moves it), its penalised held-out gain over the
  calibrated nominal exceeds
  DECISIVE_DEVIANCE ("very strong" evidence), it lowers the calibration's objective
  (data + priors) beyond its penalty k ln n_eff, its held-out RMS is MIN_GAIN_PERCENT
  lower with the verdict's drift removed from both (the raw RMS rewards a calibration
  that took up a sensor drift: on 9111 the plant's own parameters leave 199 um, the
  calibrated nominal 63 um; without the drift 45 um, the softening 29 um), it leaves
  no structure, has no parameter at a bound and its own part of the prediction is
  above the practical floor (effect_size.below_floor);
* decisive by the held-out part (gain, objective, RMS, no structure, above the floor)
  while the records speak against it (a value of its fit at a bound, refuted or moved
  the other way beyond the description, G83, or the calibrated gain moved up by over
  GAIN_DOWN_Z spreads): the calibrated nominal model is beaten on the held-out part,
  and not by a softening, so the verdict is ``unexplained`` with nothing named
  (decisions G97): the records hold a stroke-temperature relation the model lacks. On
  confusion benchmark 9149 a displacement read through x + 8 x^2 moved the gain +1.0
  spreads, and a 7 MPa/K softening cut the held-out RMS from 34.5 to 19 um with the
  gain at +2.6 spreads; the record had been called ``adequate``. A gain that merely
  did not move leaves the softening the gain's rival, as below;
* said as the nominal model's rival otherwise, when its gain is positive.

Either way the experiment that separates the two is simulated with both
(calibration.experiments.separating_experiment): a step at another load, where a
softening's share of the stroke scales with the force and the gain's does not.
"""
from collections import namedtuple

from tca_ros.calibration.experiments import separating_experiment
from tca_ros.diagnosis.effect_size import below_floor
from tca_ros.diagnosis.findings import weigh_finding_effect
from tca_ros.diagnosis.joint import DECISIVE_DEVIANCE, joint_calibrations, lowers_heldout_rms
from tca_ros.diagnosis.joint_groups import calibratable
from tca_ros.diagnosis.noise import STRUCTURE_ALPHA
from tca_ros.diagnosis.rivals import ONE_LOAD_SOFTENING
from tca_ros.diagnosis.search import MIN_GAIN_PERCENT
from tca_ros.diagnosis.verdict import pooled_heldout_rmse

#: softening_on_one_load's outcome: ``taken`` the JointFit to name or None, ``notes``,
#: ``refuted`` the 'unexplained' verdict's sentence when the softening beats the calibrated
#: nominal model decisively while the records speak against one (G97), else None
OneLoadSoftening = namedtuple('OneLoadSoftening', 'taken notes refuted')
#: the effect a one-load record lets the calibrated nominal values absorb
RIVAL = ONE_LOAD_SOFTENING
#: prior spreads the calibrated actuation gain must have moved down (-) to name the
#: softening: a coil that softens as it heats stretches under its load, so less stroke
#: is left at temperature, which a lower gain takes up (decisions G58)
GAIN_DOWN_Z = 1.0


def actuation_gain_z(cal):
    """Return how far (prior spreads, -) the calibration moved the actuation gain, or None."""
    return next((r.z for r in cal.plausibility() if r.name == 'actuation_gain'), None)


def gain_took_up_softening(cal):
    """Return True when ``cal`` moved the actuation gain down by over GAIN_DOWN_Z spreads.

    What a softening on one load does to the calibrated gain (GAIN_DOWN_Z): the
    sign that the gain may hide one (decisions G55, G58).
    """
    moved = actuation_gain_z(cal)
    return moved is not None and moved < -GAIN_DOWN_Z


def predictable_below_floor(*stats):
    """Return True when the inputs predict some channel's residual significantly.

    ``stats``: {channel: ResidualStats} dicts (held-out part, whole record) whose
    structure tests (noise.StructureTest) found p < STRUCTURE_ALPHA, whatever the
    predictable part's size against the practical floor.
    """
    return any(st.structure is not None and st.structure.p_value < STRUCTURE_ALPHA
               for part in stats for st in part.values())


def softening_on_one_load(calibrate_with, problems, nominals, cal, candidates, stats):
    """Return the OneLoadSoftening (the JointFit to name or None, notes, refuted).

    Arguments as joint.joint_calibrations, and ``stats`` the calibrated nominal
    model's held-out {channel: ResidualStats}; call only for one-load records whose
    calibrated nominal model is adequate with a significant residual
    (:func:`predictable_below_floor`). Module docstring for the rule.
    """
    candidate = calibratable(candidates).get(RIVAL)
    if candidate is None or not candidate.starts:
        return OneLoadSoftening(None, [], None)
    fits = joint_calibrations(calibrate_with, problems, nominals, cal, candidates,
                              [(candidate,)], gate=False)
    if not fits or fits[0].criterion <= 0.0:
        return OneLoadSoftening(None, [], None)
    fit = fits[0]
    fall = weigh_finding_effect(fit, cal, problems, nominals).fall
    channels = problems[0].channels
    before = pooled_heldout_rmse(problems, nominals, channels, detrend=True)
    after = pooled_heldout_rmse(problems, fit.sims, channels, detrend=True)
    value = fit.values.get('effects.extra_softening', 0.0)
    gain = cal.report.values.get('actuation_gain')
    moved, down = actuation_gain_z(cal), gain_took_up_softening(cal)
    decisive = (fit.criterion > DECISIVE_DEVIANCE and fall > 0.0 and fit.explained
                and lowers_heldout_rms(problems, fit.sims, before)
                and not below_floor(problems, stats, [RIVAL], fit.values, fit.sims,
                                    nominals))
    named = decisive and down and not fit.barred
    # the records' evidence against a softening: its fit barred (a value at a bound,
    # refuted, or moved against its own effect, G83) or the gain moved up, not down
    against = fit.barred or (moved is not None and moved > GAIN_DOWN_Z)
    if gain is None or moved is None:
        absorbed = 'the calibrated nominal values may take up a softening on one load'
    elif down:
        absorbed = (f'the calibrated actuation gain ({gain:.4g}, {moved:+.1f} prior spreads) '
                    'takes up a softening on one load')
    else:
        absorbed = (f'the calibrated actuation gain ({gain:.4g}, {moved:+.1f} prior spreads) '
                    'did not move down as a softening would move it')
    evidence = (f'{RIVAL} ({value / 1e6:.3g} MPa/K), calibrated jointly with the nominal '
                f'parameters, predicts the held-out part better than the calibrated nominal '
                f'model (penalised held-out gain {fit.criterion:.1f}; objective fall '
                f'{fall:+.1f} beyond its penalty; held-out RMS with the drift removed '
                f'{_rms_text(before)} -> {_rms_text(after)}), which leaves less than the '
                f'practical floor; {absorbed}')
    if named:
        notes = [f'{evidence}: named, its gain over {DECISIVE_DEVIANCE:g} '
                 '(docs/diagnosis_method.md, "One load, and what a record cannot see")']
    elif decisive and against:
        notes = [f'{evidence}: decisive, but not named: the records speak against a '
                 'softening, and the verdict says why (decisions G97)']
    else:
        notes = [f'{evidence}: not decisive (a gain over {DECISIVE_DEVIANCE:g}, a held-out '
                 f'RMS {MIN_GAIN_PERCENT:g} % lower, no structure, no parameter at a bound '
                 'or value it moves the other way beyond the description (G83), its own '
                 'part above the practical floor '
                 f'and the calibrated gain moved down by over {GAIN_DOWN_Z:g} prior spread '
                 'are needed to name it); the records do not tell it from the calibrated gain']
    experiment = _experiment(cal, fit)
    if experiment is not None:
        notes.append(f'next experiment for {RIVAL} against the calibrated nominal model: '
                     f'{experiment.sentence()}')
    return OneLoadSoftening(fit if named else None, notes,
                            _refuted_sentence(fit, gain, moved, down)
                            if decisive and against else None)


def _refuted_sentence(fit, gain, moved, down):
    """Return the 'unexplained' verdict's sentence of a softening decisive but not named.

    ``gain``, ``moved``: the calibrated nominal actuation gain (-) and its shift (prior
    spreads); ``down``: whether that shift is a softening's (gain_took_up_softening).
    """
    why = []
    if not down:  # the context: the gain did not take up a softening
        why.append(f'the calibrated actuation gain ({gain:.4g}) moved {moved:+.1f} prior '
                   f'spreads, not down by over {GAIN_DOWN_Z:g} as a softening moves it'
                   if gain is not None and moved is not None
                   else 'the calibration moved no actuation gain down as a softening would')
    if fit.undone:
        why.append('with it the calibration leaves ' + ', '.join(
            f'{n} {z:+.1f} prior spreads' for n, z, _ in fit.undone)
            + ' from the description, a shift a softening makes the other way')
    if fit.pinned:
        why.append(', '.join(f'{n} = {v:.4g} sits at the end of its range'
                             for n, v, _ in fit.pinned))
    if fit.refuted:
        why.append(', '.join(f'{n} = {v:.4g} is refuted by {what}'
                             for n, v, what in fit.refuted))
    return (f'the calibrated nominal model leaves less than the practical floor, but '
            f'{RIVAL}, calibrated jointly with the nominal parameters, predicts the '
            f'held-out part decisively better (penalised held-out gain {fit.criterion:.1f}) '
            f'while {"; and ".join(why)}: the records hold a stroke-temperature relation '
            'the model lacks and no catalogue effect accounts for (a static distortion of '
            'the displacement reading, a lever, are outside the catalogue); records at a '
            'second load, diagnosed together, would tell a distortion of the reading from '
            "the muscle's own")


def _rms_text(rmse):
    """Return '12.3 um, 0.2 K' of a {channel: RMSE in m or K}."""
    return ', '.join(f'{v * 1e6:.3g} um' if c == 'displacement' else f'{v:.3g} K'
                     for c, v in rmse.items())


def _experiment(cal, fit):
    """Return the Experiment separating the nominal calibration from ``fit``'s, or None."""
    try:
        return separating_experiment(cal, [dict(cal.report.values),
                                           dict(fit.calibration.report.values)],
                                     ('calibrated nominal', RIVAL), 'rivals')
    except (ValueError, ArithmeticError, KeyError):
        return None
