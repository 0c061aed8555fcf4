"""The kinetostatic model of a TCA chosen by name, and its centreline for display.

One entry point over the three readings of the kinetostatics: the Cosserat rod table
(eq. 18's f_rod, ``rod_model`` for a helix, ``conical_table`` for a conical spiral), and
the two closed forms of a uniform helix (CST, Love; ``kinetostatics``). It sits above all
of them, so that none of them needs to know the others.
"""
import numpy as np

from tca_ros.model.conical_table import cached_conical_model
from tca_ros.model.kinetostatics import CstModel, LoveModel
from tca_ros.model.rod_model import cached_rod_model, helix_centreline_at

_CLOSED_FORMS = {'love': LoveModel, 'cst': CstModel}


def make_kinetostatic_model(params, name=None):
    """Return the kinetostatic model ``name`` (rod | cst | love; default params.model).

    A conical coil has only the rod model (cst and love assume a uniform helix); the rod
    tables are cached per TCA and shared by every simulator and the centreline.
    """
    name = name or params.model
    if params.coil.shape == 'conical':
        if name != 'rod':
            raise ValueError(f'model = {name!r}: a conical TCA needs the rod model (cst and '
                             'love assume a uniform helix)')
        return cached_conical_model(params)
    if name == 'rod':
        return cached_rod_model(params)
    if name not in _CLOSED_FORMS:
        raise ValueError(f'model = {name!r}: must be one of rod, cst, love')
    return _CLOSED_FORMS[name](params)


def centreline(params, elongation, temperature, n_points=200):
    """Return the centreline of the TCA at elongation y (m) and temperature T (degC).

    Helix: the exact uniform helix at the tension f_rod(y, T), clamp at z = 0, free end
    below (rod_model.helix_centreline_at). Conical: the hanging cone from the rod branches
    of its table, apex clamp at the origin.

    Returns
    -------
    ndarray, shape (3, n_points)
        Positions (m) in the clamp's frame; n_points >= 2.
    """
    if int(n_points) < 2:
        raise ValueError(f'n_points = {n_points!r}: must be >= 2')
    if params.coil.shape == 'helix':
        return helix_centreline_at(params, elongation, temperature, n_points)
    shape = cached_conical_model(params).centreline(elongation, temperature)
    pick = np.linspace(0.0, shape.shape[1] - 1.0, int(n_points))
    return np.array([np.interp(pick, np.arange(shape.shape[1]), row) for row in shape])
