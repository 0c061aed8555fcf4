"""A user's own TCA from what a maker knows: derived geometry and constants.

A maker knows the thread, its twisted diameter, how it was coiled (self-coiled, on a
mandrel, on a conical mandrel), the mandrel or coil diameter, the pitch angle or the
coil count, a length (natural, or loaded under a hanging mass), the resistance at
ambient and the hanging mass. Everything else of the params file is derived here:
the coil radius r*, the fiber length l_t, the coil count, the contact angle, the
inserted twist, and the thermal and electrical constants. docs/describe.md gives the
derivations and the decisions behind them.

The thread presets (ThreadPreset, in muscle_spec.py) are read from their file by
tca_ros.params.thread_presets and passed in; the geometric relations are in
coil_geometry.py, the coil derived from them (r*, alpha*, l_t, the conical spiral) in
muscle_coil.py, the maker's description (MuscleSpec) and its checks in muscle_spec.py.

References
----------
[1] J. Sun and J. Zhao, "Physics-based modeling of twisted-and-coiled actuators using
    Cosserat rod theory," IEEE Trans. Robot., 2022.
"""
from dataclasses import dataclass
import math

from tca_ros.model.coil_geometry import inserted_twist_of_diameter
from tca_ros.model.heat_transfer import REFERENCE_RISE_K, still_air_loss_exponent
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import loaded_length
from tca_ros.model.muscle_coil import conical_geometry, helix_geometry
from tca_ros.model.muscle_spec import check_spec, COIL_TYPES, Derived, MuscleError, \
    MuscleSpec, ThreadPreset  # noqa: F401 (COIL_TYPES, MuscleSpec: API)
from tca_ros.model.params_schema import GRAVITY, ParameterError, SCHEMA
from tca_ros.model.tca_params import from_flat_dict
from tca_ros.model.thermal import (fiber_mass, heat_capacity, surface_area,
                                   thermal_conductance, thermal_time_constant)

#: tca_type written for each way of coiling (a mandrel-coiled helix is the paper's
#: free-stroke TCA).
TCA_TYPE_OF_COIL = {'self_coiled': 'self_coiled', 'mandrel': 'free_stroke',
                    'conical': 'conical'}


# -- the maker's description --------------------------------------------------------
@dataclass(frozen=True)
class MuscleDescription:
    """Result of describe_muscle: validated params, and what was derived."""

    params: object
    preset: ThreadPreset
    derived: dict


def describe_muscle(spec, presets):
    """Return the MuscleDescription of ``spec`` (a MuscleSpec).

    ``presets`` maps thread names to ThreadPreset (tca_ros.params.thread_presets
    .load_thread_presets reads the shipped ones).

    Raises
    ------
    MuscleError
        One line naming the field, its value and why the muscle cannot exist or is
        not fully described.
    """
    preset = check_spec(spec, presets)
    r_t = 0.5 * spec.thread_diameter
    derived = {}
    flat = {s.name: s.default for s in SCHEMA}
    flat.update(preset.params)
    flat.update({'tca_type': TCA_TYPE_OF_COIL[spec.coil], 'model': spec.model,
                 'fiber.radius': r_t,
                 'thermal.ambient_temperature_degc': spec.ambient_degc,
                 'dynamics.mass': spec.mass, 'dynamics.load': spec.mass * GRAVITY})
    twist = spec.inserted_twist
    if twist is None:
        twist = inserted_twist_of_diameter(preset.twist_diameter_product, spec.thread_diameter)
        derived['inserted_twist'] = Derived(twist, 'rad/m', f'theta* d of {preset.name} / d')
    flat['fiber.inserted_twist'] = twist
    if spec.coil == 'conical':
        conical_geometry(spec, flat, derived)
    else:
        helix_geometry(spec, flat, derived, r_t)
    flat['electrical.resistance'] = _resistance(spec, preset, flat, derived)
    flat['fiber.break_force'] = _break_force(spec, preset, r_t, derived)
    _still_air_loss(spec, flat, derived)
    params = _build(flat)
    _thermal_figures(params, derived)
    return MuscleDescription(params=params, preset=preset, derived=derived)


def _still_air_loss(spec, flat, derived):
    """Set the growth of eq. (1)'s heat loss with the rise, as a thin thread's in still air.

    h(dT) = h(dT_ref) (dT / dT_ref)^n (the 'nonlinear_convection' law of
    effects.py) with n from Morgan's correlation on the thread's diameter plus
    radiation (heat_transfer.still_air_loss_exponent, about 0.17 for 0.45 mm) and
    dT_ref = REFERENCE_RISE_K: a real thread's loss coefficient grows with its
    temperature, where the paper's eq. (1) keeps it constant (docs/decisions.md C7).
    """
    n = still_air_loss_exponent(spec.thread_diameter, spec.ambient_degc)
    flat['effects.convection_exponent'] = n
    flat['effects.convection_reference_dt'] = REFERENCE_RISE_K
    derived['effects.convection_exponent'] = Derived(
        n, '-', f'h ~ dT^n in still air (Morgan + radiation, 25-100 K, '
        f'h quoted at {REFERENCE_RISE_K:g} K)')


def _break_force(spec, preset, r_t, derived):
    """Return the thread's strength (N): given, or the preset's breaking stress x pi r_t^2."""
    if spec.break_force is not None:
        return spec.break_force
    value = preset.breaking_stress * math.pi * r_t ** 2
    derived['break_force'] = Derived(value, 'N', f'{preset.breaking_stress:.3g} Pa of '
                                     f'{preset.name} x pi r_t^2 (measure it: --break-force)')
    return value


def _resistance(spec, preset, flat, derived):
    """Return R0 (ohm): the measured one, or the preset's ohm/m times l_t."""
    if spec.resistance is not None:
        return spec.resistance
    per_length = preset.resistance_per_length
    value = float(per_length) * flat['fiber.length']
    derived['resistance'] = Derived(value, 'ohm', f'{per_length:g} ohm/m of {preset.name} '
                                    'x l_t (measure it: --resistance)')
    return value


def _build(flat):
    """Return validated TcaParams, turning a schema refusal into a MuscleError."""
    try:
        return from_flat_dict(flat)
    except MuscleError:
        raise
    except ParameterError as exc:
        raise MuscleError('derived', 'params', str(exc)) from None


def _thermal_figures(params, derived):
    """Add the constants of the thermal model, Eq. (1), to ``derived``."""
    fiber, thermal = params.fiber, params.thermal
    derived['fiber_mass'] = Derived(fiber_mass(fiber), 'kg', 'm_t = rho pi r_t^2 l_t')
    derived['heat_capacity'] = Derived(heat_capacity(fiber), 'J/K', 'm_t c_p, eq. (1)')
    derived['surface_area'] = Derived(surface_area(fiber), 'm^2',
                                      'A_0 = 2 pi r_t l_t, eq. (1) (c_s A_0 convects)')
    derived['thermal_time_constant'] = Derived(
        thermal_time_constant(fiber, thermal), 's', 'm_t c_p / (h c_s A_0), eq. (1)')
    derived['steady_rise'] = Derived(1.0 / thermal_conductance(fiber, thermal), 'K/W',
                                     '1 / (h c_s A_0), eq. (1)')


def loaded_length_at_ambient(params, model=None):
    """Return the static length (m) at ambient under the params' load (N)."""
    km = make_kinetostatic_model(params, model)
    return loaded_length(km, params.dynamics.load, params.thermal.ambient_temperature)
