"""Heating and cooling of the real records, each fitted by a delayed first-order step.

For every record of ../shared/realdata/salp_tca/records (skipped when absent):
the heating part (power on) fitted by a (1 - exp(-(t - t_on - d) / tau)) rise with
a delay d, the cooling part by a held value, then an exponential decay after a
delay; printed side by side with the end offset and the peak. A single
first-order thermal model (eq. (1)) gives the same time constant both ways.

    python bench/real_step_shapes.py [DIR]

Printed figures, not assertions.
"""
import glob
import os
import sys

from bench_diagnosis_real import REAL_DIR
import numpy as np
from scipy.optimize import curve_fit

from tca_ros.records.data import read_record


def step_shapes(record):
    """Return (heat tau, heat delay, cool tau, cool delay) (s) of one on/off record."""
    t, x = record.time, record.displacement * 1e3
    on = record.power > 0.0
    t_on, t_off = t[on][0], t[on][-1] + 1.0 / record.sample_rate
    heat, cool = (t >= t_on) & (t < t_off), t >= t_off

    def rise(tt, a, tau, d):
        return np.where(tt > t_on + d, a * (1.0 - np.exp(-(tt - t_on - d) / tau)), 0.0)

    x0 = x[cool][0]

    def fall(tt, tau, d, end):
        return np.where(tt < t_off + d, x0, end + (x0 - end) * np.exp(-(tt - t_off - d) / tau))

    (_, tau_h, d_h), _ = curve_fit(rise, t[heat], x[heat], p0=[x[heat].max(), 10.0, 2.0],
                                   bounds=([0.0, 0.5, 0.0], [500.0, 500.0, 10.0]))
    (tau_c, d_c, _), _ = curve_fit(fall, t[cool], x[cool], p0=[4.0, 2.0, x[cool][-1]],
                                   bounds=([0.2, 0.0, -20.0], [200.0, 10.0, 50.0]))
    return tau_h, d_h, tau_c, d_c


def main(argv=None):
    """Print the step shapes of every record."""
    directory = (argv or sys.argv[1:] or [REAL_DIR])[0]
    paths = sorted(glob.glob(os.path.join(directory, '*.csv')))
    if not paths:
        print(f'real_step_shapes: no records in {directory}; skipped')
        return 0
    print(f'{"record":<36s} {"heat tau":>9s} {"delay":>6s} {"cool tau":>9s} {"delay":>6s} '
          f'{"end":>7s} {"peak":>7s}')
    for path in paths:
        r = read_record(path)
        tau_h, d_h, tau_c, d_c = step_shapes(r)
        print(f'{os.path.basename(path):<36s} {tau_h:7.1f} s {d_h:4.1f} s {tau_c:7.1f} s '
              f'{d_c:4.1f} s {r.displacement[-1] * 1e3:5.1f} mm '
              f'{r.displacement.max() * 1e3:5.1f} mm')
    return 0


if __name__ == '__main__':
    sys.exit(main())
