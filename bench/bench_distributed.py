"""Benchmark of the distributed batch runner (printed, not asserted).

A statics sweep over coil designs (free-stroke TCA, pitch angle 18-26 deg, CST and rod,
25-160 degC in 1 K steps), run three ways: a serial loop, the standard library's
process pool, and tca_ros.toolkit.distributed on a Dask LocalCluster of processes
(cluster start-up timed apart). Same worker count for both pools.

Usage: python bench/bench_distributed.py [--designs 16] [--workers 2]
"""
import argparse
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
import math
import time

import numpy as np

from tca_ros.params.files import load_params
from tca_ros.toolkit import distributed

TEMPS = np.arange(25.0, 160.1, 1.0)  # degC
LOAD = 0.2943  # N (30 g)


def jobs(n, model):
    base = load_params('free_stroke')
    return [(replace(base, coil=replace(base.coil, pitch_angle=math.radians(a))), LOAD, TEMPS,
             model) for a in np.linspace(18.0, 26.0, n)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--designs', type=int, default=16, help='number of designs')
    parser.add_argument('--workers', type=int, default=2, help='worker processes')
    args = parser.parse_args()
    print(f'# statics sweep: {args.designs} designs x {TEMPS.size} temperatures, '
          f'{args.workers} workers (wall s)')
    print(f'{"model":<6} {"serial":>8} {"process pool":>13} {"dask local":>11} '
          f'{"dask start-up":>14}')
    for model in ('cst', 'rod'):
        work = jobs(args.designs, model)
        t0 = time.perf_counter()
        serial = [distributed.statics_job(j) for j in work]
        t_serial = time.perf_counter() - t0
        t0 = time.perf_counter()
        with ProcessPoolExecutor(args.workers) as pool:
            pooled = list(pool.map(distributed.statics_job, work))
        t_pool = time.perf_counter() - t0
        t0 = time.perf_counter()
        with distributed.dask_client(n_workers=args.workers) as client:
            t_start = time.perf_counter() - t0
            t0 = time.perf_counter()
            dasked = distributed.run_many(distributed.statics_job, work, client=client,
                                          progress=False)
            t_dask = time.perf_counter() - t0
        assert all(np.array_equal(a, b) and np.array_equal(a, c)
                   for a, b, c in zip(serial, pooled, dasked))
        print(f'{model:<6} {t_serial:>8.2f} {t_pool:>13.2f} {t_dask:>11.2f} {t_start:>14.2f}',
              flush=True)


if __name__ == '__main__':
    main()
