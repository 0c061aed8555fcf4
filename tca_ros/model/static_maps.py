"""Static equilibrium maps y_eq(T) of the quasi-static reduction, and their cache.

The map solves f_rod(y, T) = F (eq. (18) at rest) on a temperature grid with the
configured kinetostatic model (the exact uniform helix for the rod model, Newton
for cst and love) and the axial stiffness there; quasistatic.QuasiStaticPlant
interpolates it. Maps are cached between plants of the same mechanics and load.
"""
import collections
import math

import numpy as np

from tca_ros.model.kinetostatic_models import make_kinetostatic_model
from tca_ros.model.rod_model import helix_elongation

MAP_MARGIN = 4.0  # K beyond the lowest and highest temperature of a record
MAP_EXTENSION = 30.0  # K added when a map must grow
STIFFNESS_LOAD_STEP = 1e-4  # relative load step for k = dF / dy of the static map
MAP_CACHE_SIZE = 64  # static maps kept between plants (a fit changes thermal values most)


class QuasiStaticUnsupported(ValueError):
    """The reduction cannot represent this TCA or input: use simulation.simulate."""


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


def cached_map(key):
    """Return the cached static map of ``key`` (its last use now), or None."""
    entry = _MAP_CACHE.get(key)
    if entry is not None:
        _MAP_CACHE.move_to_end(key)
    return entry


def store_map(key, entry):
    """Keep the static map ``entry`` under ``key``; beyond MAP_CACHE_SIZE, drop the oldest."""
    _MAP_CACHE[key] = entry
    _MAP_CACHE.move_to_end(key)
    while len(_MAP_CACHE) > MAP_CACHE_SIZE:
        _MAP_CACHE.popitem(last=False)


def map_covers(entry, low, high):
    """Return True when a cached map ``entry`` spans [low, high] (degC) with margins."""
    return entry is not None and entry[0][0] <= low - MAP_MARGIN \
        and entry[0][-1] >= high + MAP_MARGIN
