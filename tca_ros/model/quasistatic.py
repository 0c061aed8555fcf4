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
The static maps and their cache are in static_maps.py, the thermal and input
filters in quasistatic_signals.py; this module puts them together per record.
``QuasiStaticUnsupported`` remains for a coil that is not a helix (rod model) and
a voltage supply under a load of too many distinct values.
"""
import math

import numpy as np
from scipy.interpolate import CubicSpline

from tca_ros.model import effects as fx
from tca_ros.model import quasistatic_effects as qe
from tca_ros.model.kinetostatics import contact_elongation
from tca_ros.model.quasistatic_signals import actuating_temperature, first_order_response, \
    thermal_response
from tca_ros.model.quasistatic_voltage import voltage_drive
from tca_ros.model.resistance import resistance
from tca_ros.model.rod_model import mechanical_params
from tca_ros.model.simulation import read_from_start, SimulationResult
from tca_ros.model.static_maps import cached_map, make_statics, map_covers, MAP_EXTENSION, \
    MAP_MARGIN, QuasiStaticUnsupported, static_map, store_map

MAP_TEMP_STEP = 2.0  # K between the static map's grid points (linear interpolation)
MAX_DISTINCT_LOADS = 16  # static maps solved per simulation; beyond, interpolated in load
LOAD_LEVELS = 9  # maps spanning a load that takes more values (ramps)


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
        if self._key is not None and not map_covers(cached, low, high):
            key = self._key + (load,)
            cached = cached_map(key) or cached
        if map_covers(cached, low, high):
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
            store_map(key or self._key + (load,), entry)
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
        warm = params.thermal.initial_temperature_rise > 0.0
        if supply == 'voltage' and warm:
            raise QuasiStaticUnsupported(
                'thermal.initial_temperature_rise > 0 with a voltage supply: the quasi-static '
                'voltage drive starts at rest; use simulation.simulate')
        if supply == 'voltage':
            temperature, fiber = voltage_drive(self, time, power, acting,
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
        # with friction the end may start held at an edge of its band (effects.py)
        start_load = fx.friction_start_load(e)
        y_ref = self.reference_elongation(float(load[0]) + start_load)
        creep = qe.creep_elongation(grid, held, e)  # the free end's tension is the load
        # the coil and the creep element in series: q = y_coil + y_c, behind the lag
        elongation = _mechanical_lag(grid, y_eq + creep, stiffness, params.dynamics.damping)
        tension = acting
        if e.friction_force > 0.0:
            start = elongation[0] + (self.lookup(float(acting[0]) + start_load,
                                                 actuating[:1])[0][0] - y_eq[0])
            elongation, tension, creep = self._friction(grid, actuating, acting, distinct,
                                                        creep, start)
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
        if warm:  # the sensor reads zero where the record starts, warm
            measured, contraction = read_from_start(measured, contraction)
        velocity = np.gradient(contraction, time) if time.size > 1 else np.zeros_like(time)
        return SimulationResult(time=time, power=power, load=load, displacement=measured,
                                temperature=temperature, resistance=r, tension=tension,
                                velocity=velocity, true_displacement=contraction, substeps=0)

    def lookup(self, load, temperature):
        """Return (y_eq (m), k (N/m)) at temperatures (degC) under load (N), contact on."""
        temperature = np.asarray(temperature, dtype=float)
        low = min(float(np.min(temperature)), self.ambient)
        high = max(float(np.max(temperature)), self.ambient)
        grid, spline, k_map = self.static_map(load, low, high)
        y = spline(temperature)
        k = np.interp(temperature, grid, k_map)
        contact = y < self.stop
        return np.where(contact, self.stop, y), np.where(contact, math.inf, k)

    def reference_elongation(self, load):
        return float(self.lookup(load, self.ambient)[0])

    def loaded_length(self, load):
        """Return the loaded length l* + y_ref (m) at ambient under ``load`` (N)."""
        return self.kinetostatics.natural_length + self.reference_elongation(load)

    def friction_offsets(self):
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
        offsets = self.friction_offsets()
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
                y_eq[sel], stiffness[sel] = self.lookup(float(value), actuating[sel])
            return y_eq, stiffness
        levels = np.linspace(distinct[0], distinct[-1], LOAD_LEVELS)
        maps = [self.lookup(float(level), actuating) for level in levels]
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


def simulate_quasistatic(params, time, power, load=None, model=None, kinetostatics=None,
                         supply='power'):
    """Quasi-static simulation of a power (W) and load (N) profile at ``time`` (s).

    Same inputs and SimulationResult as ``simulation.simulate`` (``substeps`` 0).
    The displacement reference is the loaded equilibrium at ambient under
    ``load[0]`` (with friction under ``load[0]`` + s F_s, where the end starts:
    effects.friction_start_load); ``supply`` as in QuasiStaticPlant.simulate.
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
