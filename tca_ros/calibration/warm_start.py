"""A record that begins warm: its logged temperature falls before any power.

A lab that restarts its logger before the muscle has cooled records a start above
ambient (docs/calibration.md, "a warm start is fitted only where the temperature
shows it").
"""
import numpy as np

WARM_START_WINDOW_S = 1.0  # s of power off at the start needed to see a warm start
WARM_START_SAMPLES = 8  # samples of power off at the start needed likewise
WARM_START_SIGMAS = 4.0  # the fall over them that is no noise, in its standard errors
WARM_START_MIN_FALL_K = 0.3  # K, and at least this fall (a thermocouple's resolution)
POWER_OFF_SHARE = 0.05  # a logged power below this share of its peak is taken as off


def starts_warm(record, ambient):
    """Return True when the record's logged temperature shows it beginning warm.

    Before the first power (a logged power above POWER_OFF_SHARE of its peak), a
    muscle at rest holds its temperature; one that has not cooled from an earlier
    heating still falls. Warm: the record logs temperature, the power stays off for
    at least WARM_START_WINDOW_S and WARM_START_SAMPLES samples, the first quarter of
    that span is above ``ambient`` (degC) and its median temperature exceeds the last
    quarter's by WARM_START_SIGMAS standard errors and WARM_START_MIN_FALL_K. Without
    a temperature channel the start is taken at rest: a creeping coil stretches there
    as a cooling one does (docs/diagnosis_method.md, "Records that begin warm").
    """
    from tca_ros.calibration.residuals import noise_sigma
    if record.temperature is None:
        return False
    end = first_power(record)
    if end < WARM_START_SAMPLES or record.time[end - 1] - record.time[0] < WARM_START_WINDOW_S:
        return False
    rest = record.temperature[:end]
    quarter = max(1, end // 4)
    first, last = float(np.median(rest[:quarter])), float(np.median(rest[-quarter:]))
    sigma = noise_sigma(record.temperature) / np.sqrt(quarter)
    return (first > ambient and first - last > WARM_START_MIN_FALL_K
            and first - last > WARM_START_SIGMAS * np.sqrt(2.0) * sigma)


def first_power(record):
    """Return the index of a record's first sample with the power on (its length if none).

    A logged power reads noise at rest: on is above POWER_OFF_SHARE of its peak.
    """
    on = np.flatnonzero(record.power > POWER_OFF_SHARE * max(float(np.max(record.power)), 0.0))
    return int(on[0]) if on.size else record.time.size


def resting_temperature(records, ambient):
    """Return the temperature (degC) the thermometer reads at rest before any power, or None.

    A muscle at rest is at the room's temperature, so the logged temperature
    before the first power (above POWER_OFF_SHARE of its peak; the first sample
    when the power is on from the start) measures the room. The median of those
    samples of every record, pooled. None when a record logs no temperature or
    begins warm (:func:`starts_warm` against the described ``ambient``, degC):
    its reading is then the heat it still holds.
    """
    rest = []
    for record in records:
        if record.temperature is None or starts_warm(record, ambient):
            return None
        rest.append(record.temperature[:max(first_power(record), 1)])
    if not rest:
        return None
    return float(np.median(np.concatenate(rest)))
