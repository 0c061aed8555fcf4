"""Descriptions of a realistic muscle as a maker would write them: exact, rough or guessed.

A description is a params file with its ``uncertainty`` section (the calibration's
priors, calibration/physical_priors.py). Written from the hidden truth of
realistic.py (its truth params, effects included) and the maker's start (geometry
known, thermal constants within +-30 % of a preset):

========== =========================================== ===============================
tightness  values                                      stated relative uncertainty
========== =========================================== ===============================
exact      the truth's, every effect off               2-5 % (measured)
rough      the truth's x (1 + U(-s, s)), s in 10-30 %  s (estimated)
guessed    the start's (preset-like)                   LOOSE (x/÷ 2; damping x/÷ 10)
========== =========================================== ===============================

The calibrated quantities described: the heat capacity m_t c_p and heat loss
h c_s A_0 of eq. (1) (through fiber.specific_heat and thermal.convection_coefficient),
the actuation gain (fiber.untwist_gain), the moduli E and G, the damping b_t of eq. (18)
and the delivered power ratio; the room's temperature is stated to 1 K and T_z of
eq. (2) to 2 K (exact) or to the defaults (2 K, 20 K), and an ambient offset is off in
all three. The geometry is the
truth's in all three.
"""
from tca_ros.model.params_schema import SPECS

TIGHTNESS = ('exact', 'rough', 'guessed')
EXACT_SPREAD = (0.02, 0.05)  # -, relative uncertainty of a measured value
ROUGH_SPREAD = (0.1, 0.3)  # -, how far a roughly known value is off, and its uncertainty
#: relative uncertainties of a guessed description (x/÷ 2; the damping unknown)
LOOSE = {'heat_capacity': 1.0, 'heat_loss': 1.0, 'actuation_gain': 1.0,
         'stiffness_scale': 1.0, 'damping': 9.0, 'delivered_power_ratio': 0.5}
RELATIVE = tuple(LOOSE)  # the described quantities with a relative uncertainty
#: K, the room's temperature as a measured description states it (a thermometer in the
#: room); the other two keep the default of `tca_sim config new` (a thermostat's 2 K)
EXACT_AMBIENT_K = 1.0
#: K, T_z of eq. (2) as a measured description states it (the truth's; the default 20 K
#: is the paper's law on another thread)
EXACT_CURVATURE_K = 2.0


def _effects_off(params):
    """Return ``params`` with every catalogue effect at its neutral default, at rest."""
    neutral = {name: spec.default for name, spec in SPECS.items()
               if name.startswith('effects.')}
    return params.with_values(**neutral, **{'thermal.initial_temperature_rise': 0.0})


def _scaled(params, factors):
    """Return ``params`` with the described quantities scaled by ``factors`` ({name: x})."""
    fiber, thermal = params.fiber, params.thermal
    out = {}
    if 'heat_capacity' in factors:
        out['fiber.specific_heat'] = fiber.specific_heat * factors['heat_capacity']
    if 'heat_loss' in factors:
        out['thermal.convection_coefficient'] = (thermal.convection_coefficient
                                                 * factors['heat_loss'])
    if 'actuation_gain' in factors:
        out['fiber.untwist_gain'] = fiber.untwist_gain * factors['actuation_gain']
    if 'stiffness_scale' in factors:
        out['moduli.youngs_modulus'] = params.moduli.youngs_modulus * factors['stiffness_scale']
        out['moduli.shear_modulus'] = params.moduli.shear_modulus * factors['stiffness_scale']
    if 'damping' in factors:
        out['dynamics.damping'] = params.dynamics.damping * factors['damping']
    if 'delivered_power_ratio' in factors:
        out['thermal.delivered_power_ratio'] = (thermal.delivered_power_ratio
                                                * factors['delivered_power_ratio'])
    return params.with_values(**out)


def describe(truth, start, tightness, rng, model='cst'):
    """Return the TcaParams a maker would write for the muscle ``truth``.

    ``truth``: the plant's params (effects included); ``start``: the maker's
    preset-like guess with the truth's geometry; ``tightness``: one of TIGHTNESS;
    ``rng``: numpy Generator of the drawn spread and offsets; ``model``: the
    kinetostatic model the description names (the fits run it).
    """
    if tightness == 'exact':
        u = float(rng.uniform(*EXACT_SPREAD))
        params = _effects_off(truth)
        stated = {name: u for name in RELATIVE}
        stated['ambient_temperature'] = EXACT_AMBIENT_K
        stated['expansion_zero_temperature'] = EXACT_CURVATURE_K
    elif tightness == 'rough':
        s = float(rng.uniform(*ROUGH_SPREAD))
        factors = {name: 1.0 + float(rng.uniform(-s, s)) for name in RELATIVE}
        params = _scaled(_effects_off(truth), factors)
        stated = {name: s for name in RELATIVE}
    elif tightness == 'guessed':
        params = _effects_off(start)
        stated = dict(LOOSE)
    else:
        raise ValueError(f'tightness {tightness!r}: allowed {", ".join(TIGHTNESS)}')
    return params.with_values(model=model, **{f'uncertainty.{k}': v for k, v in stated.items()})
