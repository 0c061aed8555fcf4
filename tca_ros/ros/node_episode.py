"""The physics of the ``tca`` node's episode as plain Python: no rclpy.

``Episode`` steps the simulator with the commanded power and the load, applies the
limits (max_power clamp, watchdog, max_temperature, melt_temperature), turns a thread
break into a physical event and any other failure of a step into a held, broken
muscle, and samples the outputs (with the configured sensor noise) as plain values.
``Commands`` holds the last valid command and the watchdog. The node's inputs are in
tca_ros.ros.node_core, its clocks in tca_ros.ros.node_clocks; the ROS shell in
tca_ros.ros.node (docs/node.md).
"""
from dataclasses import dataclass
import math
import time
from typing import Optional

import numpy as np

from tca_ros.model.limits import ThreadBreakError
from tca_ros.model.resistance import power_from_voltage
from tca_ros.model.rigs import start_load
from tca_ros.ros.node_tables import muscle_temperatures, table_rows

WARN_PERIOD = 1.0  # s between repeats of a throttled log line
MAX_TEMPERATURE_REARM = 1.0  # K below max_temperature before a new crossing is logged
_CHECKED = ('temperature', 'elongation', 'velocity', 'tension', 'measured_displacement',
            'resistance')


def non_finite(state):
    """Return the name of the first non-finite field of a TcaState, or ''."""
    for name in _CHECKED:
        if not math.isfinite(getattr(state, name)):
            return name
    return ''


class Log:
    """The episode's log: ``log(level, text, key)``; a key throttles its line per WARN_PERIOD.

    ``sink(level, text)`` writes a line (level 'info', 'warning' or 'error'); by default
    the lines are kept in ``lines`` (tests).
    """

    def __init__(self, sink=None):
        self.lines = []
        self._sink = sink or (lambda level, text: self.lines.append((level, text)))
        self._last = {}  # key -> monotonic s of its last line

    def __call__(self, level, text, key=None):
        """Write ``text`` at ``level``, unless ``key`` wrote less than WARN_PERIOD ago."""
        if key is not None:
            now = time.monotonic()
            last = self._last.get(key)
            if last is not None and now - last < WARN_PERIOD:
                return
            self._last[key] = now
        self._sink(level, text)


@dataclass(frozen=True)
class MuscleState:
    """What the node knows about its muscle at one instant (its /diagnostics status).

    Attributes
    ----------
    temperature : float
        Fiber temperature (degC), the model's (no sensor noise); the last finite one
        after a physics failure.
    power : float
        Heating power applied in the last physics step (W).
    displacement : float
        Contraction from the loaded ambient equilibrium (m), held when broken.
    load : float
        External tensile load (N).
    max_temperature, melt_temperature : float
        Overheat and melt limits (degC), the node's parameters.
    command_timeout : float
        Watchdog period (s).
    overheated, broken, watchdog_tripped : bool
        The node's flags; ``broken`` is set by a melt, a thread break and a physics
        failure.
    broken_cause : str
        What broke the muscle ('above melt_temperature 250 degC', 'by its load:
        tension ... exceeds fiber.break_force ...'); '' when not broken.
    failure : str or None
        Why the physics stopped (None while it runs).
    waiting : str
        What the physics waits for before its next step ('' when it runs).
    """

    temperature: float
    power: float
    displacement: float
    load: float
    max_temperature: float
    melt_temperature: float
    command_timeout: float
    overheated: bool = False
    broken: bool = False
    broken_cause: str = ''
    watchdog_tripped: bool = False
    failure: Optional[str] = None
    waiting: str = ''

    def flags(self):
        """Return the fields that set the level and message (a change is published)."""
        return (self.overheated, self.broken, self.broken_cause, self.watchdog_tripped,
                self.failure, self.waiting)


@dataclass(frozen=True)
class Sample:
    """The outputs at one instant, noise included: what the state topics carry.

    time_ns: node time (ns); displacement (m, contraction positive); rate (m/s,
    contraction rate); tension (N); resistance (ohm, inf when broken); temperature
    (degC); power (W, applied over the last step).
    """

    time_ns: int
    displacement: float
    rate: float
    tension: float
    resistance: float
    temperature: float
    power: float


class DeadWeight:
    """The rig of a dead weight: nothing to drive or sample (node_rigs.RigTopics otherwise)."""

    mode = 'dead_weight'

    def drive(self, sim, now_ns, broken):
        """Nothing to set: the load is the node's."""

    def hottest(self, sim):
        """Return the muscle's temperature (degC)."""
        return sim.state.temperature

    def sample(self, sim, broken):
        """Nothing else to sample."""


class Commands:
    """The last valid power or voltage command and the watchdog over it."""

    def __init__(self, log):
        self._log = log
        self.clear()

    def clear(self):
        """Forget the commands: 0 W, no watchdog until the next command."""
        self.drive = ('power', 0.0)  # ('power', W) or ('voltage', V)
        self.last_ns = None  # node time (ns) of the last valid command
        self.watchdog_tripped = False

    def set(self, kind, value, now_ns):
        """Take a valid command ('power' W or 'voltage' V) at node time now_ns (ns)."""
        self.last_ns = now_ns
        self.drive = (kind, value)
        if self.watchdog_tripped:
            self.watchdog_tripped = False
            self._log('info', 'commands are back: watchdog cleared', key='watchdog clear')

    def power(self, now_ns, cfg, resistance):
        """Return the power (W) to apply at now_ns (ns): watchdog, limit, V^2 / R (ohm)."""
        timeout = cfg['command_timeout']
        if self.last_ns is not None and timeout > 0.0 and \
                now_ns - self.last_ns > timeout * 1e9:
            if not self.watchdog_tripped:
                self.watchdog_tripped = True
                # throttled: a command_timeout shorter than the command period trips
                # and clears the watchdog at every message (fuzz_node: 30 lines/s)
                self._log('warning', f'no power or voltage command for {timeout:g} s: power '
                          'set to 0', key='watchdog trip')
            return 0.0
        kind, value = self.drive
        if kind == 'voltage':
            if not resistance > 0.0:  # R(T, x) law taken outside its range
                self._log('warning', f'resistance {resistance:g} ohm is not positive: voltage '
                          'drive gives power 0 (check electrical.*)', key='resistance')
                return 0.0
            power = power_from_voltage(value, resistance)
            if power > cfg['max_power']:
                self._log('warning', f'voltage_cmd {value:g} V gives {power:g} W at '
                          f'{resistance:.4g} ohm, above max_power {cfg["max_power"]:g} W: '
                          'clamped', key='voltage clamp')
            value = power
        return min(max(value, 0.0), cfg['max_power'])


class Episode:
    """One muscle's physics between resets: steps, limits, failures and its outputs.

    Parameters
    ----------
    params : TcaParams
        The TCA.
    cfg : dict
        The node's validated parameters (node_schema.validate_node_values).
    sim : TcaSimulator or a rig simulator
        Built by node_schema.build_simulator.
    log : Log
        Where the episode's lines go.
    rig : DeadWeight or node_rigs.RigTopics
        The rig's drive, hottest temperature and samples.
    """

    def __init__(self, params, cfg, sim, log, rig=None):
        self.params, self.cfg, self.sim = params, cfg, sim
        self.log = log
        self.rig = rig or DeadWeight()
        self.rng = np.random.default_rng(int(cfg['noise.seed']))
        self.commands = Commands(log)
        self.load = start_load(params)  # N: dead weight, or the spring's F_0
        self.power = 0.0  # W, applied in the last physics step
        self.broken = False
        self.broken_cause = ''  # the physical event that broke the muscle
        self.halted = False  # the thread broke: no physics until a reset
        self.failure = None  # why the physics stopped (None while it runs)
        self.overheated = False
        self.frozen = None  # (displacement, velocity) when the muscle broke
        self.last_good = (0.0, 0.0, sim.state.temperature)  # displ., rate, temp.
        self.table_wait = None  # degC of a table row the physics waits for
        self.rows = table_rows(params)
        self.sample = None  # the last Sample

    def start(self, temperature=None):
        """Reset to the equilibrium at temperature (degC) and start the table's worker."""
        self.reset(temperature)
        self.rows.start(muscle_temperatures(self.sim))

    def command_power(self, now_ns):
        """Return the power (W) to apply at node time now_ns (ns)."""
        if self.broken:
            return 0.0
        return self.commands.power(now_ns, self.cfg, self.sim.state.resistance)

    def advance(self, n_steps, now_ns):
        """Run n physics steps with the current command and load at node time now_ns.

        A step that raises or leaves a non-finite state ends the episode: the muscle
        is marked broken with its last finite outputs and the physics stops until a
        reset or a parameter change (one error line, not one per step).
        """
        self.rig.drive(self.sim, now_ns, self.broken)
        for i in range(n_steps):
            if self.failure is not None or self.halted:
                return
            if i == 0 or self.commands.drive[0] == 'voltage':  # V^2 / R follows R(T, x)
                self.power = self.command_power(now_ns)
            try:
                state = self.sim.step(self.power, self.load)
            except ThreadBreakError as exc:  # a physical event, not a failure of the physics
                self.break_thread(str(exc))
                return
            except Exception as exc:  # noqa: B902  ZeroDivision, Overflow, StabilityError...
                self.fail(f'{type(exc).__name__}: {exc}')
                return
            bad = non_finite(state)
            if bad:
                self.fail(f'{bad} = {getattr(state, bad)!r} (non-finite state)')
                return
            self._check_limits(state)

    def _check_limits(self, state):
        cfg = self.cfg
        temp = self.rig.hottest(self.sim)
        if temp > cfg['max_temperature'] and not self.overheated:
            self.overheated = True
            self.log('error', f'temperature {temp:.1f} degC above max_temperature '
                     f'{cfg["max_temperature"]:g} degC')
        elif temp < cfg['max_temperature'] - MAX_TEMPERATURE_REARM:
            self.overheated = False
        if temp > cfg['melt_temperature'] and not self.broken:
            self.log('error', f'temperature {temp:.1f} degC above melt_temperature '
                     f'{cfg["melt_temperature"]:g} degC: the muscle broke (tension 0, '
                     'resistance inf) until ~/reset')
            values = (state.measured_displacement, -state.velocity)
            self._break(values if all(map(math.isfinite, values)) else self.last_good[:2],
                        f'above melt_temperature {cfg["melt_temperature"]:g} degC')

    def physics_waits(self):
        """Return True while a table row the next steps read is being built (physics holds).

        Outputs and services go on meanwhile (tca_ros.ros.node_tables).
        """
        if self.failure is not None or self.halted:
            return False
        waiting = self.rows.missing(muscle_temperatures(self.sim))
        if waiting is not None and self.table_wait is None:
            self.log('info', f'physics waits for the rod table row at {waiting:g} degC (built '
                     'off the executor, 1-2 s a row; cached for the next start)',
                     key='table wait')
        self.table_wait = waiting
        return waiting is not None

    def break_thread(self, reason):
        """Break the thread (its load exceeded its strength): the physics stops until reset."""
        reason = reason.splitlines()[0].replace(': the thread breaks', '')
        self.halted = True
        self.log('error', f'the thread broke: {reason} (tension 0, resistance inf) until '
                 '~/reset')
        self._break(self.last_good[:2], f'by its load: {reason}')

    def fail(self, reason):
        """End the episode once: log why, mark the muscle broken, stop the physics."""
        if self.failure is not None:
            return
        self.failure = reason.splitlines()[0] if reason else 'unknown'
        self.log('error', f'physics failed at t = {self.sim.state.time:.6g} s (power '
                 f'{self.power:g} W, load {self.load:g} N): {self.failure}; the muscle is '
                 'marked broken (last finite outputs held) until ~/reset or a parameter change')
        self._break(self.last_good[:2], 'physics failure')

    def _break(self, frozen, cause):
        self.broken, self.broken_cause = True, cause
        self.frozen = frozen
        self.power = 0.0

    def reset(self, temperature=None):
        """Return to the loaded equilibrium at temperature (degC, default ambient).

        Raises ValueError or ArithmeticError (state unchanged) when the model has no
        finite equilibrium there, e.g. under a load the coil cannot hold.
        """
        self.sim.reset(load=self.load, temperature=temperature)
        bad = non_finite(self.sim.state)
        if bad:
            raise ValueError(f'{bad} = {getattr(self.sim.state, bad)!r} at the equilibrium')
        s = self.sim.state
        self.last_good = (s.measured_displacement, -s.velocity, s.temperature)
        self.failure = None
        self.broken, self.broken_cause, self.halted = False, '', False
        self.overheated = False
        self.frozen = None
        self.power = 0.0

    def _noise(self, key):
        std = self.cfg['noise.' + key]
        return float(self.rng.normal(0.0, std)) if std > 0.0 else 0.0

    def take_sample(self, now_ns):
        """Return the Sample of the outputs at node time now_ns (ns); keep it in ``sample``."""
        s = self.sim.state
        if not self.broken and non_finite(s):  # e.g. a state set by a failed reset
            self.fail(f'{non_finite(s)} = {getattr(s, non_finite(s))!r} (non-finite state)')
        if self.broken:
            displacement, rate = self.frozen
            tension, res = 0.0, math.inf  # documented: an open circuit
            temperature = s.temperature if self.failure is None else self.last_good[2]
        else:
            displacement, rate = s.measured_displacement, -s.velocity
            tension, res = s.tension, s.resistance
            temperature = s.temperature
            self.last_good = (displacement, rate, temperature)
        # The noise is drawn whoever listens, so the outputs never depend on the readers.
        displacement += self._noise('displacement')
        res += self._noise('resistance')
        temperature += self._noise('temperature')
        self.sample = Sample(now_ns, displacement, rate, tension, res, temperature, self.power)
        self.rig.sample(self.sim, self.broken)
        return self.sample

    def muscle_state(self, waiting=''):
        """Return the MuscleState of /diagnostics (model values, no noise)."""
        s, cfg = self.sim.state, self.cfg
        if self.table_wait is not None and not waiting:
            waiting = f'the rod table row at {self.table_wait:g} degC'
        return MuscleState(
            temperature=s.temperature if self.failure is None else self.last_good[2],
            power=self.power, load=self.load,
            displacement=self.frozen[0] if self.broken else s.measured_displacement,
            max_temperature=cfg['max_temperature'], melt_temperature=cfg['melt_temperature'],
            command_timeout=cfg['command_timeout'], overheated=self.overheated,
            broken=self.broken, broken_cause=self.broken_cause,
            watchdog_tripped=self.commands.watchdog_tripped, failure=self.failure,
            waiting=waiting)

    def start_temperature(self):
        """Return the temperature (degC) a rebuilt simulator starts at (None: ambient)."""
        temp = self.sim.state.temperature
        return temp if self.failure is None and math.isfinite(temp) else None
