"""The next experiment: the measurement that would separate rivals the records confuse.

When the records fix two calibrated values only in combination (their product or
ratio, Calibration.combinations), two rival muscles along that combination fit the
records alike; so do two catalogue effects that the diagnosis finds explaining the
records equally (a sensor lag and a second thermal lag delay the stroke behind the
measured temperature alike, tca_ros.diagnosis.rivals). Each candidate
experiment below is simulated with both rivals (the quasi-static reduction of
calibration, predictions.py); the one whose predictions differ most against its
sensor's noise is the one to run (:func:`separating_experiment`).
"""
from dataclasses import dataclass, replace
import math

import numpy as np

from tca_ros.calibration.conditions import rig_of
from tca_ros.calibration.predictions import predictor

THERMOCOUPLE_NOISE_K = 0.5  # K, a thermocouple on a thin thread
SECOND_LOAD_FACTOR = 3.0  # the second load, x the records' largest
OTHER_POWER_FACTOR = 1.5  # the other power, x the records' largest
LOAD_STEP_FACTOR = 2.0  # the load raised to this x the record's over its middle third
SEPARATES = 3.0  # rivals differing by this many noise units are told apart


@dataclass
class Experiment:
    """An experiment's verdict on one pair of confused values."""

    pair: tuple  # (name a, name b)
    kind: str  # 'product', 'ratio' or 'combination'
    experiment: str
    difference: float  # RMS difference of the rivals' predictions (unit)
    noise: float  # the sensor noise (unit)
    unit: str
    on_records: float = float('nan')  # m, RMS difference of the rivals on the records

    @property
    def separates(self):
        """Return True when the rivals differ by SEPARATES noise units or more."""
        return self.difference >= SEPARATES * self.noise

    def sentence(self):
        """Return what the experiment tells: '<experiment> separates them (... RMS ...)'.

        The report's one wording for calibration pairs, diagnosis rivals and the
        one-load softening; displacements in mm, temperatures in K.
        """
        told = 'separates them' if self.separates else 'would not separate them either'
        return (f'{self.experiment} {told} (simulated with each, they differ by '
                f'{shown(self.difference, self.unit)} RMS there, '
                f'{shown(self.on_records, "m")} on these records; noise '
                f'{shown(self.noise, self.unit)})')


def shown(value, unit):
    """Return ``value`` (m or K) as the reports write it: displacements in mm."""
    return f'{value * 1e3:.3g} mm' if unit == 'm' else f'{value:.3g} {unit}'


def _rivals(cal, a, b):
    """Return two value sets one posterior spread apart along the pair's confused direction.

    The direction is the principal axis of the pair's posterior covariance in fit
    coordinates (ln value for scale parameters): the records barely tell its ends apart.
    """
    est, pa, pb = cal.report.estimates, cal.priors[a], cal.priors[b]
    names = list(est)
    i, j = names.index(a), names.index(b)
    sd = np.array([est[a].stderr / est[a].value if pa.log else est[a].stderr,
                   est[b].stderr / est[b].value if pb.log else est[b].stderr])
    rho = float(cal.report.correlation[i, j])
    cov = np.outer(sd, sd) * np.array([[1.0, rho], [rho, 1.0]])
    lam, vec = np.linalg.eigh(cov)
    axis = vec[:, -1] * math.sqrt(max(lam[-1], 0.0))
    z = np.array([pa.to_fit(est[a].value), pb.to_fit(est[b].value)])
    out = []
    for sign in (-1.0, 1.0):
        v = dict(cal.report.values)
        za, zb = z + sign * axis
        v[a] = min(max(pa.from_fit(za), pa.low), pa.high)
        v[b] = min(max(pb.from_fit(zb), pb.low), pb.high)
        out.append(v)
    return out


def _scaled(record, power=1.0, load=1.0):
    return replace(record, power=record.power * power, load=record.load * load,
                   meta={**record.meta, 'mass_kg': float(record.meta.get('mass_kg', 0.0))
                         * load})


def _load_stepped(record, factor=LOAD_STEP_FACTOR):
    """Return ``record`` with its load (N) x ``factor`` over the middle third of its time.

    At a load step the coil's elastic response is immediate (behind the damping
    only): what lags the actuating temperature does not delay it, what lags the
    reading does, and friction holds back a band of it.
    """
    t = record.time
    middle = (t >= t[0] + (t[-1] - t[0]) / 3.0) & (t < t[0] + 2.0 * (t[-1] - t[0]) / 3.0)
    return replace(record, load=np.where(middle, record.load * factor, record.load))


def candidate_experiments(cal):
    """Return [(name, records, channel, noise, unit)] of the experiments to try.

    A temperature channel (when the records have none), a step at another load, the
    same steps with a load step in them (hanging-mass records) and a step at another
    power; the noise is the calibration's residual RMS (m) or a thermocouple's (K).
    """
    records = [r for r in cal.records if r.force is None or r.meta.get('rig') != 'isometric']
    if not records:
        return []
    noise = cal.report.channel_scale.get('displacement', 1e-5)
    out = []
    if 'temperature' not in cal.channels:
        out.append(('a temperature channel on the same steps', records, 'temperature',
                    THERMOCOUPLE_NOISE_K, 'K'))
    out.append((f'a step at {SECOND_LOAD_FACTOR:g}x the load',
                [_scaled(records[0], load=SECOND_LOAD_FACTOR)], 'displacement', noise, 'm'))
    if rig_of(records[0]) not in ('isometric', 'spring'):
        out.append((f'the same steps with the load raised to {LOAD_STEP_FACTOR:g}x over '
                    'their middle third', [_load_stepped(records[0])], 'displacement', noise,
                    'm'))
    out.append((f'a step at {OTHER_POWER_FACTOR:g}x the highest power',
                [_scaled(max(records, key=lambda r: float(np.max(r.power))),
                         power=OTHER_POWER_FACTOR)], 'displacement', noise, 'm'))
    return out


def rms_difference(cal, rivals, records, channel):
    """Return the RMS difference (channel unit) of two value sets' predictions on ``records``.

    ``rivals``: two {calibration name: value} sets (``effects.*`` names included),
    each simulated with the quasi-static reduction from ``cal.start``
    (predictions.predictor); NaN when either cannot be simulated.
    """
    predict = predictor(cal.start, cal.model, [channel], cal.supply)
    try:
        first, second = (predict(v, records) for v in rivals)
    except (ValueError, ArithmeticError):
        return float('nan')
    return float(np.sqrt(np.mean(np.concatenate(
        [(p[channel] - q[channel]) ** 2 for p, q in zip(first, second)]))))


def separating_experiment(cal, rivals, pair, kind):
    """Return the Experiment that separates two rival value sets best, or None.

    ``rivals``: two {calibration name: value} sets that fit ``cal.records`` alike;
    every candidate experiment (:func:`candidate_experiments`) is simulated with
    each, and the one whose predictions differ most against its sensor's noise is
    returned, with the rivals' RMS difference on the records themselves (m).
    ``pair`` names the rivals and ``kind`` says what they are ('product', 'ratio',
    'combination' of two values, or 'effects').
    """
    seen = rms_difference(cal, rivals, cal.records, 'displacement')
    best = None
    for name, records, channel, noise, unit in candidate_experiments(cal):
        diff = rms_difference(cal, rivals, records, channel)
        if diff != diff:  # the experiment cannot be simulated with a rival
            continue
        found = Experiment(tuple(pair), kind, name, diff, noise, unit, seen)
        if best is None or diff / noise > best.difference / best.noise:
            best = found
    return best


def next_experiments(cal):
    """Return [Experiment]: for each confused pair, the candidate that separates it best."""
    out = []
    for a, b, kind, _ in cal.combinations():
        best = separating_experiment(cal, _rivals(cal, a, b), (a, b), kind)
        if best is not None:
            out.append(best)
    return out


def format_experiments(experiments):
    """Return the report lines of ``next_experiments`` (rivals one posterior spread apart)."""
    return [f'next experiment for the {e.kind} of {e.pair[0]} and {e.pair[1]} (one posterior '
            f'spread apart): {e.sentence()}' for e in experiments]
