"""Benchmark of the batch simulator (printed, not asserted): muscle-steps per second.

For N = 1, 100, 10,000 muscles and the cst and rod models: tca_ros.toolkit.batch
stepping all N at once with NumPy, beside a Python loop over N scalar
TcaSimulators (the node's stepper), one physics step of 1 ms each. The muscles
differ in load (0.1-0.6 N), convection (15-30 W/(m^2 K)) and mass (20-60 g);
they share one mechanics, so the rod model builds one table. One core
(BLAS threads pinned to 1; the stepping is element-wise NumPy).

Usage: python bench/bench_batch.py [--sizes 1,100,10000] [--seconds 1.0]
"""
import argparse
from dataclasses import replace
import os
import time

os.environ.setdefault('OMP_NUM_THREADS', '1')
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

import numpy as np  # noqa: E402

from tca_ros.model.dynamics import TcaSimulator  # noqa: E402
from tca_ros.model.kinetostatic_models import make_kinetostatic_model  # noqa: E402
from tca_ros.params.files import load_params  # noqa: E402
from tca_ros.toolkit.batch import BatchSimulator  # noqa: E402

POWER = 1.0  # W, held: the muscles heat towards 100 degC


def muscles(base, n, seed=0):
    """Return n parameter sets that differ in load, convection and mass."""
    rng = np.random.default_rng(seed)
    out = []
    for load, h, mass in zip(rng.uniform(0.1, 0.6, n), rng.uniform(15.0, 30.0, n),
                             rng.uniform(0.02, 0.06, n)):
        out.append(replace(base, thermal=replace(base.thermal, convection_coefficient=h),
                           dynamics=replace(base.dynamics, load=load, mass=mass)))
    return out


def time_batch(group, model, seconds):
    """Return (build s, muscle-steps/s) of BatchSimulator over ~``seconds``."""
    t0 = time.perf_counter()
    sim = BatchSimulator(group, model=model, dt=1e-3)
    build = time.perf_counter() - t0
    power = np.full(len(group), POWER)
    steps, wall = 0, 0.0
    t0 = time.perf_counter()
    while wall < seconds:
        for _ in range(10):
            sim.step(power)
        steps += 10
        wall = time.perf_counter() - t0
    return build, len(group) * steps / wall


def time_scalar(group, model, seconds):
    """Return (build s, muscle-steps/s) of a loop over scalar TcaSimulators."""
    t0 = time.perf_counter()
    shared = make_kinetostatic_model(group[0], model)  # one mechanics: one f_rod model
    sims = [TcaSimulator(p, model=model, dt=1e-3, kinetostatics=shared) for p in group]
    build = time.perf_counter() - t0
    steps, wall = 0, 0.0
    t0 = time.perf_counter()
    while wall < seconds:
        for sim in sims:
            sim.step(POWER)
        steps += 1
        wall = time.perf_counter() - t0
    return build, len(group) * steps / wall


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--sizes', default='1,100,10000', help='numbers of muscles N')
    parser.add_argument('--seconds', type=float, default=1.0,
                        help='wall time per measurement (s)')
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(',')]
    base = load_params('free_stroke')
    print('# muscle-steps/s (1 ms physics steps), free-stroke muscles differing in load, '
          'convection and mass; one core')
    print(f'{"model":<6} {"N":>6} {"batch":>12} {"scalar loop":>12} {"speed-up":>9} '
          f'{"batch build (s)":>16} {"scalar build (s)":>17}')
    for model in ('cst', 'rod'):
        make_kinetostatic_model(base, model)  # the rod table, built once (cached)
        for n in sizes:
            group = muscles(base, n)
            b_build, b_rate = time_batch(group, model, args.seconds)
            s_build, s_rate = time_scalar(group, model, args.seconds)
            print(f'{model:<6} {n:>6} {b_rate:>12.4g} {s_rate:>12.4g} {b_rate / s_rate:>9.3g} '
                  f'{b_build:>16.3g} {s_build:>17.3g}', flush=True)


if __name__ == '__main__':
    main()
