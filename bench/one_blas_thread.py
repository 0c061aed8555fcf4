"""Import before NumPy: one BLAS thread per process, for the diagnosis benchmarks.

The fits' matrices are small (a few thousand rows, a dozen columns); OpenBLAS's
threads then mostly spin. Measured on seed 1023 of bench_diagnosis.py (2 cores,
2026-12-02): 33.3 s CPU and wall with one thread, 43.8 s CPU and 31.4 s wall with
two. With ``--jobs 2`` each worker's threads would also compete for the other
worker's core, and the time per record would measure that contention. A value
already set in the environment is kept.
"""
import os

for _variable in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
    os.environ.setdefault(_variable, '1')
