"""Diagnosis figures. Each function takes ``ax=None``, returns its artists, never shows.

The caller selects the backend (the CLI and the report use Agg).
"""
import numpy as np

from tca_ros.calibration.residuals import cross_correlation_lag, heating_mask

MICRO = 1e6  # m -> um for axis labels


def _axes(ax):
    if ax is None:
        import matplotlib.pyplot as plt
        ax = plt.gca()
    return ax


def shade_heldout(ax, spans):
    """Shade the held-out spans [(start, end)] (s) of a time axis; return the artists."""
    return [ax.axvspan(a, b, color='khaki', alpha=0.35, lw=0,
                       label='held out' if i == 0 else None)
            for i, (a, b) in enumerate(spans)]


def plot_fit(time, measured, nominal, extended, heldout_spans, ax=None, scale=1e3,
             ylabel='contraction (mm)'):
    """Plot measured vs nominal vs extended over time (s), held-out spans shaded.

    ``heldout_spans``: [(start, end)] (s). Returns the lines.
    """
    ax = _axes(ax)
    lines = [ax.plot(time, measured * scale, color='0.6', lw=0.6, label='measured')[0],
             ax.plot(time, nominal * scale, color='tab:red', lw=1.0, label='nominal')[0],
             ax.plot(time, extended * scale, color='tab:blue', lw=1.0, ls='--',
                     label='extended')[0]] + shade_heldout(ax, heldout_spans)
    ax.set_xlabel('time (s)')
    ax.set_ylabel(ylabel)
    ax.legend(loc='best', fontsize='small')
    return lines


def plot_residual_time(time, residual_nominal, residual_extended, sigma, heldout_spans,
                       ax=None, scale=MICRO, ylabel='residual (um)'):
    """Plot residuals (measured - model) over time (s) with the +-2 sigma noise band.

    ``heldout_spans``: [(start, end)] (s), shaded.
    """
    ax = _axes(ax)
    out = [ax.plot(time, residual_nominal * scale, color='tab:red', lw=0.6, label='nominal')[0],
           ax.plot(time, residual_extended * scale, color='tab:blue', lw=0.6,
                   label='extended')[0],
           ax.axhspan(-2 * sigma * scale, 2 * sigma * scale, color='0.85', label='2 sigma noise'),
           *shade_heldout(ax, heldout_spans)]
    ax.set_xlabel('time (s)')
    ax.set_ylabel(ylabel)
    ax.legend(loc='best', fontsize='small')
    return out


def plot_residual_branches(temperature, residual, sample_rate, ax=None, scale=MICRO,
                           ylabel='residual (um)', label='nominal'):
    """Scatter residual vs temperature (degC), heating and cooling branches apart."""
    ax = _axes(ax)
    heating = heating_mask(temperature, sample_rate)
    step = max(1, temperature.size // 4000)
    out = [ax.plot(temperature[heating][::step], residual[heating][::step] * scale, '.',
                   ms=1.5, color='tab:orange', label=f'{label}: heating')[0],
           ax.plot(temperature[~heating][::step], residual[~heating][::step] * scale, '.',
                   ms=1.5, color='tab:cyan', label=f'{label}: cooling')[0]]
    ax.set_xlabel('temperature (degC)')
    ax.set_ylabel(ylabel)
    ax.legend(loc='best', fontsize='small', markerscale=5)
    return out


def plot_residual_load(load, residual, ax=None, scale=MICRO, ylabel='residual (um)',
                       label='nominal', color='tab:red'):
    """Scatter residual vs tensile load (N)."""
    ax = _axes(ax)
    step = max(1, load.size // 4000)
    out = [ax.plot(load[::step], residual[::step] * scale, '.', ms=1.5, color=color,
                   label=label)[0]]
    ax.set_xlabel('load (N)')
    ax.set_ylabel(ylabel)
    ax.legend(loc='best', fontsize='small', markerscale=5)
    return out


def plot_cross_correlation(measured, predicted_nominal, predicted_extended, sample_rate,
                           ax=None):
    """Plot the measured-vs-model rate cross-correlation against lag (s)."""
    ax = _axes(ax)
    out = []
    for pred, color, label in ((predicted_nominal, 'tab:red', 'nominal'),
                               (predicted_extended, 'tab:blue', 'extended')):
        lags, corr, best = cross_correlation_lag(measured, pred, sample_rate)
        out.append(ax.plot(lags, corr, color=color, label=f'{label} (peak at {best:+.2f} s)')[0])
    out.append(ax.axvline(0.0, color='k', lw=0.8, ls=':'))
    ax.set_xlabel('lag of measurement behind model (s)')
    ax.set_ylabel('rate cross-correlation (-)')
    ax.legend(loc='best', fontsize='small')
    return out


def plot_residual_spectrum(residual_nominal, residual_extended, sigma, sample_rate, ax=None,
                           scale=MICRO, unit='um'):
    """Plot residual power spectral densities (unit^2/Hz) and the white-noise level."""
    ax = _axes(ax)
    out = []
    for res, color, label in ((residual_nominal, 'tab:red', 'nominal'),
                              (residual_extended, 'tab:blue', 'extended')):
        r = (res - res.mean()) * scale
        freq = np.fft.rfftfreq(r.size, 1.0 / sample_rate)[1:]
        psd = 2.0 * np.abs(np.fft.rfft(r))[1:] ** 2 / (sample_rate * r.size)
        # average in log-spaced bands for a readable curve
        edges = np.logspace(np.log10(freq[0]), np.log10(freq[-1]), 60)
        idx = np.digitize(freq, edges)
        centres = [freq[idx == i].mean() for i in np.unique(idx)]
        values = [psd[idx == i].mean() for i in np.unique(idx)]
        out.append(ax.loglog(centres, values, color=color, label=label)[0])
    white = 2.0 * (sigma * scale) ** 2 / sample_rate
    out.append(ax.axhline(white, color='k', ls=':', label='white noise level'))
    ax.set_xlabel('frequency (Hz)')
    ax.set_ylabel(f'residual PSD ({unit}^2/Hz)')
    ax.legend(loc='best', fontsize='small')
    return out


def plot_ranking(names, gains, significant, ax=None):
    """Bar chart of held-out displacement gain (%) per candidate."""
    ax = _axes(ax)
    y = np.arange(len(names))
    shown = np.clip(gains, -100.0, 100.0)
    colors = ['tab:green' if s else '0.6' for s in significant]
    bars = ax.barh(y, shown, color=colors)
    ax.set_yticks(y, names)
    ax.invert_yaxis()
    ax.axvline(0.0, color='k', lw=0.8)
    ax.set_xlabel('held-out displacement RMSE gain vs nominal (%, clipped at -100)')
    return [bars]
