"""The thermal and input signals of the quasi-static reduction (quasistatic.py).

Eq. (1) on a record's grid under a zero-order-hold power, with the coefficients
and steps of thermal.py that the full dynamics takes: exact while it is linear
(all intervals at once, a linear filter), Runge-Kutta with radiation or
nonlinear convection (quasistatic_effects.py); the second thermal lag behind it,
the first-order filter the lags use, and the drive's dead time as a
heat-preserving delay of the held input. Plain arrays in and out: the
calibration's lumped models use the same filters.
"""
import math

import numpy as np
from scipy.signal import lfilter

from tca_ros.model import quasistatic_effects as qe
from tca_ros.model.thermal import HeatBalance

#: Relative spread of the intervals below which a grid is taken as uniform (one filter).
UNIFORM_SPREAD = 1e-9


def thermal_response(time, power, params):
    """Return T (degC) at ``time`` (s) under zero-order-hold ``power`` (W), eq. (1).

    The logged power heats the fiber through thermal.HeatBalance: P_in = (1 - eta) r
    P (``thermal.delivered_power_ratio``, the power loss), delayed by
    ``effects.dead_time`` when set; the start is ``thermal.initial_temperature_rise``
    (K) above ambient. While eq. (1) is linear, its exact step
    (thermal.heat_step_exact) over every interval at once: the temperature relaxes to
    T_inf + P_in / (h c_s A_0) with the time constant m_t c_p / (h c_s A_0), a linear
    filter, and the start's excess decays with the same time constant
    (superposition). With radiation or nonlinear convection, eq. (1') by the
    stepper's Runge-Kutta step (quasistatic_effects).
    """
    time = np.asarray(time, dtype=float)
    balance = HeatBalance.of(params)
    power = np.asarray(power, dtype=float)
    rise = params.thermal.initial_temperature_rise
    if not balance.linear:
        delayed = delayed_input(time, power, params.effects.dead_time)
        return qe.nonlinear_thermal_response(time, delayed, balance, rise)
    heating = delayed_input(time, balance.gain * power, params.effects.dead_time)  # W, P_in
    tau = balance.capacity / balance.conductance  # s
    response = balance.ambient + first_order_response(time, heating / balance.conductance, tau)
    if rise > 0.0 and time.size:
        response = response + rise * np.exp(-(time - time[0]) / tau)
    return response


def uniform_step(time):
    """Return the step (s) of a uniform time grid (s), or None if its steps differ.

    Steps equal within UNIFORM_SPREAD of their mean count as uniform (a grid built
    by ``np.arange`` or read from a log differs in its last digits).
    """
    dt = np.diff(time)
    return float(dt[0]) if dt.size and np.ptp(dt) <= UNIFORM_SPREAD * dt.mean() else None


def actuating_temperature(time, temperature, params):
    """Return the fiber temperature T_f (degC) behind the second thermal lag.

    tau_2 dT_f/dt = T - T_f ('second_thermal_lag' in effects.py), T (degC) at ``time``
    (s) linear between samples; T_f = T when the lag is off.
    """
    tau = params.effects.second_thermal_lag
    if tau <= 0.0:
        return temperature
    start = temperature[0]
    return start + first_order_response(time, temperature - start, tau, held=False)


def first_order_response(time, target, tau, held=True):
    """Return y(t) of tau y' = target - y, y(0) = 0 (units of ``target``; tau in s).

    ``held``: the target is held constant over each interval (zero-order hold,
    exact); otherwise it is taken linear between samples (first-order hold, exact
    for a piecewise-linear target). Uniform or non-uniform time grids.
    """
    time = np.asarray(time, dtype=float)
    target = np.asarray(target, dtype=float)
    out = np.zeros_like(target)
    if time.size < 2:
        return out
    dt = np.diff(time)
    if tau <= 0.0:
        return target.copy() if not held else np.concatenate(([0.0], target[:-1]))
    step = uniform_step(time)
    if step is not None:
        a = math.exp(-step / tau)
        if held:
            out[1:] = lfilter([1.0 - a], [1.0, -a], target[:-1])
        else:
            # y_{k+1} = a y_k + (1 - a) u_{k+1} - (a - c)(u_{k+1} - u_k), c = (1 - a) tau / dt
            c = (1.0 - a) * tau / step
            b0, b1 = 1.0 - c, c - a
            out[1:] = lfilter([b0, b1], [1.0, -a], target[1:], zi=[b1 * target[0]])[0]
        return out
    for k, h in enumerate(dt):
        a = math.exp(-h / tau)
        if held:
            out[k + 1] = a * out[k] + (1.0 - a) * target[k]
        else:
            c = (1.0 - a) * tau / h
            out[k + 1] = a * out[k] + (1.0 - c) * target[k + 1] + (c - a) * target[k]
    return out


def delayed_input(time, values, delay):
    """Return the zero-order-hold signal ``values`` delayed by ``delay`` (s).

    Each interval [t_k, t_k+1) carries the mean of the delayed signal over it, so
    the heat delivered is preserved and the result is continuous in ``delay``
    (what a gradient-based fit needs). Before the record starts the signal is
    its first value.
    """
    values = np.asarray(values, dtype=float)
    if delay <= 0.0 or values.size < 2:
        return values
    time = np.asarray(time, dtype=float)
    # cumulative integral of the held signal, evaluated at shifted interval ends
    dt = np.diff(time)
    integral = np.concatenate(([0.0], np.cumsum(values[:-1] * dt)))

    def cumulative(t):
        t = np.asarray(t, dtype=float)
        before = np.minimum(t - time[0], 0.0) * values[0]
        k = np.clip(np.searchsorted(time, t, side='right') - 1, 0, time.size - 1)
        inside = integral[k] + values[k] * (np.maximum(t, time[0]) - time[k])
        return np.where(t < time[0], before, inside)

    start, end = time[:-1] - delay, time[1:] - delay
    out = values.copy()
    out[:-1] = (cumulative(end) - cumulative(start)) / dt
    out[-1] = out[-2]
    return out
