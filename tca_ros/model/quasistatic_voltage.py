"""The quasi-static TCA under a constant-voltage supply: eq. (1) with P = V^2 / R(T, x).

Under a voltage supply the heating power follows the resistance (eq. (1) with
the electrical law of resistance.py), which follows the temperature and the
elongation, so eq. (1) cannot be filtered in one pass: it is stepped sample by
sample (Heun on 1/R) by the steps of thermal.py the full dynamics takes, with the
static maps of a QuasiStaticPlant (quasistatic.py) read from a fine table.
"""
import math

import numpy as np

from tca_ros.model import effects as fx
from tca_ros.model import quasistatic_effects as qe
from tca_ros.model.quasistatic_signals import delayed_input
from tca_ros.model.resistance import resistance
from tca_ros.model.static_maps import MAP_EXTENSION, MAP_MARGIN
from tca_ros.model.thermal import heat_decay, heat_march_rk4, heat_step_exact, HeatBalance, \
    lag_step

VOLTAGE_TABLE_STEP = 0.1  # K, fine table of the static map read by the voltage-drive loop
VOLTAGE_POWER_MARGIN = 2.0  # bound on P R0 / R over P (RK4 substeps of a voltage supply)


def voltage_drive(plant, time, power, acting, creep):
    """Return (T, T_f) (degC) of eq. (1) stepped with P = P_nominal R0 / R(T, x).

    ``plant``: the QuasiStaticPlant whose static maps are read; ``time`` (s),
    logged ``power`` (W) and the ``acting`` load (N) per sample.

    Sample by sample: thermal.heat_step_exact while eq. (1) is linear,
    thermal.heat_step_rk4 (substeps of quasistatic_effects) with radiation or
    nonlinear convection, thermal.lag_step for the second lag. The static
    maps are sampled once on a fine temperature grid (VOLTAGE_TABLE_STEP) and
    read by linear interpolation in the loop, at the actuation temperature
    (play operator with hysteresis); R(T, x) sees the end with the creep
    elongation ``creep`` (m) added. T_f is the fiber temperature behind the
    second thermal lag.
    """
    p = plant.params
    e, effects = p.electrical, p.effects
    balance = HeatBalance.of(p)
    intervals = np.diff(time)
    decay = heat_decay(intervals, balance)
    lag = effects.second_thermal_lag
    nominal = delayed_input(time, np.asarray(power, dtype=float), effects.dead_time)  # W at R0
    start_load = fx.friction_start_load(effects)  # N: where in its band the end starts
    y_ref = plant.reference_elongation(float(acting[0]) + start_load)
    length = plant.kinetostatics.natural_length + y_ref
    t0 = p.thermal.ambient_temperature
    n = time.size
    temp = np.full(n, plant.ambient)
    fiber = np.full(n, plant.ambient)
    width = effects.hysteresis_width
    actuation = fiber if width <= 0.0 else np.full(n, plant.ambient)  # degC, play output
    substeps = None if balance.linear else qe.rk4_substeps(
        intervals, VOLTAGE_POWER_MARGIN * nominal[:-1], balance)
    y_eq = np.empty(n)
    position = y_eq  # m, the end as R(T, x) sees it: with friction, the play output
    if effects.friction_force > 0.0:
        position = np.empty(n)
    tables = {}
    top = qe.equilibrium_bound(VOLTAGE_POWER_MARGIN * float(np.max(nominal, initial=0.0)),
                               balance) + 20.0  # degC, also without convection

    def table(load, t_fiber):
        entry = tables.get(load)
        if entry is None or t_fiber > entry[0] + entry[1] * (entry[2].size - 2):
            high = max(top, t_fiber + MAP_EXTENSION)
            grid = np.arange(plant.ambient - MAP_MARGIN, high, VOLTAGE_TABLE_STEP)
            entry = tables[load] = (float(grid[0]), VOLTAGE_TABLE_STEP,
                                    plant.lookup(load, grid)[0])
        return entry

    def lookup(load, t_fiber):
        if not math.isfinite(t_fiber):
            raise ArithmeticError(f'voltage supply: temperature {t_fiber!r} degC')
        g0, dg, y = table(load, t_fiber)
        u = max((t_fiber - g0) / dg, 0.0)
        i = min(int(u), y.size - 2)
        w = u - i
        return y[i] + w * (y[i + 1] - y[i])  # m, y_eq (the stop in contact)

    def advance(k, inverse_r):
        drive = nominal[k] * e.resistance * inverse_r  # W, logged: P R0 / R(T, x)
        if substeps is None:
            temp[k + 1] = heat_step_exact(temp[k], drive, decay[k], balance)
        else:
            m = int(substeps[k])
            temp[k + 1] = heat_march_rk4(float(temp[k]), (float(drive),) * m,
                                         (intervals[k] / m,) * m, balance)[-1]
        fiber[k + 1] = lag_step(fiber[k], temp[k + 1], intervals[k], lag)
        if actuation is not fiber:
            actuation[k + 1] = fx.play_operator(fiber[k + 1], actuation[k], width)
        y_eq[k + 1] = lookup(float(acting[k + 1]), actuation[k + 1])
        if position is not y_eq:  # friction: the end stays in its band (no lag here)
            band = [lookup(float(acting[k + 1]) + offset, actuation[k + 1])
                    for offset in plant.friction_offsets()]
            position[k + 1] = fx.friction_play(position[k], band[:2], band[2:])

    def inverse_resistance(i):
        r = resistance(temp[i], y_ref - position[i] - creep[i], length, e, t0)
        if not r > 0.0:
            raise ArithmeticError(f'voltage supply: resistance {r:g} ohm is not positive')
        return 1.0 / r

    y_eq[0] = lookup(float(acting[0]), fiber[0])
    position[0] = lookup(float(acting[0]) + start_load, fiber[0])
    for k in range(n - 1):
        # Heun: the power of each interval is the mean of 1/R at its two ends
        first = inverse_resistance(k)
        advance(k, first)
        advance(k, 0.5 * (first + inverse_resistance(k + 1)))
    return temp, fiber
