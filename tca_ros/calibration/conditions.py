"""Per-record conditions of one muscle: the environment its heat goes to, the load it held.

A muscle's parameters are shared by all its records; what differs between
records is a condition. The environment (header ``# environment: NAME``; absent:
still air, the reference of the heat-loss prior) scales the heat loss h c_s A_0
of eq. (1): a fan, a water bath or a wind tunnel carries heat away faster.
Calibrating records of several environments at once gives each one's scale
(``heat_loss_scale.NAME``, relative to still air) with its uncertainty. A load
a record shows the thread holding outranks the strength the description assumed.
"""
import math

import numpy as np

from tca_ros.calibration import engine

STILL_AIR = 'still_air'  # the reference environment (scale 1 by definition)
SCALE_PREFIX = 'heat_loss_scale.'
#: prior (median, spread of ln) of the heat-loss scale of environments by name: forced
#: air at a few m/s about 2-3x still air on a thin thread (a filmed muscle's time
#: constant fell 2.8x with a fan); water some 30x; any other name: 1 x/÷ 5
ENVIRONMENT_PRIORS = {'forced_air': (2.5, math.log(2.5)), 'water': (30.0, math.log(3.0))}
UNKNOWN_PRIOR = (1.0, math.log(5.0))
SCALE_BOUNDS = (0.05, 500.0)
HELD_MARGIN = 1.1  # strength taken, x the largest load a record shows the thread held


#: header spellings of the rigs (rig.mode names)
RIG_ALIASES = {'isotonic': 'dead_weight', 'hanging_mass': 'dead_weight',
               'dead-weight': 'dead_weight', 'series_spring': 'spring'}
#: header spellings of the environments, and the keys that may carry them
ENVIRONMENT_ALIASES = {'still': STILL_AIR, 'free': STILL_AIR, 'free_air': STILL_AIR,
                       'natural': STILL_AIR, 'air': STILL_AIR, 'forced': 'forced_air',
                       'fan': 'forced_air'}
ENVIRONMENT_KEYS = ('environment', 'air', 'air_flow', 'airflow')


def rig_of(record):
    """Return the record's rig ('dead_weight' unless its header says otherwise)."""
    name = str(record.meta.get('rig', 'dead_weight')).strip().lower().replace(' ', '_')
    return RIG_ALIASES.get(name, name)


def spring_stiffness_of(record):
    """Return k_s (N/m) of a spring-rig record (header ``spring_stiffness_n_per_m``)."""
    value = record.meta.get('spring_stiffness_n_per_m', record.meta.get('spring_stiffness'))
    try:
        stiffness = float(value)
    except (TypeError, ValueError):
        stiffness = float('nan')
    if not stiffness > 0.0 or stiffness == float('inf'):
        raise ValueError(f"{record.source or 'a record'}: header 'spring_stiffness_n_per_m' = "
                         f'{value!r}: a spring rig needs its stiffness, a finite value > 0 N/m')
    return stiffness


def is_isometric(record):
    """Return True for a record of a clamped muscle (``# rig: isometric``)."""
    return rig_of(record) == 'isometric'


def measured(record):
    """Return what the record's rig measures: the contraction (m), or the force rise (N)."""
    if is_isometric(record):
        return record.force - record.force[0]
    return record.displacement


def with_tension(record):
    """Return the record with a force channel: a hanging mass pulls its weight (N)."""
    if record.force is not None:
        return record
    from dataclasses import replace
    return replace(record, force=np.array(record.load, dtype=float))


def environment_of(record):
    """Return the record's environment name (header ``environment``; default still air)."""
    value = next((record.meta[k] for k in ENVIRONMENT_KEYS if k in record.meta), STILL_AIR)
    name = str(value).strip().lower().replace(' ', '_').replace('-', '_')
    return ENVIRONMENT_ALIASES.get(name, name) or STILL_AIR


def environment_priors(records):
    """Return {name: engine.Parameter} of the heat-loss scales the records' environments need."""
    out = {}
    for env in sorted({environment_of(r) for r in records} - {STILL_AIR}):
        prior, spread = ENVIRONMENT_PRIORS.get(env, UNKNOWN_PRIOR)
        name = SCALE_PREFIX + env
        out[name] = engine.Parameter(name, '-', prior, *SCALE_BOUNDS, spread,
                                     description=f'heat loss in {env} / in still air')
    return out


def scale_of(environment, scales):
    """Return the heat-loss scale (-) of ``environment``: calibrated, or its prior's median.

    ``scales``: {environment: scale} a calibration fitted (None: none); an
    environment it lacks gets ENVIRONMENT_PRIORS' median (UNKNOWN_PRIOR's, 1, for
    a name it does not know), still air 1 by definition.
    """
    if environment == STILL_AIR:
        return 1.0
    if scales and environment in scales:
        return scales[environment]
    return ENVIRONMENT_PRIORS.get(environment, UNKNOWN_PRIOR)[0]


def environment_scales(values):
    """Return {environment: heat-loss scale} of the scale entries in ``values``."""
    return {k[len(SCALE_PREFIX):]: v for k, v in values.items() if k.startswith(SCALE_PREFIX)}


def in_environment(params, record, scales):
    """Return ``params`` with the heat loss of the record's environment (``scales``, -).

    An environment ``scales`` lacks (never calibrated) takes its prior's median
    (scale_of): a fan's 2.5x still air's rather than none.

    Outside still air the loss is carried by a flow (a fan, a liquid), whose
    coefficient hardly depends on the temperature rise: the still-air growth
    (effects.convection_exponent) is dropped there (docs/decisions.md C7).
    """
    env = environment_of(record)
    if env == STILL_AIR:
        return params
    values = {'thermal.convection_coefficient':
              params.thermal.convection_coefficient * scale_of(env, scales)}
    if params.effects.convection_exponent != 0.0:
        values['effects.convection_exponent'] = 0.0
    return params.with_values(**values)


def held_strength(params, records):
    """Return (params, warning or None): the thread's strength raised to what the records held.

    ``fiber.break_force`` (N) is an assumed strength (a preset's, or the paper's 240 g);
    a record whose load exceeds it shows that this thread held that load, and a
    recording is evidence, not an input to refuse. The strength is raised to
    HELD_MARGIN times the largest recorded load (N) and the warning says so.
    """
    top = max(float(np.max(r.load)) for r in records)
    if not top > params.fiber.break_force:
        return params, None
    raised = HELD_MARGIN * top
    name = next((r.source for r in records if float(np.max(r.load)) == top), None) \
        or 'a record'
    return params.with_values(**{'fiber.break_force': raised}), (
        f'warning: {name} carries {top:.4g} N, above the assumed fiber.break_force '
        f'{params.fiber.break_force:.4g} N, and the thread held: strength taken as '
        f'{raised:.4g} N ({HELD_MARGIN:g} x the load); give the measured one with '
        '`tca_sim config new --break-force`')
