"""Measured records: CSV and MCAP reading and writing, headers, operations.

Built on tca_ros.model; knows nothing of calibration or diagnosis.
"""
