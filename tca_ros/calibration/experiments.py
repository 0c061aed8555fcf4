"""The next experiment: the measurement that would separate values the records confuse.

When the records fix two calibrated values only in combination (their product or
ratio, Calibration.combinations), two rival muscles along that combination fit the
records alike. Each candidate experiment below is simulated with both rivals (the
quasi-static reduction of calibration, predictions.py); the one whose predictions
differ most against its sensor's noise is the one to run.
"""
from dataclasses import dataclass, replace
import math

import numpy as np

from tca_ros.calibration.predictions import predictor

THERMOCOUPLE_NOISE_K = 0.5  # K, a thermocouple on a thin thread
SECOND_LOAD_FACTOR = 3.0  # the second load, x the records' largest
OTHER_POWER_FACTOR = 1.5  # the other power, x the records' largest
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


def candidate_experiments(cal):
    """Return [(name, records, channel, noise, unit)] of the experiments to try."""
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
    out.append((f'a step at {OTHER_POWER_FACTOR:g}x the highest power',
                [_scaled(max(records, key=lambda r: float(np.max(r.power))),
                         power=OTHER_POWER_FACTOR)], 'displacement', noise, 'm'))
    return out


def next_experiments(cal):
    """Return [Experiment]: for each confused pair, the candidate that separates it best."""
    out = []
    for a, b, kind, _ in cal.combinations():
        best = separating_experiment(cal, _rivals(cal, a, b), (a, b), kind)
        if best is not None:
            out.append(best)
    return out


def separating_experiment(cal, rivals, pair, kind):
    """Return the Experiment of candidate_experiments that best separates two ``rivals``.

    ``rivals``: two calibration value sets ({name: value}, effect parameters by their
    dotted names) of Calibration ``cal``'s muscle that fit its records alike; each
    experiment is simulated with both (the quasi-static reduction, predictions.py)
    and the one whose predictions differ most against its sensor's noise is returned
    (None when none can be simulated). ``pair`` and ``kind`` label it.
    """
    own = predictor(cal.start, cal.model, ['displacement'], cal.supply)
    try:
        first, second = (own(v, cal.records) for v in rivals)
        seen = float(np.sqrt(np.mean(np.concatenate(
            [(p['displacement'] - q['displacement']) ** 2 for p, q in zip(first, second)]))))
    except (ValueError, ArithmeticError):
        seen = float('nan')
    best = None
    for name, records, channel, noise, unit in candidate_experiments(cal):
        predict = predictor(cal.start, cal.model, [channel], cal.supply)
        try:
            first, second = (predict(v, records) for v in rivals)
        except (ValueError, ArithmeticError):
            continue
        diff = float(np.sqrt(np.mean(np.concatenate(
            [(p[channel] - q[channel]) ** 2 for p, q in zip(first, second)]))))
        found = Experiment(tuple(pair), kind, name, diff, noise, unit, seen)
        if best is None or diff / noise > best.difference / best.noise:
            best = found
    return best


def format_experiments(experiments):
    """Return the report lines of ``next_experiments``."""
    lines = []
    for e in experiments:
        told = 'separates them' if e.separates else 'would not separate them either'
        lines.append(f'next experiment for the {e.kind} of {e.pair[0]} and {e.pair[1]}: '
                     f'{e.experiment} {told} (rivals one posterior spread apart differ by '
                     f'{e.difference:.3g} {e.unit} RMS there, {e.on_records:.3g} m on these '
                     f'records; noise {e.noise:.3g} {e.unit})')
    return lines
