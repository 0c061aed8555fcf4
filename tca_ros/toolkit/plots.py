"""Plots of the controller developer's tools (matplotlib, Agg backend)."""
import numpy as np

from tca_ros.toolkit.linearize import INPUT_UNITS, OUTPUT_UNITS

BODE_DECADES = (-3.0, 3.0)  # log10 of the frequency range (rad/s) shown
BODE_POINTS = 400


def bode_figure(curves, title=''):
    """Return a Bode figure of SISO channels, each magnitude relative to its DC gain.

    Parameters
    ----------
    curves : list of (LinearPlant, output, input)
        Channels to draw; units differ, so |G(jw)| / |G(0)| (dB) is shown and the
        DC gain (with its unit) goes into the legend. The phase (deg) includes the
        plant's dead time exp(-s d).
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    omega = np.logspace(*BODE_DECADES, BODE_POINTS)
    fig, (ax_mag, ax_phase) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 6.0))
    for plant, output, inp in curves:
        response = plant.frequency_response(omega, output, inp)
        gain = plant.dc_gain(output, inp)
        magnitude = 20.0 * np.log10(np.abs(response) / abs(gain))
        phase = np.degrees(np.unwrap(np.angle(response)) - omega * plant.dead_time)
        if gain < 0.0:  # a negative gain is drawn as a sign flip, not a 180 deg lag
            phase = phase - 180.0 * np.round(phase[0] / 180.0)
        unit = f'{OUTPUT_UNITS[output]}/{INPUT_UNITS[inp]}'
        label = f'{inp} -> {output}: DC {gain:.4g} {unit}'
        ax_mag.semilogx(omega, magnitude, label=label)
        ax_phase.semilogx(omega, phase, label=label)
    first = curves[0][0]
    corner = 1.0 / first.thermal_time_constant()
    for ax in (ax_mag, ax_phase):
        ax.axvline(corner, color='0.5', ls=':', lw=0.8)
        ax.grid(True, which='both', lw=0.3)
    ax_mag.axhline(-3.0, color='0.5', ls='--', lw=0.8)
    ax_mag.text(corner, -3.0, ' 1/tau thermal', fontsize=7, va='bottom')
    ax_mag.set_ylabel('|G(jw)| / |G(0)| (dB)')
    ax_mag.set_ylim(-120.0, 10.0)
    ax_phase.set_ylabel('phase (deg)')
    ax_phase.set_xlabel('angular frequency w (rad/s)')
    ax_mag.legend(fontsize=7, loc='lower left')
    ax_mag.set_title(title, fontsize=9)
    fig.tight_layout()
    return fig


def save_bode(curves, path, title=''):
    """Write the Bode figure of ``curves`` (see bode_figure) to ``path`` (PNG)."""
    import matplotlib.pyplot as plt
    fig = bode_figure(curves, title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def save_task_plot(run, path, title=''):
    """Write a PNG of one scored run: reference and displacement, temperature, power.

    ``run`` is a dict of tca_ros.toolkit.scoring.run_task (SI units, degC).
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    t = run['time']
    fig, axes = plt.subplots(3, 1, sharex=True, figsize=(7.5, 6.0))
    axes[0].plot(t, 1e3 * run['reference'], 'k--', label='reference')
    axes[0].plot(t, 1e3 * run['displacement'], label='displacement')
    axes[0].set_ylabel('contraction (mm)')
    axes[0].legend(fontsize=7, loc='upper right')
    axes[1].plot(t, run['temperature'], color='tab:red')
    axes[1].set_ylabel('temperature (degC)')
    axes[2].step(t, run['power'], where='post', color='tab:orange')
    axes[2].set_ylabel('power (W)')
    axes[2].set_xlabel('time (s)')
    for ax in axes:
        ax.grid(True, lw=0.3)
    axes[0].set_title(title or run['task'], fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
