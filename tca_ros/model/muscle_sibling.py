"""A muscle described with the thread a calibrated sibling measured (decision C10).

Muscles twisted, coiled and annealed from one thread share its material: the
expansion law Gamma(T) of eq. (2) (its curvature T_z), the untwist gain on eq. (4),
the moduli E and G, the specific heat c_p, the heat-loss coefficient h c_s of eq. (1)
in still air and the actuation lag (the thread's viscoelastic untwist). Their
geometry, resistance, load and supply are their own. A calibration of one muscle
(`tca_sim calibrate`, which writes what it left unknown as the file's uncertainty,
C9) therefore describes the thread of the next better than the preset does, to
within what muscles of one make differ by (SIBLING_FLOOR).
"""
from dataclasses import replace

from tca_ros.model.muscle import describe_muscle
from tca_ros.model.tca_params import to_flat_dict

#: material entries a calibration fits (as params-file entries) -> the uncertainty
#: entry that states how well it is known; geometry is derived with them
MATERIAL_FITTED = {
    'fiber.specific_heat': 'heat_capacity',
    'fiber.gamma_coefficients': 'expansion_zero_temperature',
    'fiber.expansion_plateau_temperature': 'expansion_plateau_temperature',
    'thermal.convection_coefficient': 'heat_loss',
    'thermal.surface_factor': 'heat_loss',
    'moduli.youngs_modulus': 'stiffness_scale',
    'moduli.shear_modulus': 'stiffness_scale',
}
#: the same for entries that do not enter the geometry (applied after it is derived)
PROCESS_FITTED = {
    'fiber.untwist_gain': 'actuation_gain',
    'effects.second_thermal_lag': 'actuation_lag',
}
#: how much two muscles of one make differ at least (relative; K for T_z; s for the
#: lag): the shared records' repeats at one power differ by tens of percent
SIBLING_FLOOR = {'relative': 0.25, 'expansion_zero_temperature': 5.0, 'actuation_lag': 2.0,
                 'expansion_plateau_temperature': 10.0}
RADIUS_MISMATCH = 0.2  # relative difference of thread radii that earns a warning


def sibling_preset(preset, sibling):
    """Return ``preset`` (ThreadPreset) with the material values of calibrated ``sibling``."""
    flat = to_flat_dict(sibling)
    return replace(preset, params={**preset.params,
                                   **{k: flat[k] for k in MATERIAL_FITTED}})


def with_sibling_thread(params, sibling):
    """Return (``params`` with the sibling's process values and uncertainties, warnings).

    ``params``: the new muscle described with :func:`sibling_preset`; ``sibling``:
    the calibrated TcaParams. Each value's uncertainty is the sibling's (its
    calibration's posterior, C9), at least SIBLING_FLOOR and at most the
    description's own. Warnings: a thread radius that differs by more than
    RADIUS_MISMATCH (the material is taken as this thread's anyway).
    """
    flat = to_flat_dict(sibling)
    values = {k: flat[k] for k in PROCESS_FITTED}
    for name in sorted(set(MATERIAL_FITTED.values()) | set(PROCESS_FITTED.values())):
        stated = float(getattr(sibling.uncertainty, name))
        own = float(getattr(params.uncertainty, name))
        floor = SIBLING_FLOOR.get(name, SIBLING_FLOOR['relative'])
        values[f'uncertainty.{name}'] = min(own, max(stated, floor))
    warnings = []
    ratio = params.fiber.radius / sibling.fiber.radius
    if abs(ratio - 1.0) > RADIUS_MISMATCH:
        warnings.append(f"the calibrated muscle's thread is {2e3 * sibling.fiber.radius:.3g} "
                        f'mm thick, this one {2e3 * params.fiber.radius:.3g} mm: its material '
                        "is taken as this thread's")
    return params.with_values(**values), warnings


def describe_from_sibling(spec, presets, sibling):
    """Return (MuscleDescription of ``spec`` with calibrated ``sibling``'s thread, warnings).

    describe_muscle with ``spec``'s thread preset given the sibling's material
    (:func:`sibling_preset`), then its process values and uncertainties
    (:func:`with_sibling_thread`). Raises MuscleError as describe_muscle does.
    """
    presets = dict(presets)
    if spec.thread in presets:
        presets[spec.thread] = sibling_preset(presets[spec.thread], sibling)
    result = describe_muscle(spec, presets)
    params, warnings = with_sibling_thread(result.params, sibling)
    return replace(result, params=params), warnings
