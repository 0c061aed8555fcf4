"""Diagnosis of measured TCA data: what the simulation gets wrong, and why (issue 5)."""
from tca_ros.diagnosis.fit_result import FitResult
from tca_ros.diagnosis.identification import diagnose, DiagnosisError, DiagnosisResult
from tca_ros.diagnosis.summary import format_summary
from tca_ros.records.data import DataError, read_record, Record

__all__ = ['DataError', 'DiagnosisError', 'DiagnosisResult', 'FitResult', 'Record', 'diagnose',
           'format_summary', 'read_record']
