"""Benchmark the Cosserat rod model against CST and Love (issue 3, item 7).

Prints one side-by-side table: a full free-stroke BVP solve (63 coils) cold and
warm-started, a statics sweep 25 -> 160 degC in 5 K steps under 30 g, one f_rod
evaluation, and simulated seconds per wall second of the dynamics (18) at 1 kHz.
Figures, not assertions: run ``python bench/bench_rod.py``.
"""
import argparse
import time
import timeit

import numpy as np

from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.params_schema import GRAVITY
from tca_ros.model.rod_model import rod_reference, rod_statics_sweep, stiffness_vector
from tca_ros.model.simulation import simulate, static_displacement
from tca_ros.params.files import load_params
from tca_ros.rod.statics import solve_rod_statics

TARGETS = {'bvp_warm': 50e-3, 'sweep': 2.0, 'frod': 20e-6, 'realtime': 50.0}


def _best(fn, repeat):
    """Return the best wall time (s) of ``repeat`` calls of ``fn``."""
    return min(timeit.repeat(fn, number=1, repeat=repeat))


def bench_bvp(params, load, repeat):
    """Return (cold s, warm-load s, warm-temperature s, iterations) of the full BVP."""
    offset = (params.coil.radius, 0.0, 0.0)
    ref = rod_reference(params, 25.0)
    K = stiffness_vector(params, 25.0, load)
    force = np.array([0.0, 0.0, -load])
    solve = solve_rod_statics(ref, K, end_force=force, end_load_offset=offset)
    cold = _best(lambda: solve_rod_statics(ref, K, end_force=force,
                                           end_load_offset=offset), repeat)
    force2 = 1.02 * force
    warm = _best(lambda: solve_rod_statics(ref, K, end_force=force2, end_load_offset=offset,
                                           initial=solve), repeat)
    ref30 = rod_reference(params, 30.0)
    K30 = stiffness_vector(params, 30.0, load)
    warm_t = _best(lambda: solve_rod_statics(ref30, K30, end_force=force,
                                             end_load_offset=offset, initial=solve), repeat)
    n = solve_rod_statics(ref30, K30, end_force=force, end_load_offset=offset,
                          initial=solve)
    return cold, warm, warm_t, (solve.n_iter, n.n_iter, solve.s.size - 1)


def bench_model(params, name, load, temps, repeat):
    """Return (sweep s, f_rod s, simulated s per wall s) of one kinetostatic model."""
    t0 = time.perf_counter()
    model = make_kinetostatic_model(params, name)
    build = time.perf_counter() - t0
    sweep = _best(lambda: static_displacement(params, load, temps, kinetostatics=model),
                  repeat)
    y = model.equilibrium_elongation(load, 90.0)
    n_eval = 20000
    frod = min(timeit.repeat(lambda: model.tension(y, 90.0, load), number=n_eval,
                             repeat=repeat)) / n_eval
    horizon = 2.0  # s simulated at 1 kHz: 2000 steps
    t = np.linspace(0.0, horizon, 201)
    power = np.where(t < 1.0, 1.0, 0.0)  # W, heat then cool
    wall = _best(lambda: simulate(params, t, power, load=np.full_like(t, load),
                                  physics_rate=1000.0, kinetostatics=model), repeat)
    return build, sweep, frod, horizon / wall


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--repeat', type=int, default=3, help='timing repeats (best of)')
    args = parser.parse_args(argv)
    params = load_params('free_stroke')
    load = 0.030 * GRAVITY  # N, 30 g
    temps = np.arange(25.0, 160.0 + 1e-9, 5.0)  # degC
    t0 = time.perf_counter()
    sols = rod_statics_sweep(params, load, temps)
    bvp_sweep = time.perf_counter() - t0
    cold, warm, warm_t, iters = bench_bvp(params, load, args.repeat)
    rows = {name: bench_model(params, name, load, temps, args.repeat)
            for name in ('rod', 'cst', 'love')}
    print(f'free-stroke TCA, 30 g, {len(temps)} temperatures 25-160 degC, 1 kHz dynamics')
    print(f'full BVP: {iters[2]} intervals (8 per coil), 13 unknowns per node; '
          f'Newton iterations cold {iters[0]}, warm {iters[1]}; '
          f'sweep all converged: {all(s.success for s in sols)}')
    header = f'{"figure":44s} {"target":>10s} {"rod":>12s} {"cst":>12s} {"love":>12s}'
    print(header)
    print('-' * len(header))

    def line(label, target, values, fmt):
        cells = ''.join(f'{fmt(v):>13s}' if v is not None else f'{"-":>13s}'
                        for v in values)
        print(f'{label:44s} {target:>10s}{cells}')
    ms = lambda v: f'{v * 1e3:.1f} ms'  # noqa: E731
    us = lambda v: f'{v * 1e6:.2f} us'  # noqa: E731
    line('full BVP solve, cold (63 coils)', '-', [cold, None, None], ms)
    line('full BVP solve, warm (load +2 %)', '<= 50 ms', [warm, None, None], ms)
    line('full BVP solve, warm (T +5 K)', '<= 50 ms', [warm_t, None, None], ms)
    line('BVP statics sweep 25->160 degC (Alg. 1)', '<= 2 s', [bvp_sweep, None, None],
         lambda v: f'{v:.2f} s')
    line('model build (rod: exact-helix table)', '-', [r[0] for r in rows.values()], ms)
    line('model statics sweep 25->160 degC', '<= 2 s', [r[1] for r in rows.values()], ms)
    line('one f_rod evaluation', '<= 20 us', [r[2] for r in rows.values()], us)
    line('dynamics (18) at 1 kHz, sim s / wall s', '>= 50x', [r[3] for r in rows.values()],
         lambda v: f'{v:.0f}x')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
