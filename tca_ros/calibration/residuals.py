"""Residual statistics: noise level, whiteness, spectral structure, lag, branches.

References
----------
[1] L. Ljung, System Identification: Theory for the User, 2nd ed., Prentice Hall,
    1999 (Sec. 16.6: residual analysis, whiteness and independence tests).
[2] G. M. Ljung and G. E. P. Box, "On a measure of lack of fit in time series
    models," Biometrika 65(2), 1978.
[3] H. Akaike, "A new look at the statistical model identification," IEEE TAC
    19(6), 1974; G. Schwarz, "Estimating the dimension of a model," Ann. Stat. 6(2),
    1978 (penalty for added parameters).
"""
from dataclasses import dataclass
import math

import numpy as np
from scipy import stats

MAD_TO_SIGMA = 1.4826  # sigma / MAD of a Gaussian
SECOND_DIFFERENCE_GAIN = math.sqrt(6.0)  # std of x[i+1] - 2 x[i] + x[i-1] for white x
STRUCTURE_RATIO = 1.2  # residual RMS above this many noise sigmas is structure, not noise
LJUNG_BOX_LAGS = 20  # lags in the Ljung-Box statistic
WHITENESS_RATE_HZ = 1.0  # residuals are decimated to this rate for the Ljung-Box test


def noise_sigma(signal, floor=0.0):
    """Return the white-noise level (signal units) from robust second differences.

        sigma = 1.4826 MAD(x[i+1] - 2 x[i] + x[i-1]) / sqrt(6)

    Smooth dynamics contribute little to second differences at the sample rate
    and the median ignores the few samples at steps, so this estimates the sensor
    noise without a model. ``floor`` bounds it from below (noise-free data).
    """
    d2 = np.diff(np.asarray(signal, dtype=float), 2)
    if d2.size == 0:
        return floor
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return max(MAD_TO_SIGMA * mad / SECOND_DIFFERENCE_GAIN, floor)


def lag_one_autocorrelation(residual):
    """Return the lag-1 autocorrelation (-) of a residual series."""
    r = np.asarray(residual, dtype=float) - np.mean(residual)
    denom = float(r @ r)
    return float(r[1:] @ r[:-1] / denom) if denom > 0.0 else 0.0


def effective_samples(n, rho):
    """Return n (1 - rho) / (1 + rho), the AR(1) effective sample count of n samples."""
    rho = min(max(rho, 0.0), 0.999)
    return n * (1.0 - rho) / (1.0 + rho)


def ljung_box(residual, lags=LJUNG_BOX_LAGS):
    """Return (Q, p-value) of the Ljung-Box whiteness test [2].

        Q = n (n + 2) sum_k r_k^2 / (n - k),  Q ~ chi2(lags) if white
    """
    r = np.asarray(residual, dtype=float) - np.mean(residual)
    n = r.size
    lags = min(lags, n - 2)
    if lags < 1 or not np.any(r):
        return 0.0, 1.0
    denom = float(r @ r)
    acf = np.array([r[k:] @ r[:-k] / denom for k in range(1, lags + 1)])
    q = float(n * (n + 2) * np.sum(acf ** 2 / (n - np.arange(1, lags + 1))))
    return q, float(stats.chi2.sf(q, lags))


def spectral_flatness(residual):
    """Return the spectral flatness (-): geometric / arithmetic mean of the periodogram.

    1 for white noise in expectation (about 0.56 for a single periodogram, whose
    ordinates are exponential); near 0 when power concentrates in few bands.
    """
    r = np.asarray(residual, dtype=float) - np.mean(residual)
    power = np.abs(np.fft.rfft(r))[1:] ** 2
    power = power[power > 0.0]
    if power.size == 0:
        return 1.0
    return float(np.exp(np.mean(np.log(power))) / np.mean(power))


def low_frequency_fraction(residual, sample_rate, cutoff_hz=0.1):
    """Return the share (-) of residual power below ``cutoff_hz`` (Hz).

    For white noise it equals cutoff / Nyquist; model error of a thermal TCA
    (time constants of seconds) concentrates there.
    """
    r = np.asarray(residual, dtype=float) - np.mean(residual)
    power = np.abs(np.fft.rfft(r)) ** 2
    freq = np.fft.rfftfreq(r.size, 1.0 / sample_rate)
    total = float(power[1:].sum())
    return float(power[1:][freq[1:] < cutoff_hz].sum() / total) if total > 0.0 else 0.0


def cross_correlation_lag(measured, predicted, sample_rate, max_lag_s=3.0):
    """Return (lags (s), correlation (-), best lag (s)) of measured vs predicted rates.

    The increments of the two series are correlated; a positive best lag means
    the measurement trails the model (a sensor lag or missing thermal lag).
    """
    a = np.diff(np.asarray(measured, dtype=float))
    b = np.diff(np.asarray(predicted, dtype=float))
    if a.size == 0:  # one sample: no increments to correlate
        return np.zeros(1), np.zeros(1), 0.0
    a, b = a - a.mean(), b - b.mean()
    max_lag = int(min(max_lag_s * sample_rate, a.size // 4))
    lags = np.arange(-max_lag, max_lag + 1)
    norm = math.sqrt(float(a @ a) * float(b @ b)) or 1.0
    corr = np.array([(a[k:] @ b[:a.size - k] if k >= 0 else a[:k] @ b[-k:]) / norm
                     for k in lags])
    return lags / sample_rate, corr, float(lags[int(np.argmax(corr))] / sample_rate)


def heating_mask(temperature, sample_rate, smooth_s=0.5):
    """Return True where the (smoothed) temperature rises: the heating branch.

    The smoothing window is cut to the series' length: ``np.convolve(mode='same')``
    returns the longer of its two inputs, so a window longer than a short held-out
    part would give a mask longer than the residual.
    """
    temperature = np.asarray(temperature, dtype=float)
    if temperature.size < 2:
        return np.zeros(temperature.size, dtype=bool)
    width = min(max(1, int(round(smooth_s * sample_rate))), temperature.size)
    kernel = np.ones(width) / width
    smooth = np.convolve(temperature, kernel, mode='same')
    return np.gradient(smooth) > 0.0


@dataclass
class ResidualStats:
    """Statistics of one channel's residual (channel units)."""

    channel: str
    unit: str
    rms: float
    noise_sigma: float
    ratio: float  # rms / noise_sigma
    mean: float
    lag_one: float  # lag-1 autocorrelation at the sample rate
    ljung_box_q: float
    ljung_box_p: float  # at WHITENESS_RATE_HZ
    flatness: float
    low_frequency_fraction: float
    heating_mean: float  # mean residual on the heating branch
    cooling_mean: float  # mean residual on the cooling branch
    best_lag_s: float  # lag of the peak measured-vs-model cross-correlation
    structure: object = None  # noise.StructureTest: residual-input independence test

    @property
    def structured(self):
        """Return True when the residual carries more than noise.

        With a residual-input test (noise.structure_test): when the inputs predict
        a practically relevant part of the residual, whatever the colour of the
        noise. Without one: when the RMS exceeds STRUCTURE_RATIO white-noise sigmas.
        """
        if self.structure is not None:
            return self.structure.structured
        return self.ratio > STRUCTURE_RATIO


def residual_stats(channel, unit, measured, predicted, sigma, sample_rate, temperature,
                   structure=None):
    """Return ResidualStats of ``measured - predicted`` (channel units).

    ``temperature`` (degC) splits heating and cooling branches; ``structure`` is
    the channel's noise.StructureTest, if any.
    """
    residual = np.asarray(measured) - np.asarray(predicted)
    rms = float(np.sqrt(np.mean(residual ** 2)))
    step = max(1, int(round(sample_rate / WHITENESS_RATE_HZ)))
    q, p = ljung_box(residual[::step])
    heating = heating_mask(temperature, sample_rate)
    _, _, best_lag = cross_correlation_lag(measured, predicted, sample_rate)
    return ResidualStats(
        channel=channel, unit=unit, rms=rms, noise_sigma=sigma,
        ratio=rms / sigma if sigma > 0.0 else math.inf, mean=float(residual.mean()),
        lag_one=lag_one_autocorrelation(residual), ljung_box_q=q, ljung_box_p=p,
        flatness=spectral_flatness(residual),
        low_frequency_fraction=low_frequency_fraction(residual, sample_rate),
        heating_mean=float(residual[heating].mean()) if heating.any() else 0.0,
        cooling_mean=float(residual[~heating].mean()) if (~heating).any() else 0.0,
        best_lag_s=best_lag, structure=structure)
