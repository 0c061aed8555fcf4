"""Draw the rig figures of docs/rigs.md (free-stroke TCA, tca_ros.model.rigs).

- docs/fig_rig_spring.png: the spring rig of Case 2 (Fig. 11 of [1]): 1 W for 20 s,
  then cooling; temperature, TCA force and contraction for rod, CST and Love, with
  the statics (the force curve meets the spring line) at the temperatures reached;
- docs/fig_rig_isometric.png: the force of the clamped TCA vs heating power, at
  steady state (statics) and after 30 s of simulation;
- docs/fig_rig_antagonistic.png: the pulley joint under a step of the agonist, then
  of the antagonist (co-contraction), then the agonist off, with the statics angle.

The data functions return the numbers the figures show (test/test_rig_figures.py
pins them). Usage: ``python bench/plot_rigs.py [--out docs]``.
"""
import argparse
import os

import numpy as np

from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.rig_simulation import simulate_rig
from tca_ros.model.rig_statics import antagonistic_rest_angle, isometric_force
from tca_ros.model.rig_statics import spring_rest_state
from tca_ros.model.thermal import steady_state_temperature
from tca_ros.params.files import load_params

MODELS = ('rod', 'cst', 'love')
SAMPLE = 0.1  # s between output samples
STATICS_TIMES = (5.0, 10.0, 20.0, 25.0, 30.0, 40.0)  # s, where the statics are marked


def _params(model, mode):
    return load_params('free_stroke', model=model, **{'rig.mode': mode})


def spring_case(model, heat=20.0, total=40.0, power=1.0):
    """Return the spring rig's run and its statics at STATICS_TIMES.

    Returns
    -------
    dict
        time (s), temperature (degC), force (N), displacement (m) arrays; and
        statics_time (s), statics_displacement (m), statics_force (N).
    """
    params = _params(model, 'spring')
    t = np.arange(0.0, total + 1e-9, SAMPLE)
    out = simulate_rig(params, t, np.where(t < heat, power, 0.0)).columns
    km = make_kinetostatic_model(params)
    idx = [int(round(s / SAMPLE)) for s in STATICS_TIMES]
    rest = [spring_rest_state(km, out['temperature'][i], params.rig.pretension,
                              params.rig.spring_stiffness) for i in idx]
    return dict(time=t, temperature=out['temperature'], force=out['force'],
                displacement=out['displacement'], statics_time=t[idx],
                statics_displacement=np.array([r[0] for r in rest]),
                statics_force=np.array([r[1] for r in rest]))


def isometric_curve(model, powers, seconds=30.0):
    """Return (steady force (N), simulated force after ``seconds`` (N)) per power (W)."""
    params = _params(model, 'isometric')
    km = make_kinetostatic_model(params)
    temps = [steady_state_temperature(p, params.fiber, params.thermal) for p in powers]
    steady = np.array([isometric_force(km, temp, params.rig.pretension) for temp in temps])
    t = np.arange(0.0, seconds + 1e-9, 0.5)
    # the clamped end has no mechanical limit and eq. (1) is exact: 100 Hz suffices
    simulated = np.array([simulate_rig(params, t, np.full_like(t, p),
                                       physics_rate=100.0).columns['force'][-1]
                          for p in powers])
    return steady, simulated


def antagonistic_case(model='rod', total=40.0):
    """Return the pair's run (agonist 1 W on 1-21 s, antagonist 1 W on 11-31 s).

    Returns
    -------
    dict
        time (s), power, power_2 (W), temperature, temperature_2 (degC), angle (rad),
        force, force_2 (N); statics_time (s), statics_angle (rad) at STATICS_TIMES.
    """
    params = _params(model, 'antagonistic')
    t = np.arange(0.0, total + 1e-9, SAMPLE)
    power = np.where((t >= 1.0) & (t < 21.0), 1.0, 0.0)
    power_2 = np.where((t >= 11.0) & (t < 31.0), 1.0, 0.0)
    out = simulate_rig(params, t, power, power_2=power_2).columns
    km = make_kinetostatic_model(params)
    idx = [int(round(s / SAMPLE)) for s in STATICS_TIMES]
    angles = [antagonistic_rest_angle(km, out['temperature'][i], out['temperature_2'][i],
                                      params.rig.pretension, params.rig.pulley_radius)[0]
              for i in idx]
    return dict(out, statics_time=t[idx], statics_angle=np.array(angles))


def plot_spring(path):
    """Draw docs/fig_rig_spring.png."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for model, style in zip(MODELS, ('-', '--', ':')):
        c = spring_case(model)
        if model == 'rod':
            axes[0].plot(c['time'], c['temperature'], 'k-')
        axes[1].plot(c['time'], c['force'], style, label=model)
        axes[2].plot(c['time'], 1e3 * c['displacement'], style, label=model)
        if model == 'rod':
            axes[1].plot(c['statics_time'], c['statics_force'], 'ko', mfc='none',
                         label='statics (rod)')
            axes[2].plot(c['statics_time'], 1e3 * c['statics_displacement'], 'ko',
                         mfc='none', label='statics (rod)')
    axes[0].set_ylabel('temperature (degC)')
    axes[1].set_ylabel('TCA force (N)')
    axes[2].set_ylabel('contraction (mm)')
    titles = ('1 W for 20 s, then off', 'force on the spring line', 'spring stretch')
    for ax, title in zip(axes, titles):
        ax.set_xlabel('time (s)')
        ax.set_title(title)
        ax.grid(True, alpha=0.3)
    axes[2].legend(fontsize=8)
    fig.suptitle('spring rig: k_s = 20 N/m, pretension 0.05 N (free-stroke TCA)')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_isometric(path):
    """Draw docs/fig_rig_isometric.png."""
    import matplotlib.pyplot as plt
    powers = np.linspace(0.0, 2.0, 9)
    fig, ax = plt.subplots(figsize=(6, 4))
    for model, style in zip(MODELS, ('-', '--', ':')):
        steady, simulated = isometric_curve(model, powers)
        line, = ax.plot(powers, steady, style, label=f'{model} statics')
        ax.plot(powers, simulated, 'o', color=line.get_color(), mfc='none',
                label=f'{model} after 30 s')
    ax.set_xlabel('heating power (W)')
    ax.set_ylabel('isometric force (N)')
    ax.set_title('clamped at its length under 0.05 N (free-stroke TCA)')
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_antagonistic(path):
    """Draw docs/fig_rig_antagonistic.png."""
    import matplotlib.pyplot as plt
    c = antagonistic_case()
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    axes[0].plot(c['time'], c['temperature'], label='agonist')
    axes[0].plot(c['time'], c['temperature_2'], label='antagonist')
    axes[0].set_ylabel('temperature (degC)')
    axes[1].plot(c['time'], c['force'], label='agonist')
    axes[1].plot(c['time'], c['force_2'], '--', label='antagonist')
    axes[1].set_ylabel('tendon force (N)')
    axes[2].plot(c['time'], c['angle'], 'k-', label='dynamics (rod)')
    axes[2].plot(c['statics_time'], c['statics_angle'], 'ro', mfc='none',
                 label='statics of both muscles')
    axes[2].set_ylabel('joint angle (rad)')
    titles = ('agonist 1 W 1-21 s, antagonist 1 W 11-31 s', 'co-contraction stiffens',
              'joint step')
    for ax, title in zip(axes, titles):
        ax.set_xlabel('time (s)')
        ax.set_title(title, fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle('antagonistic pair: pulley 10 mm, J = 1e-5 kg m^2, pretension 0.05 N')
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = os.path.dirname(os.path.abspath(__file__))
    parser.add_argument('--out', default=os.path.join(here, '..', 'docs'),
                        help='output directory of the PNGs')
    args = parser.parse_args(argv)
    import matplotlib
    matplotlib.use('Agg')
    plot_spring(os.path.join(args.out, 'fig_rig_spring.png'))
    plot_isometric(os.path.join(args.out, 'fig_rig_isometric.png'))
    plot_antagonistic(os.path.join(args.out, 'fig_rig_antagonistic.png'))


if __name__ == '__main__':
    main()
