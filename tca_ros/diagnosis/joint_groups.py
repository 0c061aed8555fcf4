"""Which effects the joint stage calibrates with the nominal parameters: singles and pairs.

The search (search.py) ranks every candidate in its first round, screened on top of
the calibrated nominal values; the joint stage (joint.py) calibrates the best of
them again with all the nominal parameters free (:func:`joint_order`), and, when no
single one explains the records, pairs built from the singles that helped
(:func:`pair_order`). docs/diagnosis_method.md, "Joint calibration".
"""
from tca_ros.calibration.candidates import BOUND_SHARE
from tca_ros.diagnosis.rivals import FAMILIES

JOINT_TOP = 3  # candidates of the search's first round calibrated jointly, best first
PAIR_LEADS = 2  # single joint fits that help without explaining, each tried with partners
PAIR_PARTNERS = 2  # partners of each, from the search round that added it (or the first)
MAX_PAIRS = 4  # pairs calibrated jointly at most


def calibratable(candidates):
    """Return {name: candidate} of the catalogue effects a calibration can fit.

    Those whose parameters are all ``effects.*`` (not coil contact, whose stop is
    geometry).
    """
    return {c.name: c for c in candidates
            if all(s.name.startswith('effects.') for s in c.spaces)}


def joint_order(rounds, candidates, top=JOINT_TOP, extra=()):
    """Return the candidates to calibrate jointly: the first round's best ``top``.

    By the first round's held-out score (each candidate refitted with the
    narrow recalibration), best first; only catalogue effects whose parameters
    a calibration can fit (not coil contact, whose stop is geometry). When a
    member of one of the FAMILIES is among them, the rest of its family follows:
    which lag the data ask for shows only once the damping and the time constant
    that took it up are free again (seed 9039: the second lag ranked fifth behind
    dead time and sensor lag), and hysteresis and friction, or an ambient offset
    and nonlinear convection, each explained a record that held the other when it
    was not tried (own generator 1006, bench_diagnosis_real 9032). ``extra``: effect
    names tried too, after them (those a calibration finding stands for, findings.py:
    a value the calibration moved beyond the description took up their signature, and
    the first round, screened beside it, ranks them low).
    """
    first = next((r for r in rounds if r is not None), None)
    if first is None:
        return []
    fittable = calibratable(candidates)
    scored = [(s, fittable[s.name]) for s in first.scores if s.name in fittable]
    # those that had their chance in the first round go after the rest
    ranked = ([c for s, c in scored if not had_its_chance(s, c)]
              + [c for s, c in scored if had_its_chance(s, c)])
    order = ranked[:top]
    for family in FAMILIES:
        if any(c.name in family for c in order):
            order += [c for c in ranked[top:] if c.name in family and c not in order]
    order += [fittable[n] for n in extra
              if n in fittable and fittable[n].starts and fittable[n] not in order]
    return order


def had_its_chance(score, candidate):
    """Return True when a first-round candidate was tried and did not help.

    ``score``: ``candidate``'s CandidateScore. Refined, the nominal values were
    refitted beside it, so its held-out score is mostly the refit's own: a refined
    lag fitted to 0 s with no penalised held-out gain (criterion <= 0) stood, by
    that score, ahead of an ambient offset screened without the refit (seed 9130:
    two lags refitted to 0 s and a dead time screened at the 0 s the search's lag
    exchange found, the 7.2 K offset seventh; decisions G66). So did one screened
    at its size 0 (its first parameter, effects.CATALOGUE, within BOUND_SHARE of
    its range, as candidates.parameters_at_bounds reads a bound): that is the base.
    A candidate screened at a size, not refined, has not had that chance and keeps
    its place.
    """
    space = candidate.spaces[0]
    size = abs(score.fit.params.get(space.name, 0.0))
    return (bool(score.refined and score.criterion <= 0.0)
            or size <= BOUND_SHARE * (space.high - space.low))


def pair_order(rounds, candidates, fits, extra=()):
    """Return the pairs to calibrate jointly when no single joint fit explains the data.

    Two effects at once are what a single joint fit that helps but leaves
    structure may be missing. The leads are the PAIR_LEADS single fits with a
    positive penalised held-out gain (best first); a lead's partners are the
    best PAIR_PARTNERS calibratable candidates of the search round whose base was
    that lead alone (the greedy search ranked them given it), or of the first
    round when the search did not add it, leaving out the lead's own family (its
    rivals, not its complements) and coil contact. At most MAX_PAIRS, as tuples.
    A record where no single effect helps gets no pair: the nulls and the defects
    outside the catalogue keep `unexplained` with nothing named. ``extra``: effect
    names a calibration finding stands for (findings.py); each lead is also paired
    with them (outside its family), beyond MAX_PAIRS: a value the calibration moved
    beyond the description may be the second effect the lead is missing (G47).
    """
    by_name = calibratable(candidates)
    leads = sorted((f for f in fits if f.criterion > 0.0 and len(f.effects) == 1),
                   key=lambda f: f.criterion, reverse=True)[:PAIR_LEADS]
    rounds = [r for r in rounds if r is not None]
    pairs, found, seen = [], [], set()
    for lead in leads:
        name = lead.effects[0]
        after = next((r for r in rounds if list(r.base_effects) == [name]),
                     rounds[0] if rounds else None)
        if after is None or name not in by_name:
            continue
        rivals = next((set(f) for f in FAMILIES if name in f), {name})
        partners = [s.name for s in after.scores
                    if s.name in by_name and s.name not in rivals][:PAIR_PARTNERS]
        for other in partners:
            if frozenset((name, other)) not in seen:
                seen.add(frozenset((name, other)))
                pairs.append((by_name[name], by_name[other]))
        found += [(name, other) for other in extra
                  if other in by_name and by_name[other].starts and other not in rivals]
    pairs = pairs[:MAX_PAIRS]
    kept = {frozenset(c.name for c in pair) for pair in pairs}
    for a, b in found:  # each pair once, in whichever order it came first
        if frozenset((a, b)) not in kept:
            kept.add(frozenset((a, b)))
            pairs.append((by_name[a], by_name[b]))
    return pairs
