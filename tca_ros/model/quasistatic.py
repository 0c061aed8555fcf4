"""Quasi-static reduction of the TCA dynamics for fast identification.

When the mechanical time scales (sqrt(m / k) ~ 10-50 ms, b_t / k ~ 10-100 ms) are
far below the thermal one (eq. (1), seconds), eq. (18) reduces to

    T(t)  from eq. (1), exact under zero-order-hold power          (1)
    y_eq  with f_rod(y_eq, T) = F,  y >= y_contact                 (18), m = 0, b = 0
    tau_m dy/dt = y_eq - y,  tau_m = b_t / k(y_eq, T)              first-order lag

The static map y_eq(T) is solved by the configured kinetostatic model (rod: the
exact uniform helix of the rod model, Newton for cst and love) on a temperature
grid and interpolated; the thermal response is a linear recursive filter. One
simulation of a record then costs a few dozen equilibrium solves instead of one
f_rod evaluation per physics step, which is what makes the joint calibration of
many records fast. ``simulate_quasistatic`` returns the same SimulationResult as
``simulation.simulate``; the test suite measures the difference between the two.

Every effect of the catalogue (effects.py) is represented: modulus softening and
coil contact in the static maps; the linear thermal ones (power loss, ambient
offset), the sensor lag, dead time of the drive, a second thermal lag, Coulomb
friction on the free end (a play operator on the elongation between the static
maps at F -+ F_c, each edge behind the mechanical lag); and, in
quasistatic_effects.py, radiation and nonlinear convection (eq. (1) stepped by RK4
on the record's grid; the linear eq. (1) keeps the exact filter), hysteresis (the
play operator on the actuation temperature before the static maps) and creep (a
Kelvin-Voigt filter of the tension added to the elongation).
``QuasiStaticUnsupported`` remains for a coil that is not a helix (rod model) and
a voltage supply under a load of too many distinct values.
"""
import collections
import math

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import lfilter

from tca_ros.model import effects as fx
from tca_ros.model import quasistatic_effects as qe
from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.kinetostatics import contact_elongation
from tca_ros.model.resistance import resistance
from tca_ros.model.rod_model import helix_elongation, mechanical_params
from tca_ros.model.simulation import SimulationResult
from tca_ros.model.thermal import heat_capacity, thermal_conductance

MAP_TEMP_STEP = 2.0  # K between the static map's grid points (linear interpolation)
MAP_MARGIN = 4.0  # K beyond the lowest and highest temperature of a record
MAP_EXTENSION = 30.0  # K added when a cached map must grow
VOLTAGE_TABLE_STEP = 0.1  # K, fine table of the static map read by the voltage-drive loop
STIFFNESS_LOAD_STEP = 1e-4  # relative load step for k = dF / dy of the static map
MAX_DISTINCT_LOADS = 16  # static maps solved per simulation; beyond, interpolated in load
LOAD_LEVELS = 9  # maps spanning a load that takes more values (ramps)
MAP_CACHE_SIZE = 64  # static maps kept between plants (a fit changes thermal values most)
VOLTAGE_POWER_MARGIN = 2.0  # bound on P R0 / R over P (RK4 substeps of a voltage supply)


class QuasiStaticUnsupported(ValueError):
    """The reduction cannot represent this TCA or input: use simulation.simulate."""


def thermal_response(time, power, params):
    """Return T (degC) at ``time`` (s) under zero-order-hold ``power`` (W), eq. (1).

    Exact for the linear eq. (1): over each interval the temperature relaxes to
    T_inf + P_in / (h c_s A_0) with the time constant m_t c_p / (h c_s A_0). P_in
    is the logged power times ``thermal.delivered_power_ratio`` and (1 - power
    loss), delayed by ``effects.dead_time`` when set; the start is at ambient.
    With radiation or nonlinear convection, eq. (1') of quasistatic_effects (RK4).
    """
    time = np.asarray(time, dtype=float)
    heating = fx.heating_power(np.asarray(power, dtype=float), params.effects,
                               params.thermal.delivered_power_ratio)
    heating = delayed_input(time, heating, params.effects.dead_time)
    balance = qe.HeatBalance.of(params)
    if not balance.linear:
        return qe.nonlinear_thermal_response(time, heating, balance)
    conductance = thermal_conductance(params.fiber, params.thermal)
    tau = heat_capacity(params.fiber) / conductance
    ambient = fx.true_ambient(params.thermal, params.effects)
    return ambient + first_order_response(time, heating / conductance, tau)


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
    if np.ptp(dt) <= 1e-9 * dt.mean():
        a = math.exp(-dt[0] / tau)
        if held:
            out[1:] = lfilter([1.0 - a], [1.0, -a], target[:-1])
        else:
            # y_{k+1} = a y_k + (1 - a) u_{k+1} - (a - c)(u_{k+1} - u_k), c = (1 - a) tau / dt
            c = (1.0 - a) * tau / dt[0]
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


def static_map(model, load, temperatures, stop=None, stiffness_every=4):
    """Return (y_eq (m), k (N/m)) on ``temperatures`` (degC) under ``load`` (N).

    y_eq solves f_rod(y, T) = load (eq. (18) at rest) with the coil-contact stop
    ``stop`` (m, None: no stop); k is the axial stiffness dF/dy there (inf in contact), solved at
    every ``stiffness_every``-th temperature and interpolated (it only sets the
    mechanical lag b / k).
    """
    temps = np.asarray(temperatures, dtype=float)
    step = max(abs(load), 1e-3) * STIFFNESS_LOAD_STEP
    sub = np.unique(np.concatenate((np.arange(0, temps.size, stiffness_every),
                                    [temps.size - 1])))
    many = getattr(model, 'equilibrium_elongations', None)  # one vectorised solve
    solve = getattr(model, 'loaded_equilibrium', model.equilibrium_elongation)
    if many is not None:
        y = np.array(many(load, temps), dtype=float)
    else:
        y = np.empty(temps.size)
        guess = None
        for i, temp in enumerate(temps):
            guess = solve(load, float(temp), guess=guess)
            y[i] = guess
    if not np.all(np.isfinite(y)):
        raise ArithmeticError(f'static map: no equilibrium under load = {load:g} N')
    if many is not None:
        up = np.asarray(many(load + step, temps[sub]), dtype=float)
    else:
        up = np.array([solve(load + step, float(temps[i]), guess=y[i]) for i in sub])
    with np.errstate(invalid='ignore'):
        rising = up > y[sub]
    k_sub = np.where(rising, step / np.where(rising, up - y[sub], 1.0), 1e12)
    k = np.interp(temps, temps[sub], k_sub)
    if stop is not None:
        in_contact = y < stop
        y[in_contact] = stop
        k[in_contact] = math.inf
    return y, k


class ExactHelixStatics:
    """Static equilibrium of the rod model without its dynamics table.

    The rod model's equilibrium of a helical TCA under an axial end load is the
    exact uniform helix (rod_model.helix_elongation); a fit that changes the
    mechanical parameters at every evaluation needs only that, not the
    (elongation, temperature) table the time stepper interpolates.
    """

    name = 'rod'

    def __init__(self, params):
        if params.coil.shape != 'helix':
            raise QuasiStaticUnsupported(
                f'coil.shape = {params.coil.shape!r}: the quasi-static reduction needs a '
                'helix')
        self.params = params
        self.natural_length = params.fiber.length * math.sin(params.coil.pitch_angle)

    def equilibrium_elongation(self, load, temperature, guess=None):
        """Return y (m) with f_rod(y, T) = load (N) at temperature (degC), no contact."""
        return float(helix_elongation(self.params, temperature, load))

    def equilibrium_elongations(self, load, temperatures):
        """Return y (m) per temperature (degC, array) under one load (N): one solve.

        NaN where the exact helix fails (as :meth:`equilibrium_elongation`).
        """
        temps = np.asarray(temperatures, dtype=float)
        return helix_elongation(self.params, temps, np.full(temps.shape, float(load)))


def make_statics(params, model=None):
    """Return the static-equilibrium solver of ``model`` (rod | cst | love)."""
    name = model or params.model
    if name == 'rod':
        return ExactHelixStatics(params)
    return make_kinetostatic_model(params, name)


_MAP_CACHE = collections.OrderedDict()  # (mechanical params, model, load) -> map


def clear_map_cache():
    """Forget every cached static map.

    A map grows when a record needs temperatures beyond it, so what a simulation
    reads depends on the maps earlier calls left; a caller that must give the
    same numbers for the same inputs (a diagnosis, a calibration) starts empty.
    """
    _MAP_CACHE.clear()


def _cached_map(key):
    entry = _MAP_CACHE.get(key)
    if entry is not None:
        _MAP_CACHE.move_to_end(key)
    return entry


def _store_map(key, entry):
    _MAP_CACHE[key] = entry
    _MAP_CACHE.move_to_end(key)
    while len(_MAP_CACHE) > MAP_CACHE_SIZE:
        _MAP_CACHE.popitem(last=False)


def _covers(entry, low, high):
    """Return True when a cached map ``entry`` spans [low, high] (degC) with margins."""
    return entry is not None and entry[0][0] <= low - MAP_MARGIN \
        and entry[0][-1] >= high + MAP_MARGIN


class QuasiStaticPlant:
    """The quasi-static TCA of one parameter set; static maps shared between records.

    Parameters
    ----------
    params : TcaParams
    model : str, optional
        Kinetostatic model rod | cst | love (default ``params.model``).
    temperature_range : (float, float), optional
        Temperatures (degC) the static maps cover; extended on demand.
    """

    def __init__(self, params, model=None, kinetostatics=None):
        self.params = params
        self.kinetostatics = kinetostatics or make_statics(params, model)
        self.ambient = fx.true_ambient(params.thermal, params.effects)
        self.stop = contact_elongation(params)
        # parameter sets with the same mechanics share their static maps (a fit's
        # thermal and damping steps); the ambient and the contact stop are part of it
        self._key = (mechanical_params(params), self.kinetostatics.name,
                     params.effects.ambient_offset) if kinetostatics is None else None
        self._own = {}  # load -> map, for a caller's own kinetostatics (not shared)

    def static_map(self, load, low, high):
        """Return (grid (degC), y_eq (m), k (N/m)) covering [low, high] degC at load (N).

        The grid is aligned to multiples of MAP_TEMP_STEP, so maps extend cleanly.
        """
        cached = self._own.get(load)
        key = None
        if self._key is not None and not _covers(cached, low, high):
            key = self._key + (load,)
            cached = _cached_map(key) or cached
        if _covers(cached, low, high):
            self._own[load] = cached
            return cached
        if cached is not None:  # extend generously: a voltage drive asks degree by degree
            if cached[0][0] > low - MAP_MARGIN:
                low = min(low, cached[0][0] + MAP_MARGIN - MAP_EXTENSION)
            else:
                low = cached[0][0] + MAP_MARGIN
            if cached[0][-1] < high + MAP_MARGIN:
                high = max(high, cached[0][-1] - MAP_MARGIN + MAP_EXTENSION)
            else:
                high = cached[0][-1] - MAP_MARGIN
        first = math.floor((low - MAP_MARGIN) / MAP_TEMP_STEP)
        last = math.ceil((high + MAP_MARGIN) / MAP_TEMP_STEP)
        grid = np.arange(first, last + 1) * MAP_TEMP_STEP
        y, k = static_map(self.kinetostatics, load, grid)
        # a C2 spline of the free equilibrium (contact applied after it): the fit's
        # finite differences must not see interpolation kinks
        entry = (grid, CubicSpline(grid, y), k)
        if self._key is not None:
            _store_map(key or self._key + (load,), entry)
        self._own[load] = entry
        return entry

    def simulate(self, time, power, load=None, supply='power'):
        """Return the SimulationResult of a power (W) and load (N) profile at time (s).

        ``supply``: 'power' (the column is the power delivered) or 'voltage' (the
        column is the nominal power of a constant-voltage supply set at R0:
        P = V^2 / R(T, x) with V^2 = P_nominal R0, so the power follows the
        resistance as the muscle heats and contracts).
        """
        params = self.params
        time = np.asarray(time, dtype=float)
        power = np.asarray(power, dtype=float)
        load = (np.full_like(time, params.dynamics.load) if load is None
                else np.asarray(load, dtype=float))
        # the load acting over [t_k, t_k+1) is load[k]; the equilibrium at t_k+1 uses it
        acting = np.concatenate(([load[0]], load[:-1]))
        distinct = np.unique(acting)
        if distinct.size > MAX_DISTINCT_LOADS and supply == 'voltage':
            raise QuasiStaticUnsupported(
                f'load takes {distinct.size} distinct values; the quasi-static reduction '
                f'solves at most {MAX_DISTINCT_LOADS}: use simulation.simulate')
        e = params.effects
        if supply == 'voltage':
            temperature, fiber = self._voltage_drive(time, power, acting,
                                                     qe.creep_elongation(time, load, e))
        elif supply == 'power':
            temperature = thermal_response(time, power, params)
            fiber = actuating_temperature(time, temperature, params)
        else:
            raise ValueError(f"supply = {supply!r}: must be 'power' or 'voltage'")
        # the mechanical chain runs on ``grid``: the samples, plus the instants at which
        # a hysteretic actuation temperature starts to move (quasistatic_effects)
        grid, actuating, samples = qe.hysteretic_temperature(time, fiber, e.hysteresis_width)
        held = load
        if grid is not time:  # the load held over each interval of the grid
            held = load[np.searchsorted(time, grid, side='right') - 1]
            acting = np.concatenate(([load[0]], held[:-1]))
        y_eq, stiffness = self._equilibria(actuating, acting, distinct)
        y_ref = self._reference(float(load[0]))
        creep = qe.creep_elongation(grid, held, e)  # the free end's tension is the load
        # the coil and the creep element in series: q = y_coil + y_c, behind the lag
        elongation = _mechanical_lag(grid, y_eq + creep, stiffness, params.dynamics.damping)
        tension = acting
        if e.friction_force > 0.0:
            elongation, tension, creep = self._friction(grid, actuating, acting, distinct,
                                                        creep, elongation[0])
        elongation, tension, creep = elongation[samples], tension[samples], creep[samples]
        contraction = y_ref - elongation
        tension = np.where(elongation - creep <= self.stop, np.maximum(tension, 0.0),
                           tension)
        measured = contraction
        if params.effects.sensor_lag > 0.0:  # the sensor starts settled
            measured = contraction[0] + first_order_response(
                time, contraction - contraction[0], params.effects.sensor_lag, held=False)
        r = resistance(temperature, contraction, self.loaded_length(float(load[0])),
                       params.electrical, params.thermal.ambient_temperature)
        velocity = np.gradient(contraction, time) if time.size > 1 else np.zeros_like(time)
        return SimulationResult(time=time, power=power, load=load, displacement=measured,
                                temperature=temperature, resistance=r, tension=tension,
                                velocity=velocity, true_displacement=contraction, substeps=0)

    def _lookup(self, load, temperature):
        """Return (y_eq (m), k (N/m)) at temperatures (degC) under load (N), contact on."""
        temperature = np.asarray(temperature, dtype=float)
        low = min(float(np.min(temperature)), self.ambient)
        high = max(float(np.max(temperature)), self.ambient)
        grid, spline, k_map = self.static_map(load, low, high)
        y = spline(temperature)
        k = np.interp(temperature, grid, k_map)
        contact = y < self.stop
        return np.where(contact, self.stop, y), np.where(contact, math.inf, k)

    def _reference(self, load):
        return float(self._lookup(load, self.ambient)[0])

    def loaded_length(self, load):
        """Return the loaded length l* + y_ref (m) at ambient under ``load`` (N)."""
        return self.kinetostatics.natural_length + self._reference(load)

    def _friction_offsets(self):
        """Return the load offsets (N) of the band edges: -F_s, F_s, -F_k, F_k."""
        e = self.params.effects
        static = e.friction_force * e.static_friction_ratio
        return (-static, static, -e.friction_force, e.friction_force)

    def _friction(self, time, actuating, acting, distinct, creep, start):
        """Return (q (m), f_rod (N), y_c (m)) of the end under Coulomb friction.

        q starts at ``start`` (m). The band edges (the lagged maps at F -+ F_s and
        F -+ F_k, actuation temperature ``actuating`` in degC) move with the creep
        elongation ``creep`` (m). The rod tension of the band, not the load, drives
        the creep: with creep on, it is filtered again from that tension and the
        play run again.
        """
        damping = self.params.dynamics.damping
        offsets = self._friction_offsets()
        edges = [_mechanical_lag(time, *self._equilibria(actuating, acting + offset,
                                                         distinct + offset), damping)
                 for offset in offsets]
        elongation, tension = _friction_response(start, acting, [edge + creep for edge in edges],
                                                 offsets[0])
        if self.params.effects.creep_compliance > 0.0:
            held = np.append(0.5 * (tension[:-1] + tension[1:]), tension[-1])  # per interval
            creep = qe.creep_elongation(time, held, self.params.effects)
            elongation, tension = _friction_response(
                start, acting, [edge + creep for edge in edges], offsets[0])
        return elongation, tension, creep

    def _equilibria(self, actuating, acting, distinct):
        """Return (y_eq (m), k (N/m)) per sample: exact maps per load, or interpolated.

        Up to MAX_DISTINCT_LOADS load values each get their own map; a load that
        takes more values (ramps) is interpolated linearly between maps at
        LOAD_LEVELS loads spanning its range.
        """
        if distinct.size <= MAX_DISTINCT_LOADS:
            y_eq = np.empty_like(actuating)
            stiffness = np.empty_like(actuating)
            for value in distinct:
                sel = acting == value
                y_eq[sel], stiffness[sel] = self._lookup(float(value), actuating[sel])
            return y_eq, stiffness
        levels = np.linspace(distinct[0], distinct[-1], LOAD_LEVELS)
        maps = [self._lookup(float(level), actuating) for level in levels]
        ys = np.array([m[0] for m in maps])
        ks = np.array([m[1] for m in maps])
        i = np.clip(np.searchsorted(levels, acting, side='right') - 1, 0, LOAD_LEVELS - 2)
        w = (acting - levels[i]) / (levels[i + 1] - levels[i])
        cols = np.arange(acting.size)
        y_eq = ys[i, cols] + w * (ys[i + 1, cols] - ys[i, cols])
        with np.errstate(invalid='ignore'):
            stiffness = np.where(np.isfinite(ks[i, cols]) & np.isfinite(ks[i + 1, cols]),
                                 ks[i, cols] + w * (ks[i + 1, cols] - ks[i, cols]), math.inf)
        return y_eq, stiffness

    def _voltage_drive(self, time, power, acting, creep):
        """Return (T, T_f) (degC) of eq. (1) stepped with P = P_nominal R0 / R(T, x).

        Sample by sample: exact per step while eq. (1) is linear, RK4
        (quasistatic_effects) with radiation or nonlinear convection. The static
        maps are sampled once on a fine temperature grid (VOLTAGE_TABLE_STEP) and
        read by linear interpolation in the loop, at the actuation temperature
        (play operator with hysteresis); R(T, x) sees the end with the creep
        elongation ``creep`` (m) added. T_f is the fiber temperature behind the
        second thermal lag.
        """
        p = self.params
        e, effects = p.electrical, p.effects
        conductance = thermal_conductance(p.fiber, p.thermal)
        decay = np.exp(-np.diff(time) * conductance / heat_capacity(p.fiber))
        lag = effects.second_thermal_lag
        lag_decay = np.exp(-np.diff(time) / lag) if lag > 0.0 else None
        nominal = delayed_input(time, fx.heating_power(
            power, effects, p.thermal.delivered_power_ratio), effects.dead_time)
        y_ref = self._reference(float(acting[0]))
        length = self.kinetostatics.natural_length + y_ref
        t0 = p.thermal.ambient_temperature
        n = time.size
        temp = np.full(n, self.ambient)
        fiber = np.full(n, self.ambient)
        width = effects.hysteresis_width
        actuation = fiber if width <= 0.0 else np.full(n, self.ambient)  # degC, play output
        balance = qe.HeatBalance.of(p)
        intervals = np.diff(time)
        substeps = None if balance.linear else qe.rk4_substeps(
            intervals, VOLTAGE_POWER_MARGIN * nominal[:-1], balance)
        y_eq = np.empty(n)
        stiffness = np.empty(n)
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
                grid = np.arange(self.ambient - MAP_MARGIN, high, VOLTAGE_TABLE_STEP)
                y, k = self._lookup(load, grid)
                entry = tables[load] = (float(grid[0]), VOLTAGE_TABLE_STEP, y, k)
            return entry

        def lookup(load, t_fiber):
            if not math.isfinite(t_fiber):
                raise ArithmeticError(f'voltage supply: temperature {t_fiber!r} degC')
            g0, dg, y, k = table(load, t_fiber)
            u = max((t_fiber - g0) / dg, 0.0)
            i = min(int(u), y.size - 2)
            w = u - i
            return y[i] + w * (y[i + 1] - y[i]), k[i] + w * (k[i + 1] - k[i])

        def advance(k, inverse_r):
            heating = nominal[k] * e.resistance * inverse_r
            if substeps is None:
                target = self.ambient + heating / conductance
                temp[k + 1] = target + (temp[k] - target) * decay[k]
            else:
                m = int(substeps[k])
                temp[k + 1] = qe.rk4_thermal_march(float(temp[k]), (float(heating),) * m,
                                                   (intervals[k] / m,) * m, balance)[-1]
            fiber[k + 1] = (temp[k + 1] if lag_decay is None else
                            temp[k + 1] + (fiber[k] - temp[k + 1]) * lag_decay[k])
            if actuation is not fiber:
                actuation[k + 1] = fx.play_operator(fiber[k + 1], actuation[k], width)
            y_eq[k + 1], stiffness[k + 1] = lookup(float(acting[k + 1]), actuation[k + 1])
            if position is not y_eq:  # friction: the end stays in its band (no lag here)
                band = [lookup(float(acting[k + 1]) + offset, actuation[k + 1])[0]
                        for offset in self._friction_offsets()]
                position[k + 1] = fx.friction_play(position[k], band[:2], band[2:])

        def inverse_resistance(i):
            r = resistance(temp[i], y_ref - position[i] - creep[i], length, e, t0)
            if not r > 0.0:
                raise ArithmeticError(f'voltage supply: resistance {r:g} ohm is not positive')
            return 1.0 / r

        y_eq[0], stiffness[0] = lookup(float(acting[0]), fiber[0])
        position[0] = y_eq[0]
        for k in range(n - 1):
            # Heun: the power of each interval is the mean of 1/R at its two ends
            first = inverse_resistance(k)
            advance(k, first)
            advance(k, 0.5 * (first + inverse_resistance(k + 1)))
        return temp, fiber


def simulate_quasistatic(params, time, power, load=None, model=None, kinetostatics=None,
                         supply='power'):
    """Quasi-static simulation of a power (W) and load (N) profile at ``time`` (s).

    Same inputs and SimulationResult as ``simulation.simulate`` (``substeps`` 0).
    The displacement reference is the loaded equilibrium at ambient under
    ``load[0]``; ``supply`` as in QuasiStaticPlant.simulate.
    """
    plant = QuasiStaticPlant(params, model=model, kinetostatics=kinetostatics)
    return plant.simulate(time, power, load, supply=supply)


def _friction_response(start, acting, edges, static_offset):
    """Return (y (m), f_rod (N)) of the end under Coulomb friction, 'friction'.

    ``edges`` are the lagged equilibria (m) at F - F_s, F + F_s, F - F_k, F + F_k
    per sample; y starts at ``start`` (m) and follows effects.friction_play. The
    tension f_rod = F + f is interpolated linearly in y across the static band
    (F -+ F_s at its edges, ``static_offset`` = -F_s in N).
    """
    low_s, high_s, low_k, high_k = edges
    y = np.empty_like(low_s)
    position = start
    out = []
    for ls, hs, lk, hk in zip(low_s.tolist(), high_s.tolist(), low_k.tolist(),
                              high_k.tolist()):
        position = fx.friction_play(position, (ls, hs), (lk, hk))
        out.append(position)
    y[:] = out
    width = np.maximum(high_s - low_s, 1e-15)
    fraction = np.clip((y - low_s) / width, 0.0, 1.0)
    return y, acting + static_offset * (1.0 - 2.0 * fraction)


def _mechanical_lag(time, y_eq, stiffness, damping):
    """Return y(t) of (b / k) y' = y_eq - y, y(0) = y_eq(0) (m).

    Exact per interval for y_eq linear between samples (first-order hold), so a
    ramp is followed with the lag (b / k) dy_eq/dt of the damped quasi-static
    motion; b / k is taken at the interval's end.
    """
    if damping <= 0.0 or time.size < 2:
        return y_eq.copy()
    y = np.empty_like(y_eq)
    y[0] = y_eq[0]
    dt = np.diff(time)
    with np.errstate(divide='ignore'):
        tau = np.where(np.isfinite(stiffness), damping / stiffness, 0.0)[1:]
    tau = np.maximum(tau, 1e-12)
    a = np.exp(-dt / tau)
    c = (1.0 - a) * tau / dt
    # the recursion on Python floats: the same arithmetic, without a NumPy scalar per term
    a, c, target = a.tolist(), c.tolist(), y_eq.tolist()
    out = [target[0]]
    for k in range(len(a)):
        out.append(a[k] * out[k] + (1.0 - c[k]) * target[k + 1] + (c[k] - a[k]) * target[k])
    y[:] = out
    return y
