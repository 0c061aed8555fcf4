"""The fiber's heat balance, eq. (1) of [1], stepped under the drive's dead time.

    m_t c_p dT/dt = -h c_s A_0 (T - T_inf) + P_in                        (1)

with the thermal effects of effects.py (radiation, nonlinear convection, a
delivered-power ratio) written in thermal.py, and here the drive's dead time.
The power is held over each step (zero-order hold): while eq. (1) is linear its
step is exact, otherwise it is classical Runge-Kutta (error below 1e-9 K per
step for dt <= 10 ms, tau = 3 s). Behind T, the temperature T_f of the second
thermal lag and T_a, the one the untwist sees through the hysteresis (both
effects.py, off at their defaults), advance with it (``ThermalStepper.advance``).
``ThermalStepper`` is held by the stepper of dynamics.py (and its rigs).
"""
import collections
import math

from tca_ros.model import effects as fx
from tca_ros.model.thermal import heat_decay, heat_loss_slope, heat_rate, heat_step_exact
from tca_ros.model.thermal import heat_step_rk4, HeatBalance, lag_step

RK4_REAL_LIMIT = 2.785  # h lambda on the negative real axis where classical RK4 turns unstable
THERMAL_CHECK_RISE = 300.0  # K above ambient at which the nonlinear thermal limit is also taken


class ThermalStepper:
    """Step the fiber temperature T (degC) of eq. (1) under a delayed drive power.

    ``advance`` steps a TcaState's T and, behind it, T_f and T_a (degC).

    Parameters
    ----------
    params : TcaParams
        The TCA: fiber, thermal and effects parameters are read.

    Attributes
    ----------
    balance : HeatBalance
        The coefficients of eq. (1) (thermal.py), the thermal effects included.
    ambient : float
        T_inf (degC), including an ambient offset effect.
    linear : bool
        Whether eq. (1) is linear in T (no radiation, n = 0): exact steps.
    dead_time : float
        Delay d (s) of the drive.
    fiber_lags : bool
        Whether the second thermal lag or the hysteresis is on (T_f, T_a differ from T).
    """

    def __init__(self, params):
        self.params = params
        self.balance = HeatBalance.of(params)
        self.ambient = self.balance.ambient
        self.linear = self.balance.linear
        self.dead_time = params.effects.dead_time  # s
        e = params.effects
        # the fiber lags of T (degC), each off at its default
        self.fiber_lags = e.second_thermal_lag > 0.0 or e.hysteresis_width > 0.0
        self._decay_step = None  # s, the substep self._decay (-) was computed for
        self._decay = None
        self._drive = collections.deque()  # (start time (s), power (W)) for the dead time

    def reset(self):
        """Forget the drive history: no power before the next command."""
        self._drive = collections.deque()

    def delayed(self, power, now, h):
        """Return the mean power (W) over [t - d, t - d + h]: the drive's dead time d (s).

        ``power`` (W) is commanded at ``now`` = t (s) and held over the step h (s);
        before the first command it is zero. Averaging over the delayed interval
        keeps the heat delivered and makes the result continuous in d (a fit can
        move d by less than a step).
        """
        delay = self.dead_time
        if delay <= 0.0:
            return power
        self._drive.append((now, power))
        start, end = now - delay, now - delay + h
        # drop segments that ended before the interval (a segment ends where the next starts)
        while len(self._drive) > 1 and self._drive[1][0] <= start:
            self._drive.popleft()
        energy = 0.0
        for i, (t0, p) in enumerate(self._drive):
            t1 = self._drive[i + 1][0] if i + 1 < len(self._drive) else math.inf
            overlap = min(t1, end) - max(t0, start)
            if overlap > 0.0:
                energy += p * overlap
            if t1 >= end:
                break
        return energy / h

    def advance(self, s, power, h):
        """Advance T (eq. (1)), T_f (second lag) and T_a (hysteresis) of s by h (s).

        ``s`` is a TcaState (temperatures in degC, ``time`` in s); ``power`` (W) is
        commanded at s.time and reaches the fiber after the dead time.
        """
        applied = self.delayed(power, s.time, h) if self.dead_time > 0.0 else power  # W
        s.temperature = temp = self.step(s.temperature, applied, h)
        if self.fiber_lags:
            e = self.params.effects
            s.fiber_temperature = lag_step(s.fiber_temperature, temp, h, e.second_thermal_lag)
            s.actuation_temperature = fx.play_operator(
                s.fiber_temperature, s.actuation_temperature, e.hysteresis_width)
        else:  # both lags off (the common case)
            s.fiber_temperature = s.actuation_temperature = temp

    def rate(self, temp, power):
        """Return dT/dt (K/s) of eq. (1) with the thermal effects at T (degC), P (W)."""
        return heat_rate(temp, power, self.balance)

    def step(self, temp, power, h):
        """Return T (degC) after h (s), power (W) held: exact if linear, else RK4."""
        if self.linear:
            if h != self._decay_step:  # exp(-h G / C) is kept while h is (G, C are fixed)
                self._decay_step = h
                self._decay = heat_decay(h, self.balance)
            return heat_step_exact(temp, power, self._decay, self.balance)
        return heat_step_rk4(temp, power, h, self.balance)

    def limit(self, temp):
        """Return the largest stable substep (s) of the RK4 update at T (degC) (inf if exact).

        The linear eq. (1) is updated exactly. With radiation or nonlinear convection
        RK4 needs h lambda < 2.785, lambda = d(loss)/dT / (m c_p), taken at ``temp``
        and THERMAL_CHECK_RISE above ambient (the temperature rises between re-checks).
        """
        if self.linear:
            return math.inf
        b = self.balance
        rate = 0.0
        for t in (temp, self.ambient + THERMAL_CHECK_RISE):
            rate = max(rate, heat_loss_slope(t, b) / b.capacity)
        return RK4_REAL_LIMIT / rate if rate > 0.0 else math.inf
