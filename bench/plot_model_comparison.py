"""Draw docs/fig_model_comparison.png: rod vs CST vs Love, like Fig. 10 of [1].

Contraction under a hanging weight while the temperature rises 25 -> 160 degC, for
the self-coiled TCA (50/100/200 g) and the free-stroke TCA (2/30/60 g), from the
three kinetostatic models (coil contact included, as in the simulator). Markers:
the full-length rod BVP (Algorithm 1) for the middle load, a check of the rod
model's exact-helix fast path. Usage: ``python bench/plot_model_comparison.py
[--out docs/fig_model_comparison.png]``.
"""
import argparse
import os

import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tca_ros.model.kinetostatics import contact_elongation  # noqa: E402
from tca_ros.model.params_schema import GRAVITY  # noqa: E402
from tca_ros.model.rod_model import rod_statics_sweep, solution_elongation  # noqa: E402
from tca_ros.model.simulation import static_displacement  # noqa: E402
from tca_ros.params.files import load_params  # noqa: E402

CASES = (('self_coiled', (0.050, 0.100, 0.200)), ('free_stroke', (0.002, 0.030, 0.060)))
STYLES = {'rod': '-', 'cst': '--', 'love': ':'}


def plot_case(ax, name, masses, temps, bvp_temps):
    """Plot contraction (mm) vs temperature (degC) for one TCA; return the artists."""
    params = load_params(name)
    artists = []
    colors = plt.rcParams['axes.prop_cycle'].by_key()['color']
    for color, mass in zip(colors, masses):
        load = mass * GRAVITY
        for model, style in STYLES.items():
            x = static_displacement(params, load, temps, model=model)
            artists += ax.plot(temps, 1e3 * x, style, color=color,
                               label=f'{model} {1e3 * mass:g} g')
    load = masses[1] * GRAVITY
    sols = rod_statics_sweep(params, load, bvp_temps)
    stop = contact_elongation(params)
    ys = np.array([max(solution_elongation(params, s), stop) if s.success else np.nan
                   for s in sols])
    artists += ax.plot(bvp_temps, 1e3 * (ys[0] - ys), 'o', color=colors[1], mfc='none',
                       label=f'rod full BVP {1e3 * masses[1]:g} g')
    ax.set_title(f'{name.replace("_", "-")} TCA')
    ax.set_xlabel('temperature (degC)')
    ax.set_ylabel('contraction from loaded length at 25 degC (mm)')
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    return artists


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = os.path.dirname(os.path.abspath(__file__))
    parser.add_argument('--out', default=os.path.join(here, '..', 'docs',
                                                      'fig_model_comparison.png'),
                        help='output PNG path')
    args = parser.parse_args(argv)
    temps = np.linspace(25.0, 160.0, 136)  # degC, 1 K
    bvp_temps = np.arange(25.0, 160.0 + 1e-9, 15.0)  # degC
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True)
    for ax, (name, masses) in zip(axes, CASES):
        plot_case(ax, name, masses, temps, bvp_temps)
    fig.savefig(args.out, dpi=120)
    print(f'wrote {os.path.normpath(args.out)}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
