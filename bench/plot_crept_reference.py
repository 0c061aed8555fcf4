"""Draw docs/fig_crept_reference.png: Fig. 10(c) of [1] with both reference readings.

Contraction of the free-stroke TCA under a hanging weight (2, 30, 60 g) while the
temperature rises 25 -> 160 degC, from the rod model with coil contact, once from
Table III's reference (alpha* = 22.42 deg for every weight, the default) and once
from the reference crept under each weight (``coil.crept_reference``: alpha*(F) of
tca_ros/model/reference_state.py, 15.6/20.2/21.8 deg). Prints the figures pinned by
test/test_crept_reference.py. Usage: ``python bench/plot_crept_reference.py
[--out docs/fig_crept_reference.png]``.
"""
import argparse
import math
import os

import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tca_ros.model.kinetostatic_models import make_kinetostatic_model  # noqa: E402
from tca_ros.model.kinetostatics import contact_elongation  # noqa
from tca_ros.model.params_schema import GRAVITY  # noqa: E402
from tca_ros.model.reference_state import crept_under  # noqa: E402
from tca_ros.model.simulation import static_displacement  # noqa: E402
from tca_ros.params.files import load_params  # noqa: E402

MASSES = (0.002, 0.030, 0.060)  # kg, the free-stroke weights of Fig. 10(c)
READINGS = (('Table III', False), ('crept', True))


def reading_params(crept, mass):
    """Return the free-stroke params for a weight (kg), crept under it or not."""
    base = load_params('free_stroke').with_values(**{'coil.crept_reference': crept})
    return crept_under(base, mass * GRAVITY)


def contact_onset(params, load, temps, model='rod'):
    """Return the first temperature (degC) at which the coils touch, or nan."""
    km = make_kinetostatic_model(params, model)
    stop = contact_elongation(params)
    for temp in temps:
        if km.equilibrium_elongation(load, float(temp)) < stop:
            return float(temp)
    return math.nan


def main(argv=None):
    """Draw the figure and print contraction at 160 degC and contact onset per case."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = os.path.dirname(os.path.abspath(__file__))
    parser.add_argument('--out', default=os.path.join(here, '..', 'docs',
                                                      'fig_crept_reference.png'),
                        help='output PNG path')
    args = parser.parse_args(argv)
    temps = np.arange(25.0, 160.5, 1.0)  # degC
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    colors = plt.rcParams['axes.prop_cycle'].by_key()['color']
    print(f'{"reading":10s} {"mass":>6s} {"alpha*":>8s} {"x(160)":>8s} {"contact from":>13s}')
    for (label, crept), style in zip(READINGS, ('--', '-')):
        for color, mass in zip(colors, MASSES):
            params = reading_params(crept, mass)
            load = mass * GRAVITY
            x = static_displacement(params, load, temps, model='rod')
            onset = contact_onset(params, load, temps)
            alpha = math.degrees(params.coil.pitch_angle)
            ax.plot(temps, 1e3 * x, style, color=color,
                    label=f'{label} {1e3 * mass:g} g (alpha* {alpha:.1f} deg)')
            if math.isfinite(onset):
                ax.plot(onset, 1e3 * np.interp(onset, temps, x), 'o', color=color, mfc='none')
            print(f'{label:10s} {1e3 * mass:4g} g {alpha:6.2f}'
                  f'   {1e3 * x[-1]:6.2f} mm  {onset:8.0f} degC')
    ax.set_xlabel('temperature (degC)')
    ax.set_ylabel('contraction from loaded length at 25 degC (mm)')
    ax.set_title('free-stroke TCA, rod model: reference as coiled vs crept (o: coils touch)',
                 fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    plt.close(fig)
    print(f'wrote {os.path.normpath(args.out)}')


if __name__ == '__main__':
    main()
