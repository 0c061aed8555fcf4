"""The verdict's sentence: what decided each channel, in the numbers that decided it.

A channel's residual is structured (noise.StructureTest.structured) when

- the inputs predict part of it: the F-test of the input-driven terms has
  p < STRUCTURE_ALPHA **and** the predictable part's RMS exceeds the floor
  (the larger of STRUCTURE_NOISE_SHARE x the noise and STRUCTURE_FLOOR x the
  measured swing), or
- what neither the inputs nor an offset and a drift describe (the wander)
  exceeds MAX_NOISE_SHARE of the swing;

without that test, when its RMS exceeds STRUCTURE_RATIO white-noise sigmas.
Each channel's clause names the criterion that decided it with its statistic
and threshold, so the sentence cannot say "structured" beside a p-value that
says otherwise.
"""
from tca_ros.calibration.residuals import STRUCTURE_RATIO
from tca_ros.diagnosis.noise import MAX_NOISE_SHARE, STRUCTURE_ALPHA, STRUCTURE_FLOOR, \
    STRUCTURE_NOISE_SHARE

MIN_TEST_SAMPLES = 12  # block means the structure test needs (noise.structure_test)


def _scale(unit):
    """Return (factor, printed unit) of a channel unit: m prints as um."""
    return (1e6, 'um') if unit == 'm' else (1.0, unit)


def _num(value):
    """Return a swing for print: whole units from 1000 up, else 3 significant digits."""
    return f'{value:.0f}' if abs(value) >= 1e3 else f'{value:.3g}'


def _alpha():
    return f'{STRUCTURE_ALPHA:g}'


def channel_clause(st):
    """Return one clause saying why ``st`` (ResidualStats) is or is not structured.

    The clause carries the statistics the decision compared, each beside its
    threshold: 'displacement: the inputs predict 135 um of the residual (F-test
    p=1.3e-188 < 0.001), above its floor 58.8 um (...)'.
    """
    t = st.structure
    if t is None:
        side = 'above' if st.structured else 'within'
        return (f'{st.channel}: residual RMS {st.ratio:.2f} x the sensor noise, {side} the '
                f'limit {STRUCTURE_RATIO:g}')
    k, unit = _scale(st.unit)
    if t.n < MIN_TEST_SAMPLES:
        head = f'{st.channel}: too few samples to test ({t.n} block means)'
        predicted = False
    else:
        significant = t.p_value < STRUCTURE_ALPHA
        large = t.predictable_rms > t.floor
        predicted = significant and large
        share = '' if STRUCTURE_NOISE_SHARE == 1.0 else f'{STRUCTURE_NOISE_SHARE:g} x '
        floor = (f'floor {t.floor * k:.3g} {unit} (the larger of {share}the noise '
                 f'{t.noise_rms * k:.3g} {unit} and {100 * STRUCTURE_FLOOR:g} % of the '
                 f'{_num(t.swing * k)} {unit} swing, {STRUCTURE_FLOOR * t.swing * k:.3g} {unit})')
        if not significant:
            head = (f'{st.channel}: the inputs predict nothing significant in the residual '
                    f'(F-test p={t.p_value:.2g} >= {_alpha()})')
        else:
            side = 'above' if large else 'within'
            head = (f'{st.channel}: the inputs predict {t.predictable_rms * k:.3g} {unit} of '
                    f'the residual (F-test p={t.p_value:.2g} < {_alpha()}), {side} its '
                    f'{floor}')
    limit = MAX_NOISE_SHARE * t.swing
    if t.wander_rms > limit:
        return (f'{head}{", but" if not predicted else ", and"} {t.wander_rms * k:.3g} {unit} '
                f'that neither the inputs nor an offset and a drift describe exceeds '
                f'{100 * MAX_NOISE_SHARE:g} % of the {_num(t.swing * k)} {unit} swing '
                f'({limit * k:.3g} {unit})')
    return head


def channels_text(stats):
    """Return the clauses of {channel: ResidualStats} joined into one list (';')."""
    return '; '.join(channel_clause(st) for st in stats.values())


def verdict_sentence(verdict, effects, stats, whole_stats=None):
    """Return the one-sentence explanation of ``verdict`` from the stats that decided it.

    ``stats``: {channel: ResidualStats} of the held-out part (the extended
    model's when ``effects`` were added, else the nominal's); ``whole_stats``:
    the nominal model's on the whole record, when they decided (held-out part
    unstructured, whole record structured).
    """
    added = ' + '.join(effects)
    held = channels_text(stats)
    if verdict == 'explained':
        return (f'after adding {added}, no channel of the held-out residual is structured '
                f'({held})')
    if verdict == 'adequate':
        if not whole_stats:
            return ('the nominal model leaves no structured channel in the held-out residual '
                    f'({held})')
        return ('the nominal model leaves no structured channel in the held-out residual or '
                f'in that of the whole record (held-out part: {held}; whole record: '
                f'{channels_text(whole_stats)})')
    if whole_stats is not None and not any(st.structured for st in stats.values()):
        structured = [st.channel for st in whole_stats.values() if st.structured]
        return ('unexplained structure remains in the residual of the whole record in '
                f'{", ".join(structured)} though not in the held-out part alone, and no '
                f'candidate improves the held-out fit (whole record: '
                f'{channels_text(whole_stats)}; held-out part: {held})')
    structured = [st.channel for st in stats.values() if st.structured]
    what = f'after adding {added}' if effects else 'and no candidate passes the held-out test'
    caution = ('; the effects added improve the fit but do not explain the data, so do not '
               'read them as its cause') if effects else ''
    return (f'unexplained structure remains {what}: the held-out residual of '
            f'{", ".join(structured)} is structured ({held}){caution}')


def confirmed_sentence(effects, heldout_stats, whole_stats, gain):
    """Return the sentence of an extension explained on the whole record, not the held-out part.

    ``heldout_stats``: the extension fitted on the training part, on the held-out
    part (structured); ``whole_stats``: it calibrated on the whole record, on the
    whole record (not structured); ``gain``: its penalised held-out gain over the
    calibrated nominal model (joint.py, "confirmed on the whole record").
    """
    return (f'after adding {" + ".join(effects)}, calibrated jointly on the whole record '
            f"less each record's sensor drift, no channel of its residual is structured "
            f'({channels_text(whole_stats)}); '
            f'fitted on the training part it predicts the held-out part better than the '
            f'nominal model (penalised held-out gain {gain:.1f}), and what the inputs still '
            f"predict there is its parameters' estimation error, which the whole-record "
            f'calibration removes ({channels_text(heldout_stats)})')


def found_sentence(effects, stats, evidence):
    """Return the sentence of effects found by the findings while structure remains.

    ``stats``: {channel: ResidualStats} of the extension on the held-out part
    (structured); ``evidence``: the clause giving why the effects are named
    (findings.found_text). The verdict stays 'unexplained': the effects are a
    cause, not all of it.
    """
    structured = [st.channel for st in stats.values() if st.structured]
    return (f'{" + ".join(effects)} found: {evidence}; unexplained structure remains beside '
            f'it: the held-out residual of {", ".join(structured)} is structured '
            f'({channels_text(stats)}), so something else acts too')


def rivals_clause(rivals):
    """Return the verdict's clause on rivals the records leave open, '' without any.

    ``rivals``: {named effect: [rivals]} (rivals.undecided_rivals), e.g. ';
    second_thermal_lag or sensor_lag: these records cannot tell which, and a note
    names the experiment that would'.
    """
    if not rivals:
        return ''
    options = '; '.join(' or '.join([named, *others]) for named, others in rivals.items())
    return (f'; {options}: these records cannot tell which, and a note names the '
            'experiment that would')


def not_taken_note(rounds, min_gain_percent):
    """Return the note on the first round's best unaccepted candidate, or None.

    A reader of the candidate table sees a candidate lower the held-out RMS and
    'effects found: none' below it: this says why it was not taken. ``rounds``:
    the search's SearchRounds; the candidate is the first round's with the
    lowest held-out score (noise-normalised RMS over the channels, -), taken when
    that is at least ``min_gain_percent`` (%) below the round's base and the
    candidate is not significant. None when no such candidate exists.
    """
    first = next((r for r in rounds if r is not None), None)
    if first is None or first.accepted or not first.scores:
        return None
    best = min(first.scores, key=lambda s: s.heldout_score)
    lower = 100.0 * (1.0 - best.heldout_score / first.base_score) if first.base_score else 0.0
    if best.significant or lower < min_gain_percent or not best.fit.success:
        return None
    if best.criterion <= 0.0:
        why = (f'its penalised held-out gain is {best.criterion:.1f} (<= 0): the test removes '
               "from each residual a drift from the record's zero, which a sensor may have, "
               'and weighs what remains by the noise model, and there what '
               f'{best.name} leaves is no closer to noise than what the nominal model leaves')
    else:
        why = ("with each record's drift removed its held-out RMS is less than "
               f'{min_gain_percent:g} % lower')
    return (f'{best.name} lowers the held-out RMS by {lower:.0f} % (noise-normalised, all '
            f'channels) but is not taken: {why} (docs/diagnosis_method.md, "Acceptance and '
            'the search")')
