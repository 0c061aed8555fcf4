"""Benchmark the quasi-static reduction against simulation.simulate on a fit-sized record.

Prints, for the cst and rod models, the wall time of one call on a 240 s record at
10 Hz (the diagnosis's fit grid) for the nominal model, each effect the reduction
gained in quasistatic_effects.py and all four together: the reduction (static maps
cached, the effect's parameter moved at every call as a fit moves it) beside
simulation.simulate with its physics at the record's rate, as the coarse fits call
it. Figures, not assertions: run ``python bench/bench_quasistatic.py``.
"""
import argparse
import time

import numpy as np

from tca_ros.model.params_schema import GRAVITY
from tca_ros.model.quasistatic import simulate_quasistatic
from tca_ros.model.simulation import simulate
from tca_ros.params.files import load_params

DURATION = 240.0  # s, the record
RATE = 10.0  # Hz, the diagnosis's fit grid (fitting.FIT_RATE_HZ)
MASS = 0.02  # kg
STEP = 1e-3  # relative move of the fitted parameter between calls

# name: (effect values, the parameter a fit moves)
EFFECTS = {
    'nominal': ({}, 'thermal.convection_coefficient'),
    'radiation': ({'effects.emissivity': 0.9}, 'effects.emissivity'),
    'nonlinear_convection': ({'effects.convection_exponent': 0.25},
                             'effects.convection_exponent'),
    'hysteresis': ({'effects.hysteresis_width': 10.0}, 'effects.hysteresis_width'),
    'creep': ({'effects.creep_compliance': 0.01, 'effects.creep_time_constant': 30.0},
              'effects.creep_compliance'),
    'all four': ({'effects.emissivity': 0.9, 'effects.convection_exponent': 0.25,
                  'effects.hysteresis_width': 10.0, 'effects.creep_compliance': 0.01,
                  'effects.creep_time_constant': 30.0}, 'effects.emissivity'),
}


def record():
    """Return (time (s), power (W), load (N)): steps, a ramp and a pseudo-random sequence."""
    t = np.arange(0.0, DURATION, 1.0 / RATE)
    power = np.zeros_like(t)
    power[(t >= 10.0) & (t < 40.0)] = 0.6
    power[(t >= 60.0) & (t < 90.0)] = 1.2
    ramp = (t >= 110.0) & (t < 150.0)
    power[ramp] = 1.5 * (t[ramp] - 110.0) / 40.0
    bits = np.random.default_rng(7).integers(0, 2, size=40)  # 2 s bits over 160-240 s
    prbs = t >= 160.0
    power[prbs] = 1.0 * bits[((t[prbs] - 160.0) // 2.0).astype(int)]
    return t, power, np.full_like(t, MASS * GRAVITY)


def time_calls(run, params, name, calls):
    """Return the median wall time (s) of ``calls`` calls, ``name`` moved by STEP each.

    The median, not the mean: on a shared machine one call now and then waits.
    """
    group, field = name.split('.')
    value = getattr(getattr(params, group), field)
    times = []
    for i in range(calls):
        moved = params.with_values(**{name: value * (1.0 + STEP * (i + 1))})
        start = time.perf_counter()
        run(moved)
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--calls', type=int, default=7,
                        help='reduction calls timed per row (median)')
    parser.add_argument('--dynamics-calls', type=int, default=3,
                        help='simulation.simulate calls timed per row (median)')
    args = parser.parse_args(argv)
    t, power, load = record()
    print(f'free-stroke TCA, {MASS * 1e3:.0f} g; record {DURATION:.0f} s at {RATE:g} Hz '
          f'({t.size} samples): steps, a ramp, a pseudo-random sequence')
    print('median wall time per call; reduction: simulate_quasistatic, static maps cached, '
          'the parameter moved each call;')
    print(f'dynamics: simulate at physics_rate {RATE:g} Hz (the fit grid, substeps as its '
          'stability needs)')
    header = (f'{"model":6s} {"effect":22s} {"reduction ms/call":>18s} '
              f'{"dynamics ms/call":>17s} {"speed-up":>9s}')
    print(header)
    print('-' * len(header))
    for model in ('cst', 'rod'):
        first = None
        for effect, (values, moved) in EFFECTS.items():
            params = load_params('free_stroke').with_values(**{
                'dynamics.mass': MASS, 'dynamics.load': MASS * GRAVITY, **values})

            def reduction(p):
                return simulate_quasistatic(p, t, power, load, model=model)

            def dynamics(p):
                return simulate(p, t, power, load, model=model, physics_rate=RATE)

            start = time.perf_counter()
            reduction(params)  # builds (or finds) the static maps
            first = time.perf_counter() - start if first is None else first
            dynamics(params)  # builds (or finds) the model's tables
            fast = time_calls(reduction, params, moved, args.calls)
            full = time_calls(dynamics, params, moved, args.dynamics_calls)
            print(f'{model:6s} {effect:22s} {fast * 1e3:18.1f} {full * 1e3:17.0f} '
                  f'{full / fast:8.0f}x')
        print(f'{model:6s} first call of the process (static maps built): '
              f'{first * 1e3:.0f} ms')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
