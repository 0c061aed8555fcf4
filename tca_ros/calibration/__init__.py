"""Calibration of a muscle from its records.

The least-squares engine, the physical priors, the conditions of each record,
predictions, validation and transfer, and the lumped first-order baseline.
Built on tca_ros.records and tca_ros.model.
"""
