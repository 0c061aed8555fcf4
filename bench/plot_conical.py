"""The conical TCA hanging from its apex clamp: end height vs temperature, a dynamic run.

    python bench/plot_conical.py [--out docs]

writes fig_conical.png and fig_conical.csv (the numbers docs/rod.md quotes;
test/test_conical.py pins them). Statics: the rod model's hanging equilibria
(model/conical.py) at 0, 2 and 10 g; dynamics: eq. (18) on the conical rod table
with a 0.3 W heating step (no load, the 0.5 g end marker), then cooling.
"""
import argparse
import os

import numpy as np

from tca_ros.model.conical import conical_end_height
from tca_ros.model.simulation import simulate
from tca_ros.params.files import load_params

GRAVITY = 9.81  # m/s^2
MASSES = (0.0, 0.002, 0.010)  # kg hanging from the free end
TEMPERATURES = np.arange(25.0, 251.0, 15.0)  # degC, to the node's melt limit
POWER = 0.3  # W, heating step of the dynamic run
HEAT = 20.0  # s of heating
TOTAL = 40.0  # s of the run
SAMPLE = 0.1  # s between samples


def statics_heights(masses=MASSES, temperatures=TEMPERATURES):
    """Return {mass (kg): end height (m) per temperature} (clamp at 0, Z up)."""
    params = load_params('conical')
    return {m: conical_end_height(params, temperatures, load=m * GRAVITY) for m in masses}


def dynamic_case(total=TOTAL):
    """Return (time (s), temperature (degC), end height (m)) of the heating step."""
    params = load_params('conical')
    time = np.arange(0.0, total + 0.5 * SAMPLE, SAMPLE)
    power = np.where(time < HEAT, POWER, 0.0)
    res = simulate(params, time, power)
    height0 = -float(conical_end_height(params, [25.0])[0])  # drop at rest, no load
    return time, res.temperature, -(height0 - res.true_displacement)


def write_csv(path, heights, dynamic):
    """Write the figure's numbers: statics rows, then dynamic rows."""
    with open(path, 'w', encoding='utf-8') as fh:
        fh.write('kind,mass_or_time,temperature,end_height\n')
        for mass, values in heights.items():
            for temp, h in zip(TEMPERATURES, values):
                fh.write(f'statics,{mass:g},{temp:g},{h:.6e}\n')
        for t, temp, h in zip(*dynamic):
            fh.write(f'dynamic,{t:.3f},{temp:.6f},{h:.6e}\n')


def plot(path, heights, dynamic):
    """Plot the statics and the dynamic run side by side."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    for mass, values in heights.items():
        ax1.plot(TEMPERATURES, values * 1e3, 'o-', ms=3, label=f'{mass * 1e3:g} g')
    ax1.axhline(0.0, color='k', lw=0.6)
    ax1.set_xlabel('temperature (degC)')
    ax1.set_ylabel('free end height above the clamp (mm)')
    ax1.set_title('conical TCA hanging from its apex: statics')
    ax1.legend()
    t, temp, h = dynamic
    ax2.plot(t, h * 1e3, 'b-', label='end height (mm)')
    ax2.set_xlabel('time (s)')
    ax2.set_ylabel('end height (mm)', color='b')
    twin = ax2.twinx()
    twin.plot(t, temp, 'r--', label='temperature')
    twin.set_ylabel('temperature (degC)', color='r')
    ax2.set_title(f'dynamics (18): {POWER:g} W for {HEAT:g} s, no load')
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None):
    """Compute, write the CSV and the PNG."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', default='docs')
    args = parser.parse_args(argv)
    heights = statics_heights()
    dynamic = dynamic_case()
    write_csv(os.path.join(args.out, 'fig_conical.csv'), heights, dynamic)
    plot(os.path.join(args.out, 'fig_conical.png'), heights, dynamic)
    for mass, values in heights.items():
        cells = [f'{t:g} degC {h * 1e3:.1f} mm' for t, h in zip(TEMPERATURES, values)]
        print(f'{mass * 1e3:g} g: ' + ', '.join(cells))
    t, temp, h = dynamic
    for k in (0, int(5 / SAMPLE), int(HEAT / SAMPLE), len(t) - 1):
        print(f't = {t[k]:g} s: {temp[k]:.1f} degC, end height {h[k] * 1e3:.2f} mm')


if __name__ == '__main__':
    main()
