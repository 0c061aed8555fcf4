"""The pair's hot path (bench_rigs, issue 11) against a plain step-by-step evaluation.

AntagonisticPair steps through ForceTable.force_at (the Hermite cells written out),
a kept exp(-h G / C) and switches read once per simulator. The reference below
steps Eqs. (R5)-(R7) and the exact eq. (1) as written, with none of that: a fresh
exp each substep, heating_power each substep, the table through evaluate(). The
two must agree to 1e-12 (they are bit-identical today), so a speed-up cannot
drift the physics.
"""
import math

import numpy as np
import pytest

from tca_ros.model import effects as fx
from tca_ros.model.rigs import AntagonisticPair
from tca_ros.model.rod_table import RodTableError
from tca_ros.model.tca_params import EffectParams
from tca_ros.model.thermal import heat_capacity, thermal_conductance
from tca_ros.params.files import load_params

RTOL = 1e-12  # relative agreement demanded of every compared quantity


@pytest.fixture(scope='module')
def pair_params():
    return load_params('free_stroke', model='rod', **{'rig.mode': 'antagonistic'})


class ReferencePair:
    """Eqs. (R5)-(R7) and eq. (1), one plain substep at a time (no kept values)."""

    def __init__(self, pair):
        p = pair.params
        assert p.effects == EffectParams()  # the reference has no effects
        self.params, self.table = p, pair.kinetostatics._table
        self.r, self.J, self.c = pair.radius, pair.inertia, pair.damping
        self.q0, self.contact = pair.reference, pair.agonist._contact
        self.rest = pair.agonist.reference_elongation  # m, displacement reference
        self.angle, self.previous = pair.angle, pair.previous_angle
        self.temps = [pair.agonist.state.temperature, pair.antagonist.state.temperature]
        self.tensions = [pair.agonist.state.tension, pair.antagonist.state.tension]
        self.velocity = 0.0

    def substep(self, powers, h):
        p, r = self.params, self.r
        force_1, force_2 = (max(f, 0.0) for f in self.tensions)  # Eq. (R6)
        a, c = self.J / (h * h), self.c / (2.0 * h)  # Eq. (R7), central differences
        theta = self.angle
        nxt = (r * (force_1 - force_2) + a * (2.0 * theta - self.previous)
               + c * self.previous) / (a + c)
        high, low = (self.q0 - self.contact) / r, (self.contact - self.q0) / r
        if not low <= nxt <= high:  # a coil in contact stops the joint
            nxt = min(max(nxt, low), high)
            theta = nxt
        self.previous, self.angle = theta, nxt
        self.velocity = (nxt - theta) / h
        ambient = fx.true_ambient(p.thermal, p.effects)
        conductance = thermal_conductance(p.fiber, p.thermal)
        for i, sign in enumerate((-1.0, 1.0)):
            target = ambient + fx.heating_power(
                powers[i], p.effects, p.thermal.delivered_power_ratio) / conductance
            self.temps[i] = target + (self.temps[i] - target) * math.exp(
                -h * conductance / heat_capacity(p.fiber))  # eq. (1), exact
            q = self.q0 + sign * r * nxt  # Eq. (R5)
            self.tensions[i] = self.table.evaluate(max(q, self.contact), self.temps[i])[0]

    def sample(self):
        """Return angle, velocity, temperatures, displacements and tensions."""
        shift = self.r * self.angle
        return [self.angle, self.velocity, *self.temps, self.rest - (self.q0 - shift),
                self.rest - (self.q0 + shift), *self.tensions]


def _sample(pair):
    a, b = pair.agonist.state, pair.antagonist.state
    return [pair.angle, pair.velocity, a.temperature, b.temperature, a.displacement,
            b.displacement, a.tension, b.tension]


def _run_both(pair, schedule, angle=0.0):
    """Step the pair and the reference through (steps, P_1 W, P_2 W, dt s) segments."""
    pair.reset(angle=angle)
    ref = ReferencePair(pair)
    got, want = [], []
    for steps, power_1, power_2, dt in schedule:
        if dt != pair.dt:
            pair.set_dt(dt)
        for _ in range(steps):
            pair.step(power_1, power_2=power_2)
            n = pair.plan.count  # the substeps this step took (re-planned every 100 steps)
            for _ in range(n):
                ref.substep((power_1, power_2), pair.dt / n)
            got.append(_sample(pair))
            want.append(ref.sample())
    return np.array(got), np.array(want)


def _assert_close(got, want):
    scale = np.max(np.abs(want), axis=0)  # per quantity, for the ones passing zero
    np.testing.assert_array_less(np.abs(got - want), RTOL * np.maximum(np.abs(want), scale)
                                 + 1e-300)


def test_pair_steps_as_the_plain_equations_through_heating_cooling_and_a_new_dt(
        pair_params):
    pair = AntagonisticPair(pair_params, dt=1e-3)
    got, want = _run_both(pair, [(2000, 3.0, 0.0, 1e-3), (4000, 0.0, 3.0, 5e-4),
                                 (500, 0.5, 0.5, 2e-3)])
    assert got[1999, 0] > 0.5 and got[5999, 0] < -0.3  # the joint turned both ways
    assert got[:, 2:4].max() > 120.0  # both muscles crossed many table rows
    _assert_close(got, want)


def test_pair_at_its_stop_steps_as_the_plain_equations(pair_params):
    """Started past the agonist's coil contact: the stop and the clamped end run."""
    pair = AntagonisticPair(pair_params, dt=1e-3)
    high = (pair.reference - pair.agonist._contact) / pair.radius  # rad, the stop
    got, want = _run_both(pair, [(300, 0.0, 0.0, 1e-3)], angle=high + 0.05)
    assert got[0, 0] == pytest.approx(high) and got[-1, 0] < high - 0.1
    _assert_close(got, want)


def test_force_at_equals_evaluate_everywhere_in_and_beyond_the_table(pair_params):
    table = AntagonisticPair(pair_params).kinetostatics._table
    span = table.eta_step[0] * (table.n_eta - 1)
    temps = np.linspace(table.temp0 - 10.0, table.top, 97)  # below: clamped
    etas = np.linspace(table.eta0[0] - 0.2 * span, table.eta0[0] + 1.2 * span, 151)
    for temp in temps:
        for eta in etas:
            y = float(eta) + table.free[0]
            assert table.force_at(y, float(temp)) == table.evaluate(y, float(temp))[0]
    for temp in (table.top + 1e-9, math.nan):
        with pytest.raises(RodTableError, match='beyond the rod table'):
            table.force_at(0.0, temp)
