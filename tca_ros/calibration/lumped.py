"""The control-oriented lumped TCA model, the baseline a calibration must beat.

Most TCA controllers are designed on a first-order thermal state with the
displacement linear in the temperature rise and, optionally, a dead time
(M. C. Yip and G. Niemeyer, "On the control and properties of supercoiled
polymer artificial muscles," IEEE T-RO 33(3), 2017):

    tau dtheta/dt = -theta + P(t - d),     x = K theta

theta (W) is the temperature rise times the thermal conductance, K (m/W) the
static gain from power to contraction. Fitted by the same engine (engine.py)
as the physics model, on the same records, with broad priors.
"""
import math

import numpy as np

from tca_ros.calibration import engine
from tca_ros.calibration.predictions import normalised_rmse, peak_stroke
from tca_ros.model.quasistatic_signals import delayed_input, first_order_response


def lumped_response(time, power, gain, tau, delay):
    """Return the contraction (m) of the lumped model at ``time`` (s).

    ``power`` (W, zero-order hold), ``gain`` K (m/W), ``tau`` (s), ``delay`` d (s).
    """
    return gain * first_order_response(time, delayed_input(time, power, delay), tau)


def lumped_parameters(records):
    """Return the engine Parameters of the lumped model, priors from the records."""
    gains = [peak_stroke(r) / max(float(r.power.max()), 1e-9) for r in records]
    gain = max(float(np.median(gains)), 1e-6)
    return [
        engine.Parameter('gain', 'm/W', gain, gain / 100.0, gain * 100.0, math.log(10.0),
                         description='static gain K'),
        engine.Parameter('tau', 's', 10.0, 0.05, 1000.0, math.log(10.0),
                         description='thermal time constant'),
        engine.Parameter('delay', 's', 0.5, 0.0, 20.0, 5.0, log=False,
                         description='dead time d'),
    ]


def predict_lumped(values, records):
    """Return the engine prediction list for ``values`` ({gain, tau, delay})."""
    return [{'displacement': lumped_response(r.time, r.power, values['gain'], values['tau'],
                                             values['delay'])} for r in records]


def fit_lumped(records, max_nfev=60):
    """Fit the lumped model jointly on ``records``; return the engine FitReport."""
    peaks = [peak_stroke(r) for r in records]
    median_peak = float(np.median(peaks))
    objective = engine.Objective(records, ['displacement'], predict_lumped,
                                 weights=[p / median_peak for p in peaks])
    return engine.fit(objective, lumped_parameters(records),
                      initial_scale={'displacement': 0.05 * median_peak},
                      max_nfev=max_nfev)


def lumped_nrmse(values, records):
    """Return per-record RMSE / peak stroke (-) of the lumped model with ``values``."""
    return [normalised_rmse(r, pred['displacement'])
            for r, pred in zip(records, predict_lumped(values, records))]
