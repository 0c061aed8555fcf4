"""The coil's reference state: as coiled (Table III) or crept under its hanging weight.

Sec. V-D1 of [1]: a nylon TCA creeps to a length that depends on the weight it
carries, and the paper starts every load case from the length the muscle has crept
to under that weight ("we also use the reference state corresponding to the length
as the reference for simulation"); the authors' code looks the rest pitch angle up
by mass (15, 16, 20, 22 deg at 0, 2, 30, 60 g, coil count kept). Here that is an
option (``coil.crept_reference``, off by default: Table III's alpha* for every load)
with a two-parameter law instead of a table per mass (docs/decisions.md, D6):

    sin a*(F) = sin a_c - (sin a_c - sin a_0) exp(-F / F_c)
    r*(F) = r_c cos a*(F) / cos a_c                                 (eq. (24))

a_c, r_c the as-coiled pitch angle and radius (``coil.pitch_angle_deg``,
``coil.radius``: the limit of a heavily crept coil), a_0 the rest pitch angle crept
without load (``coil.unloaded_pitch_angle_deg``) and F_c (N) the load scale
(``coil.crept_force_scale``). The defaults a_0 = 15 deg, F_c = 0.24 N reproduce the
authors' four angles to 0.43 deg. F is ``dynamics.load``: the weight the muscle hung
under before the run; a load changed during a run is an actuation load and leaves
the reference alone.

References
----------
[1] Sun et al., IEEE T-RO 2022, Sec. V-D1, eqs. (24), (26); the authors' TCA_geo.m.
"""
from dataclasses import replace
import math


def crept_pitch_angle(load, coil):
    """Return the rest pitch angle a*(F) (rad) crept under the load F (N).

    ``coil`` holds the as-coiled angle a_c (``coiled_pitch_angle``, rad), the
    unloaded crept angle a_0 (``unloaded_pitch_angle``, rad) and F_c
    (``crept_force_scale``, N); see the module docstring for the law.
    """
    s_c = math.sin(coil.coiled_pitch_angle)
    s_0 = math.sin(coil.unloaded_pitch_angle)
    return math.asin(s_c - (s_c - s_0) * math.exp(-max(load, 0.0) / coil.crept_force_scale))


def crept_coil_radius(pitch_angle, coil):
    """Return r* (m) at the rest pitch angle (rad) for the coil count as coiled, Eq. (24)."""
    return coil.coiled_radius * math.cos(pitch_angle) / math.cos(coil.coiled_pitch_angle)


def resolve_reference(coil, load):
    """Return ``coil`` with pitch_angle and radius of its reference state under load (N).

    As coiled unless ``coil.crept_reference`` (and the shape is a helix); then crept
    under the load by the law of the module docstring. The as-coiled values stay in
    ``coiled_pitch_angle`` and ``coiled_radius``.
    """
    if not coil.crept_reference or coil.shape != 'helix':
        return replace(coil, pitch_angle=coil.coiled_pitch_angle, radius=coil.coiled_radius)
    angle = crept_pitch_angle(load, coil)
    return replace(coil, pitch_angle=angle, radius=crept_coil_radius(angle, coil))


def crept_under(params, load):
    """Return ``params`` with the reference crept under the hanging load (N).

    Unchanged unless ``coil.crept_reference``; then ``dynamics.load`` becomes the
    load, so the reference state (and every model built from it) is that of a muscle
    that has crept under it (the paper's Fig. 10 protocol, one reference per weight).
    """
    if not params.coil.crept_reference or load == params.dynamics.load:
        return params
    return params.with_values(**{'dynamics.load': float(load)})
