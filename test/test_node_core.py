"""The node's episode without ROS: tca_ros.ros.node_core.NodeCore and node_episode.Episode.

Commands and their clamps, the watchdog, the limits, a thread break, physics failures
and resets, the node clock's catch-up and its wall-time budget, the own clock in
lockstep, parameter changes and the physics held while a table row is built: all on a
NodeCore driven by a fake clock, with no rclpy in the process (checked first).
"""
from dataclasses import replace
import math
import subprocess
import sys
import types

import pytest

from tca_ros.model.params_schema import SCHEMA
from tca_ros.model.tca_params import from_flat_dict, to_flat_dict
from tca_ros.params.files import load_params
from tca_ros.ros import node_clocks
from tca_ros.ros.node_clocks import CATCH_UP_CHUNK, MAX_CATCH_UP_WALL, NS
from tca_ros.ros.node_core import NodeCore
from tca_ros.ros.node_episode import Log, MuscleState
from tca_ros.ros.node_schema import build_simulator, NODE_SCHEMA, validate_node_values

NODE_DEFAULTS = {s.name: s.default for s in NODE_SCHEMA}


def test_the_core_imports_no_rclpy_and_no_ros_message():
    check = ('import sys, tca_ros.ros.node_core, tca_ros.ros.node_clocks, '
             'tca_ros.ros.node_episode, tca_ros.ros.node_schema, '
             'tca_ros.ros.node_tables; print(sorted(m for m in sys.modules if m.split(".")[0] in '
             '("rclpy", "std_msgs", "sensor_msgs", "diagnostic_msgs", "builtin_interfaces")))')
    out = subprocess.run([sys.executable, '-c', check], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == '[]'


class Rig:
    """A node's core on a fake ROS clock; ticks of the own clock are recorded."""

    def __init__(self, owns_time=False, params=None, **cfg):
        # as the node reads them: the flat parameter values (degrees round-tripped)
        flat = to_flat_dict(params or replace(load_params('free_stroke'), model='cst'))
        self.params = from_flat_dict({s.name: flat[s.name] for s in SCHEMA},
                                     source='ros parameters')
        self.cfg = validate_node_values({**NODE_DEFAULTS, **cfg})
        self.clock = [5 * NS]  # ns, the ROS clock
        self.ticks = []  # (ns, Sample) published
        self.republished = 0
        self.log = Log()
        self.core = NodeCore(
            self.params, self.cfg, build_simulator(self.params, self.cfg),
            owns_time=owns_time, clock_ns=lambda: self.clock[0],
            publish_tick=self._publish, republish=self._republish, log=self.log)
        self.core.episode.start()

    def _publish(self, ns):
        self.ticks.append((ns, self.core.episode.take_sample(ns)))

    def _republish(self):
        self.republished += 1

    def lines(self, level):
        return [text for lvl, text in self.log.lines if lvl == level]

    def run(self, seconds):
        """Advance the ROS clock by seconds (s) and catch up, as a timer tick does."""
        self.clock[0] += round(seconds * NS)
        self.core.catch_up()
        return self.core.episode.take_sample(self.core.now_ns())


@pytest.fixture
def rig():
    return Rig()


# -- commands, clamps, watchdog -------------------------------------------------------
def test_commands_are_clamped_and_non_finite_ones_rejected(rig):
    ep = rig.core.episode
    rig.core.power_command(9.0)
    assert rig.run(0.01).power == 5.0  # max_power
    assert rig.lines('warning')[-1] == 'power_cmd 9 W outside [0, 5] W: clamped'
    rig.core.power_command(-1.0)
    assert rig.run(0.01).power == 0.0
    rig.core.power_command(1.0)
    rig.core.power_command(math.nan)  # rejected: the last valid one holds
    assert rig.run(0.01).power == 1.0
    assert 'power_cmd: rejected non-finite value nan' in rig.lines('warning')[-1]
    rig.core.load_command(50.0)
    assert ep.load == 10.0  # max_load
    rig.core.voltage_command(5.0)
    sample = rig.run(0.01)
    assert sample.power == pytest.approx(25.0 / ep.sim.state.resistance, rel=1e-2)


def test_the_watchdog_zeroes_the_power_and_a_command_clears_it(rig):
    rig.core.power_command(1.0)
    assert rig.run(0.3).power == 1.0
    assert rig.run(0.3).power == 0.0  # command_timeout 0.5 s
    assert rig.core.muscle_state().watchdog_tripped
    rig.core.power_command(1.0)
    assert not rig.core.muscle_state().watchdog_tripped
    assert rig.run(0.01).power == 1.0
    assert rig.lines('warning') == ['no power or voltage command for 0.5 s: power set to 0']
    assert rig.lines('info') == ['commands are back: watchdog cleared']


def test_a_watchdog_shorter_than_the_command_period_does_not_flood_the_log(rig):
    """Trip and clear lines are throttled per kind (fuzz_node: command_timeout 5e-324 s)."""
    ep = rig.core.episode
    ep.cfg = dict(ep.cfg, command_timeout=5e-324)
    trips = 0
    for k in range(3):
        rig.core.power_command(0.5)
        trips += ep.command_power(ep.commands.last_ns + 1_000_000) == 0.0  # 1 ms later
    assert trips == 3  # the watchdog trips every time
    watchdog = [t for _, t in rig.log.lines if 'no power or voltage' in t or 'cleared' in t]
    assert len(watchdog) == 2  # one trip and one clear line in a second, not 5


# -- limits, thread break, failures, resets -----------------------------------------
def test_overheat_then_melt_break_the_muscle_until_reset():
    rig = Rig(max_temperature=40.0, melt_temperature=45.0)
    rig.core.power_command(5.0)
    for _ in range(300):
        sample = rig.run(0.01)
        rig.core.power_command(5.0)
    state = rig.core.muscle_state()
    assert state.broken and state.broken_cause == 'above melt_temperature 45 degC'
    assert not state.overheated  # no power since the melt: cooled below 39 degC
    assert len([t for t in rig.lines('error') if 'above max_temperature 40' in t]) == 1
    assert sample.tension == 0.0 and sample.resistance == math.inf and sample.power == 0.0
    assert len([t for t in rig.lines('error') if 'above melt_temperature' in t]) == 1
    rig.core.reset()
    assert not rig.core.muscle_state().broken
    assert rig.core.episode.sim.state.temperature == 25.0


def test_a_thread_break_is_a_physical_event_not_a_physics_failure(rig):
    ep = rig.core.episode
    params = ep.sim.params  # a weak thread: 0.4 N, and 0.5 N of load pulls past it
    ep.sim.params = replace(params, fiber=replace(params.fiber, break_force=0.4))
    rig.core.load_command(0.5)
    for _ in range(50):
        sample = rig.run(0.01)
    errors = rig.lines('error')
    assert len(errors) == 1 and errors[0].startswith('the thread broke: tension '), errors
    assert 'fiber.break_force 0.4 N' in errors[0] and 'physics failed' not in errors[0]
    state = rig.core.muscle_state()
    assert state.broken and state.failure is None
    assert state.broken_cause.startswith('by its load: tension ')
    assert sample.tension == 0.0 and sample.resistance == math.inf  # open circuit
    time_at_break = ep.sim.state.time
    rig.run(0.1)
    assert ep.sim.state.time == time_at_break  # the physics stopped
    rig.core.load_command(0.2)
    rig.core.reset()
    assert not ep.broken and rig.core.muscle_state().broken_cause == ''


@pytest.mark.parametrize('failure', ['raise', 'inf', 'nan'])
def test_a_physics_failure_is_reported_once_and_reset_recovers(rig, failure):
    ep = rig.core.episode
    rig.core.power_command(1.0)
    rig.run(0.1)
    good = ep.sim.state.temperature
    real_step = ep.sim.step

    def broken_step(power, load=None):
        if failure == 'raise':
            raise ZeroDivisionError('float division by zero')
        state = real_step(power, load)
        state.elongation = math.inf if failure == 'inf' else math.nan
        return state
    ep.sim.step = broken_step
    for _ in range(50):  # 50 ticks of 10 steps: one error line, not 500
        sample = rig.run(0.01)
    errors = rig.lines('error')
    assert len(errors) == 1, errors
    assert 'physics failed' in errors[0] and 'until ~/reset' in errors[0]
    assert ep.broken and all(map(math.isfinite, (
        sample.displacement, sample.rate, sample.tension, sample.temperature, sample.power)))
    assert sample.temperature == pytest.approx(good, abs=1.0)  # last finite one held
    assert rig.core.muscle_state().failure.startswith(
        'ZeroDivisionError' if failure == 'raise' else 'elongation')
    del ep.sim.step  # back to the class's step
    rig.core.reset()
    assert not ep.broken
    assert math.isfinite(rig.run(0.01).resistance) and len(rig.lines('error')) == 1


def test_a_failed_reset_raises_and_a_parameter_change_recovers(rig):
    ep = rig.core.episode
    ep.fail('injected')
    ep.load = 1e4  # far beyond what the coil holds: no equilibrium
    with pytest.raises((ValueError, ArithmeticError)):
        rig.core.reset()
    assert ep.broken
    ep.load = 0.3
    change = rig.core.reconfigure(_tca_values(rig, **{'dynamics.damping': 0.6}), ep.cfg,
                                  ['dynamics.damping'])
    assert change.successful and change.rebuilt, change.reason
    assert not ep.broken and ep.failure is None
    assert math.isfinite(rig.run(0.01).resistance)


# -- parameters -----------------------------------------------------------------------
def _tca_values(rig, **changes):
    values = to_flat_dict(rig.core.episode.params)
    values.update(changes)
    return {s.name: values[s.name] for s in SCHEMA}


def test_parameter_changes_are_refused_with_a_reason_and_keep_the_state(rig):
    ep = rig.core.episode
    rig.core.power_command(2.0)
    rig.run(1.0)
    hot = ep.sim.state.temperature
    change = rig.core.reconfigure(_tca_values(rig), dict(ep.cfg, publish_rate=5000.0),
                                  ['publish_rate'])
    assert not change.successful
    assert change.reason.startswith("parameter 'publish_rate' = 5000: must not exceed")
    change = rig.core.reconfigure(_tca_values(rig), dict(ep.cfg, joint_name=''),
                                  ['joint_name'])
    assert not change.successful and "parameter 'joint_name' = ''" in change.reason
    sim = ep.sim
    change = rig.core.reconfigure(_tca_values(rig), dict(ep.cfg, physics_rate=2000),
                                  ['physics_rate'])
    assert change.successful and not change.rebuilt and ep.sim is sim  # same state
    assert ep.sim.dt == pytest.approx(5e-4) and ep.sim.state.temperature == hot
    change = rig.core.reconfigure(
        _tca_values(rig, **{'thermal.convection_coefficient': 60.0}), ep.cfg,
        ['thermal.convection_coefficient'])
    assert change.successful and change.rebuilt and ep.sim is not sim
    assert ep.sim.state.temperature == pytest.approx(hot)  # a new TCA at the node's state
    change = rig.core.reconfigure(_tca_values(rig), dict(ep.cfg, lockstep=True), ['lockstep'])
    assert change.successful and change.retime


# -- the own clock, lockstep ------------------------------------------------------------
def _lockstep(commands, **cfg):
    """Return the samples of an own-clock lockstep run answering each tick from commands."""
    rig = Rig(owns_time=True, publish_clock=True, lockstep=True, real_time_factor=0.0,
              **{'noise.displacement': 1e-5, 'noise.seed': 3, **cfg})
    rig.core.clock_tick(lambda: False)
    assert rig.ticks == [] and rig.core.muscle_state().waiting == 'a controller (lockstep)'
    rig.core.clock_tick(lambda: True)
    for value in commands:
        assert rig.core.own_clock.awaiting
        rig.core.power_command(value)
    return rig


def test_lockstep_publishes_one_tick_per_command_and_is_repeatable():
    commands = [1.0] * 20 + [3.0] * 20 + [0.0] * 10
    rig = _lockstep(commands)
    times = [ns for ns, _ in rig.ticks]
    assert times == [k * 10_000_000 for k in range(len(commands) + 1)]  # 100 Hz ticks
    assert [s.power for _, s in rig.ticks][1:] == commands
    again = _lockstep(commands)
    assert [s for _, s in again.ticks] == [s for _, s in rig.ticks]  # bit-identical


def test_lockstep_repeats_the_first_state_then_advances_after_the_timeout(monkeypatch):
    wall = [100.0]
    monkeypatch.setattr(node_clocks, 'time', types.SimpleNamespace(monotonic=lambda: wall[0]))
    rig = _lockstep([], lockstep_timeout=1.0)
    assert len(rig.ticks) == 1
    rig.core.clock_tick(lambda: True)
    assert rig.republished == 0  # before the timeout: nothing
    wall[0] += 1.5
    rig.core.clock_tick(lambda: True)
    assert rig.republished == 1 and len(rig.ticks) == 1  # no command yet: the same state
    rig.core.power_command(1.0)
    assert len(rig.ticks) == 2
    wall[0] += 1.5  # no answer to tick 1 within the timeout: advance with the last command
    rig.core.clock_tick(lambda: True)
    assert len(rig.ticks) == 3
    assert rig.lines('warning') == ['lockstep: no command within 1 s: advancing with the '
                                    'last one']


def test_lockstep_starts_once_the_controller_has_stayed_matched(monkeypatch):
    wall = [100.0]
    monkeypatch.setattr(node_clocks, 'time', types.SimpleNamespace(monotonic=lambda: wall[0]))
    settled = node_clocks.Settled(0.25)
    assert not settled(False) and not settled(True)  # matched just now
    wall[0] += 0.2
    assert not settled(True)
    wall[0] += 0.1
    assert settled(True)  # matched for 0.3 s
    assert not settled(False)  # unmatched: the wait starts again
    wall[0] += 1.0
    assert not settled(True)
    wall[0] += 0.25
    assert settled(True)


# -- the node clock -----------------------------------------------------------------------
def test_the_physics_catches_up_to_the_clock_and_rebases_on_a_jump_back(rig):
    ep = rig.core.episode
    rig.run(0.0)  # the first tick: physics time 0 is now
    rig.run(0.25)
    assert ep.sim.state.time == pytest.approx(0.25, abs=2e-3)
    rig.clock[0] -= NS  # a clock jumped backwards
    rig.run(0.0)
    assert rig.lines('warning') == ['clock jumped backwards: physics time rebased']
    rig.run(0.1)
    assert ep.sim.state.time == pytest.approx(0.35, abs=2e-3)
    assert rig.core.muscle_state(now_ns=0).waiting == 'the first /clock message'


def test_a_physics_rate_the_machine_cannot_keep_up_with_pauses_the_stepping(rig, monkeypatch):
    """A catch-up out of budget pauses stepping for one budget (fake clock, issue 10).

    fuzz_node, antagonistic rig on a starved machine: every command message stepped
    for a whole budget too, and 43 of 400 requests waited past 3 s behind them.
    """
    wall = [100.0]  # s, the node's monotonic clock
    monkeypatch.setattr(node_clocks, 'time', types.SimpleNamespace(monotonic=lambda: wall[0]))
    ep = rig.core.episode
    real_step = ep.sim.step
    steps = []

    def slow_step(power, load=None):
        wall[0] += 1e-3  # 1 ms of wall time a step: the machine cannot keep up
        steps.append(wall[0])
        return real_step(power, load)
    rig.core.catch_up()
    ep.sim.step = slow_step
    rig.run(1.0)  # 1 s of physics behind
    first = len(steps)
    assert 0 < first <= MAX_CATCH_UP_WALL / 1e-3 + CATCH_UP_CHUNK
    assert any('skipped to now' in t for t in rig.lines('warning'))
    rig.run(0.1)  # a command callback right after, 0.1 s more behind
    assert len(steps) == first  # paused: nothing stepped, the physics skipped to now
    wall[0] += MAX_CATCH_UP_WALL + 1e-3  # the pause is over
    rig.run(0.01)
    assert len(steps) > first
    assert not ep.broken


def test_the_physics_holds_while_a_table_row_is_built(rig):
    class Building:
        """TableRows stand-in: the row at 55 degC is being built."""

        wanted = 55.0

        def missing(self, temperatures):
            return self.wanted
    ep = rig.core.episode
    ep.rows = Building()
    time0 = ep.sim.state.time
    sample = rig.run(0.5)
    assert ep.sim.state.time == time0 and math.isfinite(sample.displacement)
    assert rig.core.muscle_state().waiting == 'the rod table row at 55 degC'
    assert rig.lines('info')[-1].startswith('physics waits for the rod table row at 55 degC')
    Building.wanted = None  # built: the physics runs again from now on
    rig.run(0.1)
    assert ep.sim.state.time == pytest.approx(time0 + 0.1, abs=2e-3)
    assert rig.core.muscle_state() == MuscleState(**{
        **rig.core.muscle_state().__dict__, 'waiting': ''})


def test_the_own_clock_holds_while_a_table_row_is_built():
    rig = _lockstep([1.0] * 3)
    rig.core.episode.rows = types.SimpleNamespace(missing=lambda temperatures: 55.0)
    rig.core.power_command(1.0)
    assert len(rig.ticks) == 4  # the command came, the tick waits for the row
    assert not rig.core.own_clock.awaiting
    rig.core.episode.rows = types.SimpleNamespace(missing=lambda temperatures: None)
    rig.core.clock_tick(lambda: True)
    assert len(rig.ticks) == 5 and rig.ticks[-1][0] == 40_000_000
