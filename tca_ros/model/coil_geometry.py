"""Geometric relations of a coiled thread, one function each, in SI units.

The coil radius from a mandrel or a caliper, the pitch angle at which coils touch,
the fiber length, coil count and pitch angle of a helix [1, eqs. (24), (26)], the
inserted twist of a twisted thread, and the height, fiber length and turns of a
conical spiral [1, eqs. (36), (37)] with its equivalent helix. muscle_coil.py derives a
maker's muscle from them.

[1] J. Sun and J. Zhao, "Physics-based modeling of twisted-and-coiled actuators using
    Cosserat rod theory," IEEE Trans. Robot., 2022.
"""
import math

import numpy as np

from tca_ros.rod.reference import spiral_arc_length, spiral_coefficients


def mandrel_coil_radius(mandrel_diameter, thread_diameter):
    """Return r* = (D_m + d) / 2 (m): the thread's centreline on a mandrel core.

    The twisted thread (diameter d, m) lies against the mandrel core (diameter D_m,
    m), so its centreline is one thread radius outside the core.
    """
    return 0.5 * (mandrel_diameter + thread_diameter)


def outer_coil_radius(outer_diameter, thread_diameter):
    """Return r* = (D_o - d) / 2 (m) from the coil's outer (caliper) diameter D_o (m)."""
    return 0.5 * (outer_diameter - thread_diameter)


def contact_pitch_angle(coil_radius, thread_radius):
    """Return alpha_min (rad), the pitch angle at which neighbouring coils touch.

        sin(alpha_min) = r_t / (pi r*)

    On the developed coil cylinder the turns are parallel lines at angle alpha,
    2 pi r* tan(alpha) apart axially, hence 2 pi r* sin(alpha) apart normal to the
    thread; they touch when that gap equals the thread diameter 2 r_t. Radii in m.
    """
    return math.asin(min(thread_radius / (math.pi * coil_radius), 1.0))


def fiber_length_of_natural_length(natural_length, pitch_angle):
    """Return l_t = l* / sin(alpha*) (m), Eq. (26); l* in m, alpha* in rad."""
    return natural_length / math.sin(pitch_angle)


def coil_count(fiber_length, coil_radius, pitch_angle):
    """Return N = l_t cos(alpha*) / (2 pi r*) (-), Eq. (24); lengths in m, angle in rad."""
    return fiber_length * math.cos(pitch_angle) / (2.0 * math.pi * coil_radius)


def pitch_angle_of_coil_count(natural_length, coil_radius, coils):
    """Return alpha* = atan(l* / (2 pi r* N)) (rad) of N coils over l* (m), Eqs. (24), (26)."""
    return math.atan2(natural_length, 2.0 * math.pi * coil_radius * coils)


def inserted_twist_of_diameter(twist_diameter_product, thread_diameter):
    """Return theta* = (theta* d) / d (rad/m) for a twisted-thread diameter d (m)."""
    return twist_diameter_product / thread_diameter


def conical_height_of_coil_count(spiral_pitch, coils):
    """Return the height z = N p_c (m) of N turns of a conical spiral, Eq. (36)."""
    return coils * spiral_pitch


def conical_fiber_length(spiral_pitch, cone_angle, height):
    """Return l_t = s(z) (m), the arc length of a conical spiral of height z (m), Eq. (37).

    ``spiral_pitch`` p_c in m, ``cone_angle`` (full angle) in rad.
    """
    a, b = spiral_coefficients(spiral_pitch, cone_angle)
    return float(spiral_arc_length(np.array([height]), a, b)[0])


def conical_coil_count(spiral_pitch, height):
    """Return the turns N = z / p_c (-) of a conical spiral of height z (m), Eq. (36)."""
    return height / spiral_pitch


def equivalent_helix(fiber_length, height, coils):
    """Return (r (m), alpha (rad)): the uniform helix of equal l_t, height and turns.

    sin(alpha) = z / l_t (Eq. (26)) and r = l_t cos(alpha) / (2 pi N) (Eq. (24)); written
    for a conical TCA so that l* and N read from its params file are right.
    """
    alpha = math.asin(height / fiber_length)
    return fiber_length * math.cos(alpha) / (2.0 * math.pi * coils), alpha
