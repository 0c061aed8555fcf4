"""The verdict of a diagnosis: held-out scores and whether what is left is noise.

A channel is structured when the inputs still predict its held-out residual
(noise.structure_test, pooled over the records of a set); the verdict follows
(docs/diagnosis_method.md, "Noise and the structure test"). A candidate is accepted by its
held-out gain under the same noise model (noise_model_gain).
"""
import math

import numpy as np

from tca_ros.calibration.residuals import residual_stats
from tca_ros.diagnosis.input_wander import WanderPath
from tca_ros.diagnosis.noise import heldout_deviance_gain, structure_test
from tca_ros.diagnosis.regressors import input_terms_in_runs, remove_nuisance_jointly
from tca_ros.diagnosis.verdict_text import confirmed_sentence, verdict_sentence
from tca_ros.model.simulation import simulate
from tca_ros.model.thermal import thermal_time_constant
from tca_ros.records.record import power_is_command

UNITS = {'displacement': 'm', 'temperature': 'K'}


def gain(before, after):
    """Return 100 (1 - after / before) (%), the relative RMSE reduction."""
    return 100.0 * (1.0 - after / before) if before > 0.0 else 0.0


#: relative step of the delivered power for the response's sensitivity to it (-)
WANDER_STEP = 0.02


def wander_scale(problem, channel, prediction, params=None):
    """Return the response's sensitivity to the delivered power, or None (channel units).

    None when ``problem``'s record logs the power delivered. Else d y / d ln P: the
    change of the predicted displacement (m) or temperature (K) over the record when
    the power heating the thread is WANDER_STEP larger (the delivered power ratio),
    divided by that step. A slow relative wander w of the supply moves the response
    by about this times w (noise.structure_test, input_wander.py); for the
    temperature under a linear heat loss it is the rise, for the stroke the local
    stroke-temperature slope times the rise, not the stroke itself (G62).
    ``prediction``: the channel simulated with ``params`` (default the problem's)
    at the record's samples.
    """
    if not power_is_command(problem.record):
        return None
    raised = _with_more_power(problem, params or problem.params)
    return (getattr(raised, channel) - prediction) / WANDER_STEP


def wander_path(record, channel, params):
    """Return the WanderPath of a commanded power's wander to ``channel`` of ``record``.

    The lags in series from the heat input to the channel: the thermal time
    constant (eq. 8) for both channels, and for the stroke the second thermal lag
    and the sensor lag when ``params`` (TcaParams) has them; the dead time delays
    the power of both (G63).
    """
    e = params.effects
    lags = (thermal_time_constant(params.fiber, params.thermal),)
    if channel == 'displacement':
        lags += tuple(t for t in (e.second_thermal_lag, e.sensor_lag) if t > 0.0)
    return WanderPath(record.power, record.sample_rate, lags, e.dead_time)


def _with_more_power(problem, params):
    """Return the simulation of ``params`` with WANDER_STEP more power delivered (cached)."""
    cache = problem.__dict__.setdefault('_more_power', {})
    if params not in cache:
        if len(cache) > 64:  # the verdicts of one diagnosis: a few dozen parameter sets
            cache.clear()
        r = problem.record
        ratio = params.thermal.delivered_power_ratio * (1.0 + WANDER_STEP)
        cache[params] = simulate(params.with_values(**{'thermal.delivered_power_ratio': ratio}),
                                 r.time, r.power, r.load, model=problem.model,
                                 physics_rate=problem.physics_rate)
    return cache[params]


def pooled_heldout_rmse(problems, sims, channels, detrend=False):
    """Return {channel: RMSE} over the held-out parts of all records (m, K).

    ``detrend``: of the residual less the verdict's nuisance (per record a drift from
    the record's zero, shared by its held-out runs: regressors.nuisance_design), the
    part a sensor drift cannot explain.
    """
    out = {}
    for c in channels:
        parts, items = [], []
        for p, s in zip(problems, sims):
            res = getattr(p.record, c) - getattr(s, c)
            for a, b in p.full_runs:
                parts.append(res[a:b])
                items.append((b - a, p.sample_rate, float(p.record.time[a] - p.record.time[0]),
                              id(p)))
        if detrend:
            parts = remove_nuisance_jointly(parts, items)
        res = np.concatenate(parts)
        out[c] = float(np.sqrt(np.mean(res ** 2)))
    return out


def drift_free_heldout_score(problem, residuals):
    """Return the held-out RMS (in sensor sigmas, -) of ``residuals`` less the drift.

    ``residuals``: ``problem.heldout_residuals(values)`` (None: the model failed,
    +inf). Per channel the verdict's nuisance (a drift from each record's zero,
    shared by its held-out runs) is removed jointly, then each channel is divided
    by its sensor noise sigma: the coarse-grid form of
    ``pooled_heldout_rmse(..., detrend=True)`` that the search's 1 % rule uses,
    so a candidate is not accepted for fitting a sensor's drift (decisions G46).
    """
    if residuals is None:
        return math.inf
    items = list(zip([len(next(iter(r.values()))) for r in residuals], problem.coarse_rates,
                     problem.heldout_starts, problem.heldout_groups))
    total, n = 0.0, 0
    for c in problem.channels:
        parts = remove_nuisance_jointly([r[c] for r in residuals], items)
        res = np.concatenate(parts) / problem.sigma[c]
        total += float(res @ res)
        n += res.size
    return math.sqrt(total / n) if n else math.inf


def channel_stats(problems, sims, params=None, whole=False):
    """Return {channel: ResidualStats} of ``sims`` on the held-out parts (record rate).

    ``problems`` and ``sims`` are lists (one per record) or a single pair. Each
    channel carries the residual-input independence test (noise.structure_test),
    pooled over the records and their held-out runs (one drift per record),
    against the input-driven signals of ``params`` (per record; default each
    problem's). ``whole``: on the whole records (training and held-out parts)
    instead.
    """
    if not isinstance(problems, (list, tuple)):
        problems, sims = [problems], [sims]
        params = None if params is None else [params]
    params = params or [p.params for p in problems]
    out, tests = {}, {}
    for c in problems[0].channels:
        segments, measured_all, predicted_all, temp_all = [], [], [], []
        swing = 0.0
        for p, sim, par in zip(problems, sims, params):
            r = p.record
            runs = [(0, r.time.size)] if whole else p.full_runs
            measured, predicted = getattr(r, c), getattr(sim, c)
            tau = thermal_time_constant(par.fiber, par.thermal)
            rise = sim.temperature - par.thermal.ambient_temperature
            terms = input_terms_in_runs(predicted, rise, r.power, p.sample_rate, tau, runs)
            level = wander_scale(p, c, predicted, par)
            path = None if level is None else wander_path(r, c, par)
            for (a, b), x in zip(runs, terms):
                segments.append((measured[a:b] - predicted[a:b], x, p.sample_rate,
                                 float(r.time[a] - r.time[0]), id(p),
                                 None if level is None else level[a:b], path))
            swing = max(swing, float(np.percentile(measured, 99.0)
                                     - np.percentile(measured, 1.0)))
            index = np.arange(r.time.size) if whole else p.full_heldout_index
            measured_all.append(measured[index])
            predicted_all.append(predicted[index])
            temp = r.temperature if r.temperature is not None else sim.temperature
            temp_all.append(temp[index])
        tests[c] = (segments, swing, structure_test(segments, swing))
        out[c] = (np.concatenate(measured_all), np.concatenate(predicted_all),
                  np.concatenate(temp_all))
    supply = one_supply(tests)
    first = problems[0]
    for c, (segments, swing, test) in tests.items():
        if supply is not None and test.supply != supply:
            test = structure_test(segments, swing, supply=supply)
        out[c] = residual_stats(c, UNITS[c], *out[c][:2], first.sigma[c], first.sample_rate,
                                out[c][2], structure=test)
    return out


def one_supply(tests):
    """Return (sigma_w -, tau_w s) of the smallest input wander the channels fitted, or None.

    ``tests``: {channel: (segments, swing, StructureTest)}. One supply heats the
    thread, so the unlogged wander of a commanded power (input_wander.py) is one
    process in every channel. A channel's own estimate takes up, besides it,
    whatever of a model error follows the response's level; the smallest is the
    supply's, and the other channels are tested with it (G62). None with fewer
    than two channels that model the wander.
    """
    fitted = [t.supply for _, _, t in tests.values() if t.supply is not None]
    return min(fitted) if len(fitted) > 1 else None


NOTHING_TO_EXPLAIN = ('no effect searched: the inputs predict nothing beyond the noise in '
                      "the calibrated nominal model's residual (held-out part or whole "
                      'record)')


#: load levels within this share of the largest are one load (N / N)
ONE_LOAD_SPREAD = 0.05
ONE_LOAD_NOTE = ('every record holds one load: a static distortion of the displacement '
                 'reading (a sensor nonlinearity, a lever) cannot be told from the calibrated '
                 'stroke-temperature relation on one load; diagnose records at two or more '
                 'loads together to test for it (docs/diagnosis_method.md)')


def holds_one_load(records):
    """Return True when the records' load channels (N) span a single load level.

    On one load the stroke is a static function of the fibre temperature, and
    the calibrated steady rise and actuation gain (with eq. 2's quadratic in
    temperature) can reshape it: a smooth static map of the reading is absorbed.
    """
    loads = [float(v) for r in records for v in (r.load.min(), r.load.max())]
    top = max(abs(v) for v in loads)
    return top == 0.0 or max(loads) - min(loads) <= ONE_LOAD_SPREAD * top


def needs_explaining(*stats):
    """Return the channels (list) of {channel: ResidualStats} with structure left.

    Empty when what the model leaves is noise by the verdict's own test
    (noise.structure_test): then there is nothing for an effect to explain,
    and any effect a search would add could only fit noise. ``stats`` may be
    several such dicts (held-out part, whole record): structure in any counts.
    """
    return [st.channel for part in stats for st in part.values() if st.structured]


def decide_verdict(effects, nominal_stats, extended_stats, nominal_whole_stats=None,
                   confirmed=None):
    """Return (verdict, one-sentence explanation) from the residual structure.

    A channel is structured when the inputs still predict a practically relevant
    part of its held-out residual (noise.structure_test; the noise may be
    coloured, drifting or quantised). 'adequate': nothing added and no channel
    structured, neither on the held-out part nor, when ``nominal_whole_stats``
    is given, on the whole record (the reason a search ran: the training part
    can show what the held-out part's test does not resolve); 'explained':
    effects added and no channel structured; 'unexplained': structure remains.
    The sentence names, per channel, the statistics that decided and their
    thresholds (verdict_text.py). ``confirmed``: (whole-record stats, penalised
    held-out gain) of a joint fit confirmed on the whole record (joint.py): its
    effects leave no structure there, and the held-out structure of the
    training-part fit is its estimation error: 'explained'.
    """
    if effects and confirmed is not None:
        whole_refit, heldout_gain = confirmed
        if not needs_explaining(whole_refit):
            return 'explained', confirmed_sentence(effects, extended_stats, whole_refit,
                                                   heldout_gain)
    stats = extended_stats if effects else nominal_stats
    structured = [st.channel for st in stats.values() if st.structured]
    whole = [] if effects or not nominal_whole_stats else \
        [st.channel for st in nominal_whole_stats.values() if st.structured]
    if structured or whole:
        verdict = 'unexplained'
    else:
        verdict = 'explained' if effects else 'adequate'
    whole_stats = None if effects else nominal_whole_stats
    return verdict, verdict_sentence(verdict, effects, stats, whole_stats)


def heldout_gain_over(problems, base_sims, sims, added_params):
    """Return the penalised held-out gain D - k ln(n) of ``sims`` over ``base_sims``.

    As :func:`noise_model_gain`, on the record-rate simulations (one per problem)
    of two complete models rather than on the fit grid: how the diagnosis
    checks that its extended model predicts the held-out parts better than the
    calibrated nominal one it started from.
    """
    deviance, n = heldout_deviance(problems, base_sims, sims)
    if n < added_params + 2:
        return -math.inf
    return deviance - added_params * math.log(n)


def heldout_deviance(problems, base_sims, sims):
    """Return (D, n): the held-out deviance gain of ``sims`` over ``base_sims`` and its count.

    noise.heldout_deviance_gain on the record-rate simulations (one per problem).
    """
    pairs = []
    for c in problems[0].channels:
        channel = []
        for p, b, e in zip(problems, base_sims, sims):
            measured = getattr(p.record, c)
            for i0, i1 in p.full_runs:
                channel.append((measured[i0:i1] - getattr(b, c)[i0:i1],
                                measured[i0:i1] - getattr(e, c)[i0:i1], p.sample_rate,
                                float(p.record.time[i0] - p.record.time[0]), id(p)))
        pairs.append(channel)
    return heldout_deviance_gain(pairs)


def noise_model_gain(problem, base_residuals, values, added_params, residuals=None):
    """Return the BIC-penalised held-out gain of ``values`` under the verdict's noise model.

        D - k ln(n)

    D from noise.heldout_deviance_gain (per record a drift from the record's
    zero is noise, the rest AR(p) noise: the model the verdict judges residuals by),
    n its sample count, k the added parameters. Positive: the candidate
    predicts the held-out part better than k parameters fitted to noise would.
    ``base_residuals`` is ``problem.heldout_residuals`` of the base; ``residuals``
    those of ``values`` when already simulated.
    """
    cand = problem.heldout_residuals(values) if residuals is None else residuals
    if base_residuals is None or cand is None:
        return -math.inf
    rates, starts, groups = problem.coarse_rates, problem.heldout_starts, \
        problem.heldout_groups
    pairs = [[(b[c], r[c], rate, t0, g)
              for b, r, rate, t0, g in zip(base_residuals, cand, rates, starts, groups)]
             for c in problem.channels]
    deviance, n = heldout_deviance_gain(pairs)
    if n < added_params + 2:
        return -math.inf
    return deviance - added_params * math.log(n)
