"""The numbers behind the rig figures of docs/rigs.md (bench/plot_rigs.py), rod model.

Each figure is checked against the rigs' statics (physics) and against the values
docs/rigs.md quotes (to their printed precision), not on its pixels.
"""
import importlib.util
import pathlib

import numpy as np
import pytest

SCRIPT = pathlib.Path(__file__).resolve().parents[1] / 'bench' / 'plot_rigs.py'
_spec = importlib.util.spec_from_file_location('plot_rigs', SCRIPT)
plot_rigs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(plot_rigs)

SPRING_LAG = 0.5 / (22.5 + 20.0)  # s, b_t / (k + k_s): the end trails its rest point
JOINT_LAG = (2e-4 + 2 * 0.01 ** 2 * 0.5) / (0.01 ** 2 * 2 * 22.5)  # s, c_eff / (r^2 2k)
TABLE_RTOL = 1e-3  # the rod dynamics table against the exact helix of the statics, and
TABLE_ERROR = 4e-6  # m as a displacement (docs/rod.md: at most 3.8 um, free-stroke)


def _trailing(values, index, lag):
    """Return the distance a quantity moving at its last slope covers in 2 lags."""
    slope = (values[index] - values[index - 1]) / plot_rigs.SAMPLE
    return 2.0 * lag * abs(slope)


def test_spring_figure_follows_the_statics_and_the_quoted_numbers():
    c = plot_rigs.spring_case('rod')
    idx = [int(round(t / plot_rigs.SAMPLE)) for t in c['statics_time']]
    for k, i in enumerate(idx):
        slack = _trailing(c['displacement'], i, SPRING_LAG)
        assert abs(c['displacement'][i] - c['statics_displacement'][k]) <= \
            slack + TABLE_ERROR
    end = int(round(20.0 / plot_rigs.SAMPLE))  # end of heating, quoted in docs/rigs.md
    assert c['temperature'][end] == pytest.approx(100.2, abs=0.05)
    assert c['displacement'][end] == pytest.approx(4.77e-3, abs=5e-6)
    assert c['force'][end] == pytest.approx(0.1454, abs=5e-5)
    assert c['force'][end] == pytest.approx(0.05 + 20.0 * c['displacement'][end], rel=1e-4)


def test_isometric_figure_reaches_the_statics_force_at_each_power():
    steady, simulated = plot_rigs.isometric_curve('rod', [0.0, 1.0, 2.0])
    assert steady[0] == pytest.approx(0.05, rel=1e-9)  # unheated: the pretension
    # 30 s is 10 thermal time constants: T within 4e-3 K of steady state
    np.testing.assert_allclose(simulated, steady, rtol=TABLE_RTOL)
    assert steady[1] == pytest.approx(0.2636, abs=5e-5)  # quoted in docs/rigs.md
    assert steady[2] == pytest.approx(0.690, abs=5e-4)


def test_antagonistic_figure_steps_to_the_statics_angles():
    c = plot_rigs.antagonistic_case()
    idx = [int(round(t / plot_rigs.SAMPLE)) for t in c['statics_time']]
    for k, i in enumerate(idx):
        slack = _trailing(c['angle'], i, JOINT_LAG)
        # each muscle's table error moves the joint by at most TABLE_ERROR / (2 r_p)
        assert abs(c['angle'][i] - c['statics_angle'][k]) <= slack + TABLE_ERROR / 0.01
    at = {t: c['angle'][int(round(t / plot_rigs.SAMPLE))] for t in (10.0, 20.0, 30.0)}
    assert at[10.0] == pytest.approx(0.401, abs=5e-4)  # agonist alone: positive
    assert at[20.0] == pytest.approx(0.036, abs=5e-4)  # both hot: back near zero
    assert at[30.0] == pytest.approx(-0.430, abs=5e-4)  # antagonist alone: negative
    force_20 = c['force'][int(round(20.0 / plot_rigs.SAMPLE))]
    assert force_20 == pytest.approx(0.254, abs=5e-4)  # co-contraction: 5x the pretension
