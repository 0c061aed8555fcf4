"""Benchmark the load rigs: simulated seconds per wall (and CPU) second at 1 kHz.

The targets (issue 11) are the antagonistic pair at >= 50x real time with the rod
model and the conical TCA (rod table) at >= 10x; the other rigs and models are
printed beside them (the conical rows beside the free-stroke rod rows). Each run heats with 1 W
for half the span and cools for the rest (the pair: agonist, then antagonist).
Wall time counts what a user waits on a shared machine, CPU time (process time)
what the code costs. Usage: ``python bench/bench_rigs.py [--seconds 20]``.
"""
import argparse
import time

from tca_ros.model.rigs import make_rig
from tca_ros.params.files import load_params

RIGS = ('dead_weight', 'spring', 'isometric', 'antagonistic')
MODELS = ('rod', 'cst', 'love')
TARGET = 50.0  # x real time, antagonistic pair (issue 11)
CONICAL_TARGET = 10.0  # x real time, conical TCA dynamics (issue 11)


def run(mode, model, seconds, physics_rate=1000.0, config='free_stroke'):
    """Return (wall s, CPU s) of ``seconds`` simulated on rig ``mode`` with ``model``."""
    params = load_params(config, model=model, **{'rig.mode': mode})
    sim = make_rig(params, dt=1.0 / physics_rate)
    steps = int(round(seconds * physics_rate))
    half = steps // 2
    wall, cpu = time.perf_counter(), time.process_time()
    for i in range(steps):
        if mode == 'antagonistic':
            sim.step(1.0 if i < half else 0.0, power_2=0.0 if i < half else 1.0)
        else:
            sim.step(1.0 if i < half else 0.0)
    return time.perf_counter() - wall, time.process_time() - cpu


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=20.0, help='simulated time (s)')
    args = parser.parse_args(argv)
    for model in MODELS:  # build the rod table before timing (cached afterwards)
        make_rig(load_params('free_stroke', model=model))
    print(f'# rigs of the free-stroke TCA, physics 1 kHz, {args.seconds:g} s simulated, '
          'one core')
    print(f'{"rig":<13} {"model":<6} {"us/step":>8} {"x real (wall)":>14} '
          f'{"x real (CPU)":>13}')
    for mode in RIGS:
        for model in MODELS:
            wall, cpu = run(mode, model, args.seconds)
            print(f'{mode:<13} {model:<6} {1e6 * cpu / (args.seconds * 1000):>8.1f} '
                  f'{args.seconds / wall:>14.1f} {args.seconds / cpu:>13.1f}')
    print(f'# target: antagonistic pair (rod) >= {TARGET:g}x real time')
    bench_conical(args.seconds)


def bench_conical(seconds):
    """Print the conical TCA's rigs (rod table) beside the free-stroke rod model."""
    from tca_ros.model.kinetostatic_models import make_kinetostatic_model
    start = time.perf_counter()
    rows = make_kinetostatic_model(load_params('conical')).table.build_all()
    print(f'# conical rod table: {rows} rows ready in {time.perf_counter() - start:.1f} s '
          '(built once per parameter set, then read from the disk cache)')
    print(f'{"rig":<13} {"TCA":<12} {"us/step":>8} {"x real (wall)":>14} '
          f'{"x real (CPU)":>13}')
    for mode in RIGS:
        for config in ('free_stroke', 'conical'):
            wall, cpu = run(mode, 'rod', seconds, config=config)
            print(f'{mode:<13} {config:<12} {1e6 * cpu / (seconds * 1000):>8.1f} '
                  f'{seconds / wall:>14.1f} {seconds / cpu:>13.1f}')
    print(f'# target: conical TCA (rod) >= {CONICAL_TARGET:g}x real time')


if __name__ == '__main__':
    main()
