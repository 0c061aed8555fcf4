"""Synthetic records for tests and benchmarks.

Random power profiles and effects (generator), realistic rigs and sensors
(realistic).
"""
