"""Record the golden outputs of the steppers and the linearisation (test/golden/).

The outputs test/test_golden.py compares the code against: the dynamics of each
kinetostatic model (cst, love, rod) on the dead weight, each rig (spring,
isometric, antagonistic) with each model, runs with the effects switched on
(thermal, creep, hysteresis, lags, friction, the massless modes, a changing
step), batch steps of six different muscles (cst and rod), and the small-signal
plants at an operating point (power and voltage drives). Each run heats for
half its span and cools for the rest. Units: SI, temperatures in degC.

Usage: ``python bench/make_golden.py [--out test/golden/steppers.npz]``; re-run
only when a change of the physics is meant (say so in the commit).
"""
import argparse
from dataclasses import replace
import math
import os

import numpy as np

from tca_ros.model.rig_simulation import simulate_rig
from tca_ros.model.simulation import simulate
from tca_ros.model.tca_params import with_effects
from tca_ros.params.files import load_params
from tca_ros.toolkit.batch import simulate_batch
from tca_ros.toolkit.linearize import linearize

OUT = os.path.join(os.path.dirname(__file__), '..', 'test', 'golden', 'steppers.npz')
TIME = np.arange(0.0, 0.6001, 0.01)  # s, 100 Hz samples, physics at 1 kHz
POWER = np.where(TIME < 0.3, 4.0, 0.0)  # W
POWER_2 = np.where(TIME < 0.3, 0.0, 4.0)  # W, the antagonist heats second
MODELS = ('cst', 'love', 'rod')
# effects on at once (each well away from its neutral value)
THERMAL = {'emissivity': 0.8, 'convection_exponent': 0.25, 'power_loss_fraction': 0.1,
           'ambient_offset': 2.0, 'dead_time': 0.015}
LAGS = {'second_thermal_lag': 0.05, 'sensor_lag': 0.02, 'hysteresis_width': 4.0,
        'extra_softening': 2e5}
CREEP = {'creep_compliance': 2e-3, 'creep_time_constant': 0.2}
FRICTION = {'friction_force': 0.002, 'static_friction_ratio': 1.3}


def _params(model='cst', mode='dead_weight', **effects):
    return with_effects(load_params('free_stroke', model=model, **{'rig.mode': mode}),
                        **effects)


def _dynamics(mass=None, damping=None, **effects):
    p = _params(**effects)
    d = {'mass': p.dynamics.mass if mass is None else mass,
         'damping': p.dynamics.damping if damping is None else damping}
    return replace(p, dynamics=replace(p.dynamics, **d))


def _run(params, model=None, time=TIME, power=POWER, supply='power'):
    r = simulate(params, time, power, model=model, supply=supply)
    return {'displacement': r.displacement, 'temperature': r.temperature,
            'resistance': r.resistance, 'tension': r.tension, 'velocity': r.velocity,
            'true_displacement': r.true_displacement}


def dynamics_cases():
    """Return {case: {column: array}} of the dead-weight stepper (TcaSimulator)."""
    cases = {f'dynamics/{m}': _run(_params(m), model=m) for m in MODELS}
    cases['dynamics/cst_thermal'] = _run(_params(**THERMAL))
    cases['dynamics/rod_lags'] = _run(_params('rod', **LAGS), model='rod')
    cases['dynamics/cst_creep_lags'] = _run(_params(**CREEP, **LAGS))
    cases['dynamics/cst_friction'] = _run(_params(**FRICTION))
    cases['dynamics/massless_damped_creep'] = _run(_dynamics(mass=0.0, damping=2.0, **CREEP))
    cases['dynamics/massless_static'] = _run(_dynamics(mass=0.0, damping=0.0))
    cases['dynamics/massless_friction'] = _run(_dynamics(mass=0.0, damping=1.0, **FRICTION))
    cases['dynamics/light_substeps'] = _run(_dynamics(mass=1e-6))
    contact = _params()
    contact = replace(contact, coil=replace(contact.coil, min_pitch_angle=math.radians(21.5)),
                      dynamics=replace(contact.dynamics, load=0.05))
    cases['dynamics/contact'] = _run(contact)
    cases['dynamics/voltage_supply'] = _run(_params(**LAGS), supply='voltage')
    uneven = np.concatenate([TIME[:20], TIME[20] + np.cumsum(np.full(30, 0.0035))])
    cases['dynamics/changing_step'] = _run(_params(), time=uneven,
                                           power=np.where(uneven < 0.1, 2.0, 0.3))
    return cases


def rig_cases():
    """Return {case: {column: array}} of the rigs (simulate_rig)."""
    cases = {}
    for mode in ('spring', 'isometric', 'antagonistic'):
        for model in MODELS:
            p = _params(model, mode)
            extra = {'power_2': POWER_2} if mode == 'antagonistic' else {}
            cases[f'rig/{mode}/{model}'] = simulate_rig(p, TIME, POWER, model=model,
                                                        **extra).columns
    light = _params('cst', 'antagonistic')
    light = replace(light, rig=replace(light.rig, joint_inertia=1e-10))
    cases['rig/antagonistic/light_substeps'] = simulate_rig(light, TIME, POWER,
                                                            power_2=POWER_2).columns
    effects = dict(THERMAL, **LAGS)
    cases['rig/spring/cst_effects'] = simulate_rig(_params('cst', 'spring', **effects),
                                                   TIME, POWER).columns
    for mode in ('isometric', 'antagonistic'):
        extra = {'power_2': POWER_2} if mode == 'antagonistic' else {}
        p = _params('cst', mode, **effects, **CREEP)
        cases[f'rig/{mode}/cst_effects'] = simulate_rig(p, TIME, POWER, **extra).columns
    return cases


def batch_cases():
    """Return {case: {column: array (N, n)}} of six different muscles (simulate_batch)."""
    base = load_params('free_stroke')
    heavy = replace(base, dynamics=replace(base.dynamics, mass=0.06, load=0.5886,
                                           damping=0.8))
    windy = replace(base, thermal=replace(base.thermal, convection_coefficient=30.0))
    early = replace(base, coil=replace(base.coil, min_pitch_angle=math.radians(21.5)),
                    dynamics=replace(base.dynamics, load=0.05))
    lagged = with_effects(base, sensor_lag=0.05, second_thermal_lag=0.3,
                          power_loss_fraction=0.1, ambient_offset=2.0)
    group = [base, heavy, windy, early, load_params('self_coiled'), lagged]
    power = np.where(TIME < 0.3, 1.8, 0.0)
    return {f'batch/{m}': simulate_batch(group, TIME, power, model=m) for m in ('cst', 'rod')}


def plant_cases():
    """Return {case: {'A', 'B', 'C', 'D': arrays}} of linearize at 0.8 W."""
    full = dict(CREEP, second_thermal_lag=0.3, sensor_lag=0.05, emissivity=0.8,
                convection_exponent=0.25, power_loss_fraction=0.1)
    runs = {'plant/cst': (_params(), 'cst', 'power'),
            'plant/rod': (_params('rod'), 'rod', 'power'),
            'plant/cst_effects_voltage': (_params(**full), 'cst', 'voltage'),
            'plant/massless_damped': (_dynamics(mass=0.0, damping=2.0), 'cst', 'power'),
            'plant/massless_static': (_dynamics(mass=0.0, damping=0.0), 'cst', 'power')}
    cases = {}
    for name, (params, model, drive) in runs.items():
        plant = linearize(params, 0.8, model=model, drive=drive)
        cases[name] = {'A': plant.A, 'B': plant.B, 'C': plant.C, 'D': plant.D,
                       'state': np.array(plant.point.state)}
    return cases


def all_cases():
    """Return every golden case: {case/column: array}."""
    flat = {}
    for group in (dynamics_cases(), rig_cases(), batch_cases(), plant_cases()):
        for case, columns in group.items():
            for column, values in columns.items():
                flat[f'{case}/{column}'] = np.asarray(values, dtype=float)
    return flat


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', default=OUT, help='the .npz written')
    args = parser.parse_args(argv)
    flat = all_cases()
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    np.savez_compressed(args.out, **flat)
    print(f'{len(flat)} arrays, {sum(v.size for v in flat.values())} values -> {args.out}')


if __name__ == '__main__':
    main()
