"""Main job without ROS: statics and a dynamics run of a TCA, as a table and a plot."""
import os

import numpy as np

from tca_ros.model.params_schema import GRAVITY, MODELS
from tca_ros.model.simulation import simulate, static_displacement
from tca_ros.params.files import load_params

DEMO_MASSES = (0.002, 0.03, 0.06)  # kg, the free-stroke weights of Fig. 10 [1]
DEMO_TEMPS = np.arange(25.0, 160.0 + 1e-9, 5.0)  # degC, Sec. V-D2


def run_statics_demo(config, out_dir, out):
    """Write statics.png and dynamics.png to ``out_dir`` and print the tables to ``out``."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    p = load_params(config)
    models = MODELS
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    out.write(f'Statics of the {p.tca_type} TCA: contraction (mm) at 160 degC\n')
    out.write(f'{"mass (g)":>9}' + ''.join(f'{m:>9}' for m in models) + '\n')
    for mass in DEMO_MASSES:
        row = f'{mass * 1e3:>9.0f}'
        for j, name in enumerate(models):
            x = static_displacement(p, mass * GRAVITY, DEMO_TEMPS, model=name)
            row += f'{x[-1] * 1e3:>9.2f}'
            axes[0].plot(DEMO_TEMPS, x * 1e3, ('-', '--', ':')[j % 3],
                         color={0.002: 'C0', 0.03: 'C1', 0.06: 'C2'}.get(mass, 'k'),
                         label=f'{name} {mass * 1e3:.0f} g')
        out.write(row + '\n')
    axes[0].set_xlabel('temperature (degC)')
    axes[0].set_ylabel('contraction (mm)')
    axes[0].set_title('Statics (hanging weight)')
    axes[0].legend(fontsize=7, ncol=2)

    t = np.arange(0.0, 40.0 + 1e-9, 0.01)
    power = np.where(t < 20.0, 1.0, 0.0)
    out.write(f'\nDynamics: 1 W for 20 s then off, {p.dynamics.mass * 1e3:.0f} g\n')
    out.write(f'{"model":>6} {"T max (degC)":>13} {"x max (mm)":>11} {"x(40 s) (mm)":>13} '
              f'{"R min (ohm)":>12}\n')
    ax2 = axes[1].twinx()
    for j, name in enumerate(models):
        r = simulate(p, t, power, model=name)
        out.write(f'{name:>6} {r.temperature.max():>13.1f} {r.displacement.max() * 1e3:>11.2f}'
                  f' {r.displacement[-1] * 1e3:>13.3f} {r.resistance.min():>12.2f}\n')
        axes[1].plot(t, r.displacement * 1e3, ('-', '--', ':')[j % 3], label=name)
        if j == 0:
            ax2.plot(t, r.temperature, color='C3', alpha=0.5, label='temperature')
    axes[1].set_xlabel('time (s)')
    axes[1].set_ylabel('contraction (mm)')
    ax2.set_ylabel('temperature (degC)', color='C3')
    axes[1].set_title('Dynamics: 1 W step, eq. (1) + (18)')
    axes[1].legend(fontsize=8, loc='upper left')
    fig.tight_layout()
    path = os.path.join(out_dir, 'statics_dynamics.png')
    fig.savefig(path, dpi=110)
    plt.close(fig)
    out.write(f'\nwrote {path}\n')
    return path
