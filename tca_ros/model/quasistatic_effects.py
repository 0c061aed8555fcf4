"""The nonlinear and history-dependent effects in the quasi-static reduction.

quasistatic.py reduces eq. (18) to the thermal response (1), the static maps
y_eq(F, T) and a first-order mechanical lag. Four catalogue effects (effects.py)
change that chain; each is reproduced here as dynamics.py applies it:

    radiation, nonlinear_convection   eq. (1) with the loss                 (1')
        m_t c_p dT/dt = P_in - Q(T),
        Q(T) = h c_s A_0 (T - T_inf) (|T - T_inf| / dT_ref)^n
               + eps sigma A_0 ((T + 273.15)^4 - (T_inf + 273.15)^4)
    hysteresis                        T_a = play(T_f; width), T_f the fiber temperature
                                      behind the second lag; y_eq(F, T_a), k(F, T_a)
    creep                             tau_c dy_c/dt = C f_rod - y_c, y_c(0) = 0;
                                      q = y_coil + y_c, coil contact on y_coil

Eq. (1') is written once, in thermal.py (HeatBalance, heat_loss, heat_step_rk4):
the reduction steps it by the full dynamics' own classical Runge-Kutta step under
zero-order-hold power, but on the record's own grid: each interval is split into
the fewest equal substeps with h lambda <= RK4_STEP_RATE, lambda = Q'(T) / (m_t c_p)
at the hottest temperature the heating can reach. The play operator is rate
independent, so applying it at the samples equals the 1 kHz stepper whenever T_f
is monotonic between samples. The creep element sees the tension f_rod = F of the
free end (with friction, the rod tension of the friction band); it is an exact
first-order filter of the tension held over each interval. In coil contact the
stepper's f_rod(stop, T) exceeds F and the reduction keeps F (the free-stroke TCA
reaches contact only near 250 degC).

References
----------
[1] J. Sun and J. Zhao, IEEE Trans. Robot., 2022 (eq. (1), (18)).
[2] effects.py: creep_rate, play_operator; thermal.py: heat_loss (radiation and
    nonlinear convection).
"""
import math

import numpy as np
from scipy.signal import lfilter

from tca_ros.model.thermal import heat_loss, heat_loss_slope, heat_march_rk4

RK4_STEP_RATE = 0.2  # largest h lambda per RK4 substep: local error ~ (h lambda)^5 / 120
BRACKET_START = 1.0  # K, first temperature rise tried when bracketing the hottest state
BRACKET_LIMIT = 1e5  # K, rise beyond which the bracket gives up (no finite heating gets there)
BISECTIONS = 60  # halvings of the bracket: 1e5 K / 2^60, far below a rounding error
ONSET_RESOLUTION = 1e-6  # fraction of an interval below which an onset is not inserted


def equilibrium_bound(power, balance):
    """Return the temperature (degC) where eq. (1') rests under the logged ``power`` (W).

    Where the loss Q(T) (thermal.heat_loss) carries the heating (1 - eta) r P. Q rises
    monotonically with T, so from ambient under power held at most P the fiber never
    passes this temperature (nor, for negative P, falls below it). ``balance`` is
    the thermal.HeatBalance of the TCA.
    """
    heating = balance.gain * power  # W, heating the fiber
    if heating == 0.0:
        return balance.ambient
    direction = math.copysign(1.0, heating)
    low, high = 0.0, BRACKET_START
    while direction * heat_loss(balance.ambient + direction * high, balance) < abs(heating):
        low, high = high, 2.0 * high
        if high > BRACKET_LIMIT:
            raise ArithmeticError(f'eq. (1): no equilibrium for heating {heating:g} W')
    for _ in range(BISECTIONS):
        middle = 0.5 * (low + high)
        if direction * heat_loss(balance.ambient + direction * middle, balance) < abs(heating):
            low = middle
        else:
            high = middle
    return balance.ambient + direction * high


def rk4_substeps(intervals, power, balance, start=None):
    """Return the RK4 substeps (int array) of each interval (s) under logged ``power`` (W).

    The fewest equal substeps with h lambda <= RK4_STEP_RATE, lambda = Q'(T) / m_t c_p
    (1/s, thermal.heat_loss_slope) at the hottest (and coldest) equilibrium the
    power can reach, or at the ``start`` temperature (degC) when that is hotter; Q'
    grows away from ambient, so that bounds lambda over the record.
    """
    power = np.asarray(power, dtype=float)
    extremes = {float(np.max(power, initial=0.0)), float(np.min(power, initial=0.0))}
    hottest = [equilibrium_bound(p, balance) for p in extremes]
    if start is not None:
        hottest.append(start)
    rate = max(heat_loss_slope(t, balance) for t in hottest) / balance.capacity
    return np.maximum(1, np.ceil(np.asarray(intervals) * rate / RK4_STEP_RATE)).astype(int)


def nonlinear_thermal_response(time, power, balance, rise=0.0):
    """Return T (degC) at ``time`` (s) of eq. (1') under zero-order-hold ``power`` (W).

        m_t c_p dT/dt = (1 - eta) r P - Q(T),  T(0) = T_inf + rise

    ``power`` is the logged power over each interval [t_k, t_k+1) (already delayed
    by the dead time), ``balance`` the thermal.HeatBalance of the TCA (the thermal
    effects: radiation, nonlinear convection, the power ratio and loss), ``rise``
    (K) the start's excess over ambient (0: at rest). thermal.heat_step_rk4 with
    rk4_substeps equal substeps per interval.
    """
    time = np.asarray(time, dtype=float)
    power = np.asarray(power, dtype=float)
    out = np.empty(time.size)
    if time.size == 0:
        return out
    out[0] = balance.ambient + rise
    intervals = np.diff(time)
    substeps = rk4_substeps(intervals, power[:-1], balance, out[0] if rise > 0.0 else None)
    held = power[:-1]
    if substeps.max(initial=1) > 1:
        intervals = np.repeat(intervals / substeps, substeps)
        held = np.repeat(held, substeps)
    temps = heat_march_rk4(float(out[0]), held.tolist(), intervals.tolist(), balance)
    out[1:] = np.asarray(temps)[np.cumsum(substeps) - 1]
    return out


def hysteretic_temperature(time, temperature, width):
    """Return (t (s), T_a (degC), samples): the actuation temperature of 'hysteresis'.

        T_a,k = min(max(T_a,k-1, T_k - w/2), T_k + w/2),  T_a,0 = T_0

    The play operator (effects.play_operator) of width w (K) along ``temperature``
    (degC) at ``time`` (s), from the settled start as the stepper applies it. Where
    T_a is held at t_k and moves by t_k+1, the instant t* at which T (linear
    between samples) reaches the edge T_a,k -+ w/2 is inserted with T_a(t*) = T_a,k
    (also when T turns and crosses the whole band within the interval):
    the stroke starts to move there, and a lag filter of y_eq(T_a) taken linear
    between samples would spread that onset over the interval (up to 0.14 mm at
    5-10 Hz on the free-stroke TCA). ``samples`` indexes the input instants in the
    returned arrays (a slice when nothing was inserted).
    """
    time = np.asarray(time, dtype=float)
    temperature = np.asarray(temperature, dtype=float)
    if width <= 0.0 or temperature.size == 0:
        return time, temperature, slice(None)
    half = 0.5 * width
    values, times = temperature.tolist(), time.tolist()
    instants, actuation, samples = [times[0]], [values[0]], [0]
    state = previous = values[0]
    moving = 0  # -1, 0, +1: the output's motion at the previous sample
    for k in range(1, len(values)):
        now = values[k]
        # effects.play_operator, min(max(state, T - w/2), T + w/2), written out: the
        # loop runs once per sample of every fit evaluation
        if state < now - half:
            state, direction = now - half, 1
        elif state > now + half:
            state, direction = now + half, -1
        else:
            direction = 0
        if direction and direction != moving:  # starts to move within this interval
            edge = actuation[-1] + direction * half  # where T leaves the band held at t_k-1
            fraction = (edge - previous) / (now - previous)
            if ONSET_RESOLUTION < fraction < 1.0 - ONSET_RESOLUTION:
                instants.append(times[k - 1] + fraction * (times[k] - times[k - 1]))
                actuation.append(actuation[-1])
        samples.append(len(instants))
        instants.append(times[k])
        actuation.append(state)
        previous, moving = now, direction
    if len(instants) == time.size:
        return time, np.array(actuation), slice(None)
    return np.array(instants), np.array(actuation), np.array(samples)


def creep_elongation(time, tension, effects):
    """Return the creep elongation y_c (m) at ``time`` (s), 'creep' (effects.creep_rate).

        tau_c dy_c/dt = C F - y_c,  y_c(0) = 0

    The Kelvin-Voigt element in series with the coil: C the compliance (m/N),
    tau_c the retardation time (s), F the rod tension (N) held over each interval
    [t_k, t_k+1) (``tension[k]``; the last value unused). Exact per interval.
    """
    time = np.asarray(time, dtype=float)
    target = effects.creep_compliance * np.asarray(tension, dtype=float)
    out = np.zeros(time.size)
    if time.size < 2 or effects.creep_compliance <= 0.0:
        return out
    intervals = np.diff(time)
    decay = np.exp(-intervals / effects.creep_time_constant)
    if np.ptp(intervals) <= 1e-9 * intervals.mean():  # uniform grid: one recursive filter
        a = float(decay[0])
        out[1:] = lfilter([1.0 - a], [1.0, -a], target[:-1])
        return out
    for k, a in enumerate(decay):
        out[k + 1] = a * out[k] + (1.0 - a) * target[k]
    return out
