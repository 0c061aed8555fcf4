"""Geometrically exact Cosserat rod statics for TCAs (NumPy/SciPy only).

Modules: ``so3`` (rotations, non-unit quaternions), ``reference`` (helix and conical
spiral reference curves), ``helix`` (exact uniform-helix equilibrium), ``statics``
(full-length BVP solver with continuation). See docs/rod.md.
"""
