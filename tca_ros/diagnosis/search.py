"""Choose among candidate extensions on held-out data: the greedy effect search.

Uses one FitProblem (fitting.py) per diagnosis (or a FitProblemSet over several records),
and screens, fits and scores each candidate on it with candidate_fit.py.

1. If nominal parameters are recalibrated, they are refitted first under the defect
   correction, so that no candidate is credited with what that refit alone gains.
2. Each round screens every remaining candidate at a few starting magnitudes, refines
   the best few (and the best of each measured channel) by bounded least squares, the
   effects already found refitted jointly with each, and scores them on the held-out part.
3. A candidate is accepted when its held-out gain is significant under the verdict's
   noise model (an offset and a drift per record, AR(p) noise; verdict.noise_model_gain)
   and its held-out RMS, drift removed (verdict.drift_free_heldout_score), falls by at
   least MIN_GAIN_PERCENT; the search repeats with the added effects as the new
   base until the held-out residual is within WHITE_SCORE of the sensor noise or the
   verdict's test finds no structure left in it.
4. When the greedy path ends with structured residuals it restarts once from the first
   round's runner-up (a beam of width two at the root); the lower held-out BIC wins.
5. Effects made redundant by later ones are removed (backward elimination).
"""
import dataclasses
from dataclasses import dataclass
import math

from tca_ros.diagnosis.candidate_fit import fit_candidate, score_fit, screen
from tca_ros.diagnosis.verdict import channel_stats, drift_free_heldout_score, \
    gain as heldout_gain, needs_explaining, noise_model_gain

REFINE_TOP = 3  # candidates refined by least squares after screening
POLISH_NFEV = 10  # iterations of the joint refit after an effect is added
PRUNE_NFEV = 4  # iterations of the brief refit when an effect is tentatively removed
MIN_GAIN_PERCENT = 1.0  # held-out RMS gain below this is not worth a parameter
MAX_EFFECTS = 3  # greedy additions
WHITE_SCORE = 1.05  # held-out RMS (noise sigmas) at which the search stops
#: effects that delay the response as a calibrated damping b_t does (b_t / k is a lag
#: of seconds); each is also screened with the damping handed over to it
LAG_EFFECTS = ('second_thermal_lag', 'sensor_lag', 'dead_time')
EXCHANGE_FACTOR = 0.1  # the damping a lag effect is also screened with, x the base's


@dataclass
class SearchRound:
    """One greedy round: the scores of every remaining candidate, best first."""

    base_effects: list
    base_score: float
    base_rmse: dict
    scores: list
    accepted: str = ''
    restarted: bool = False  # the search restarted from this round's runner-up


def search_effects(problem, candidates, max_effects=MAX_EFFECTS, refine_top=REFINE_TOP,
                   min_gain_percent=MIN_GAIN_PERCENT):
    """Add candidates greedily while the held-out gain is significant.

    Greedy forward selection can be led astray when one effect alone mimics two
    (creep plus power loss look like extra softening). So when the greedy path
    ends with structured residuals, it is restarted once from the runner-up of
    the first round (a beam of width two at the root), and the path with the
    lower held-out BIC wins.

    Returns (effects found in order, values of the extended model, list of
    SearchRound). ``problem`` must have its nominal base set; on return its base
    is the extended model.
    """
    if problem.recalibration:
        # the recalibrated nominal parameters are refitted under the defect correction
        # first, so no candidate is credited with what that refit alone gains
        polish_effects(problem, [], {})
    nominal = dict(problem.base_values)
    found, values, rounds = _greedy(problem, candidates, max_effects, refine_top,
                                    min_gain_percent)
    first = rounds[0].scores if rounds else []
    runner_up = next((s for s in first[1:2] if s.refined and s.significant), None)
    if found and runner_up is not None and _structure_left(problem, values):
        best_bic = _heldout_bic(problem, values, found, candidates)
        problem.set_base(nominal)
        alt_found, alt_values, alt_rounds = _greedy(problem, candidates, max_effects,
                                                    refine_top, min_gain_percent,
                                                    first=runner_up)
        if alt_found and _heldout_bic(problem, alt_values, alt_found, candidates) < best_bic:
            alt_rounds[0] = dataclasses.replace(rounds[0], accepted=runner_up.name,
                                                restarted=True)
            found, values, rounds = alt_found, alt_values, alt_rounds
        else:
            problem.set_base(values)
    found, values = prune_effects(problem, found, values, candidates)
    return found, values, rounds


def prune_effects(problem, found, values, candidates):
    """Drop effects made redundant by later additions (backward elimination).

    An effect accepted early, while the residuals were structured, can become
    redundant once a later effect explains the same signature. Each found effect
    is removed in turn and the rest refitted briefly under the current defect
    correction; the removal that lowers the held-out BIC (n ln(S/n) + k ln n) most
    is made (and polished), and the step repeats. Returns (effects, values); the
    problem's base is left at the returned model.
    """
    from tca_ros.calibration.candidates import Candidate
    spaces_of = {c.name: c.spaces for c in candidates}
    best_bic = _heldout_bic(problem, values, found, candidates)
    while len(found) > 1:
        trials = []
        for name in found:
            rest = [n for n in found if n != name]
            dropped = {s.name for s in spaces_of[name]}
            reduced = {k: v for k, v in values.items() if k not in dropped}
            spaces = tuple(s for n in rest for s in spaces_of[n])
            problem.base_values = reduced
            fit = fit_candidate(problem, Candidate('+'.join(rest), spaces, ()),
                                [reduced[s.name] for s in spaces], max_nfev=PRUNE_NFEV)
            reduced.update(fit.params)
            trials.append((_heldout_bic(problem, reduced, rest, candidates), rest, reduced))
        bic, rest, reduced = min(trials, key=lambda t: t[0])
        if bic > best_bic or not rebase(problem, reduced):
            break
        reduced = polish_effects(problem, rest, spaces_of)
        best_bic, found, values = _heldout_bic(problem, reduced, rest, candidates), rest, reduced
    problem.set_base(values)
    return found, values


def rebase(problem, values):
    """Make ``values`` the problem's base; return False when that cannot be simulated.

    A candidate is fitted and scored on the fit grid (the quasi-static reduction
    where it applies); the full dynamics (18) at the record rate may still fail
    for it, e.g. a rod model driven past the table's 260 degC melt. Then the base
    is restored and the caller treats the candidate as not simulable.
    """
    previous = dict(problem.base_values)
    try:
        problem.set_base(values)
        return True
    except (ValueError, ArithmeticError):  # StabilityError, RodTableError are ValueErrors
        problem.set_base(previous)
        return False


def _lag_exchange(problem, values):
    """Return (base starts, lag start) that hand the damping's lag to a lag effect.

    Calibrate-first fits the damping on the training part, and a lag that is not
    viscous (a second thermal time constant, a dead time, a sensor lag) is taken
    up as damping b_t, b_t / k being a lag of seconds (docs/diagnosis_method.md,
    "Candidates"). Screened on that base, a lag effect only adds to a lag already there and
    its fit stays in that basin. So lag effects are also screened with the damping
    at EXCHANGE_FACTOR of the base's (the base start) and with the lag that takes
    away, (1 - EXCHANGE_FACTOR) b_t / k in s, as a further start of the effect.
    Returns (base starts, lag in s), or ((), None) when the damping is not
    refitted or the coil has no stiffness.
    """
    from tca_ros.calibration.calibration import coil_stiffness
    space = next((s for s in problem.recalibration if s.name == 'dynamics.damping'), None)
    if space is None:
        return (), None
    damping = values[space.name]
    stiffness = coil_stiffness(problem.parameters(values), problem.model)
    if not stiffness > 0.0:
        return (), None
    lowered = max(space.low, EXCHANGE_FACTOR * damping)
    return ({space.name: lowered},), (damping - lowered) / stiffness


def _with_start(candidate, value):
    """Return the one-parameter ``candidate`` with ``value`` (clipped to its range) as a start."""
    space, = candidate.spaces
    return dataclasses.replace(candidate, starts=candidate.starts + (
        (min(max(value, space.low), space.high),),))


def _structure_left(problem, values, score=None):
    """Return True when the model of ``values`` leaves held-out structure.

    False when its held-out RMS is within WHITE_SCORE of the sensor noise, or when
    the verdict's own test (verdict.channel_stats: the inputs predict nothing
    beyond the noise model) finds no channel structured at the record rate: then
    a further effect could only fit coloured noise, drift or the power log's
    errors, and the verdict would call the model explained as it stands
    (docs/diagnosis_method.md, "Acceptance and the search"). ``score``: the
    held-out RMS (noise sigmas) when the caller has it.
    """
    if score is None:
        cost, _, n, _ = problem.heldout(values)
        score = math.sqrt(cost / n)
    if score <= WHITE_SCORE:
        return False
    problems = getattr(problem, 'problems', [problem])
    sims = [p.simulate_full(values) for p in problems]
    stats = channel_stats(problems, sims, [p.parameters(values) for p in problems])
    return bool(needs_explaining(stats))


def _heldout_bic(problem, values, found, candidates):
    """Return n ln(S / n) + k ln(n) of the held-out residuals of ``values`` (-)."""
    cost, _, n, _ = problem.heldout(values)
    k = sum(c.n_params for c in candidates if c.name in found)
    return n * math.log(cost / n) + k * math.log(n)


def _greedy(problem, candidates, max_effects, refine_top, min_gain_percent, first=None):
    """Run forward selection from the problem's base; ``first`` forces round one."""
    found, rounds = [], []
    remaining = [c for c in candidates if c.starts]
    spaces_of = {c.name: c.spaces for c in candidates}
    values = dict(problem.base_values)
    if first is not None:
        if not rebase(problem, first.values):
            return [], values, [None]  # the forced start cannot be simulated: no path
        rounds.append(None)  # the caller fills in the first round it forced
        found.append(first.name)
        values = polish_effects(problem, found, spaces_of)
        remaining = [c for c in remaining if c.name != first.name]
    while remaining and len(found) < max_effects:
        base_cost, base_rmse, n, _ = problem.heldout(values)
        base_score = math.sqrt(base_cost / n)
        if found and not _structure_left(problem, values, base_score):
            break  # the residual is noise: nothing left for a further effect to explain
        base_residuals = problem.heldout_residuals(values)
        base_drift_free = drift_free_heldout_score(problem, base_residuals)
        lags = [c for c in remaining if c.name in LAG_EFFECTS]
        exchange, lag = _lag_exchange(problem, values) if lags else ((), None)
        screened = [(screen(problem, _with_start(c, lag), exchange)
                     if c in lags and exchange else screen(problem, c), c) for c in remaining]
        screened.sort(key=lambda item: item[0][0][0])
        scores = []
        # forward selection with refit: the effects already found are refitted jointly
        # with each refined candidate, so an earlier effect that absorbed part of this
        # one's signature can give it back
        free = tuple(s for name in found for s in spaces_of[name]) + problem.recalibration

        def evaluate(trials, cand, refine):
            fit = fit_candidate(problem, cand, trials[0][1], refine=refine,
                                free=free if refine else (), base_start=trials[0][3])
            score = score_fit(problem, fit, refine)
            residuals = problem.heldout_residuals(score.values)
            score.criterion = noise_model_gain(problem, base_residuals, score.values,
                                               cand.n_params, residuals)
            # the 1 % rule on the drift-free RMS: a fitted drift is not a gain (G46)
            gain = heldout_gain(base_drift_free, drift_free_heldout_score(problem, residuals))
            score.significant = bool(fit.success and score.criterion > 0.0
                                     and gain >= min_gain_percent)
            return score

        by_name = {cand.name: (trials, cand) for trials, cand in screened}
        # refine the best few by total cost, and the best screen of each channel: an
        # effect that alone explains the temperature points at a thermal cause even
        # when displacement errors dominate the total
        refine = {cand.name for _, cand in screened[:refine_top]}
        for i in range(len(problem.channels)):
            refine.add(min(screened, key=lambda item: min(t[2][i] for t in item[0]))[1].name)
        scores = [evaluate(trials, cand, cand.name in refine) for trials, cand in screened]
        scores.sort(key=lambda s: s.heldout_cost)
        while not scores[0].refined:
            # a screened start beat the refined fits on held-out data: refine it too
            scores[0] = evaluate(*by_name[scores[0].name], True)
            scores.sort(key=lambda s: s.heldout_cost)
        rnd = SearchRound(base_effects=list(found), base_score=base_score,
                          base_rmse=base_rmse, scores=scores)
        rounds.append(rnd)
        best = scores[0]
        if not (best.refined and best.significant):
            break
        if not rebase(problem, best.values):  # the full dynamics cannot run it
            best.significant = False
            remaining = [c for c in remaining if c.name != best.name]
            continue
        rnd.accepted = best.name
        found.append(best.name)
        values = polish_effects(problem, found, spaces_of)
        remaining = [c for c in remaining if c.name != best.name]
    return found, values, rounds


def polish_effects(problem, found, spaces_of, max_nfev=POLISH_NFEV):
    """Refit the found effects jointly under the current base's defect correction.

    The correction was computed for the model the candidate was fitted against;
    refitting now makes the base as good as it can be before the next round, so
    a further candidate is not credited with the refit's gain. Returns the values
    of the (re-based) model.
    """
    from tca_ros.calibration.candidates import Candidate
    values = dict(problem.base_values)
    spaces = tuple(s for name in found for s in spaces_of[name]) + problem.recalibration
    joint = Candidate('+'.join(found), spaces, ())
    fit = fit_candidate(problem, joint, [values[s.name] for s in spaces], refine=True,
                        max_nfev=max_nfev)
    polished = dict(values)
    polished.update(fit.params)
    before = problem.train_residuals(values)
    after = problem.train_residuals(polished)
    if fit.success and after @ after < before @ before and rebase(problem, polished):
        return polished
    return values
