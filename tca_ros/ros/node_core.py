"""The ``tca`` node's episode as a plain class: commands, clock, lockstep; no rclpy.

``NodeCore`` is everything the node decides: the inputs (commands clamped, the load,
a reset), the time (the physics caught up to a clock it is given, or a clock of its own
ticked at real_time_factor; lockstep: one command per tick; both in node_clocks.py),
scored tasks' bookkeeping and parameter changes (validated, then applied to a rebuilt
or re-stepped simulator). Its physics and outputs are a
tca_ros.ros.node_episode.Episode. The ROS shell (tca_ros.ros.node.TcaSimNode) turns
messages and parameters into calls of it and its outputs (plain values) into
messages; here it is only a few callables:

- ``clock_ns()``: the ROS time (ns) in the node-clock modes;
- ``publish_tick(now_ns)``: publish /clock and the state of a tick of the own clock;
- ``republish()``: publish the last tick again (lockstep, while no controller answered);
- ``log``: a node_episode.Log.

Time modes and their rules: docs/node.md, "Time".
"""
from dataclasses import dataclass
import math

import numpy as np

from tca_ros.model.dynamics import StabilityError
from tca_ros.model.params_schema import ParameterError
from tca_ros.model.rigs import start_load
from tca_ros.model.tca_params import from_flat_dict
from tca_ros.ros.node_clocks import NodeClock, OwnClock
from tca_ros.ros.node_episode import Episode, Log, non_finite
from tca_ros.ros.node_schema import build_simulator, physics_dt, REBUILD, validate_node_values
from tca_ros.ros.node_tables import muscle_temperatures, table_rows

TASK_GAP = 2.0  # s of node time between a task's first state and the state before it


class NoTask:
    """No scored task (node_task.TaskPlayer otherwise): nothing queued, active or held."""

    queued = None
    holding = active = False
    missed = extra = 0

    def at_end(self):
        """Return False: no task ends."""
        return False


@dataclass(frozen=True)
class Change:
    """The outcome of a parameter change: refused with a reason, or what it changed."""

    successful: bool
    reason: str = ''
    retime: bool = False  # publish_rate, real_time_factor or lockstep changed: new timer
    rebuilt: bool = False  # a new TCA: a new simulator at the node's load and temperature


class NodeCore:
    """The node's episode, inputs and time; see the module doc for the callables."""

    def __init__(self, params, cfg, sim, *, owns_time, clock_ns, publish_tick,
                 republish=None, log=None, rig=None, task=None):
        self.owns_time = owns_time
        self._clock_ns = clock_ns
        self.log = log or Log()
        self.task = task or NoTask()
        self.episode = Episode(params, cfg, sim, self.log, rig)
        self.node_clock = NodeClock(self.log)  # the node-clock modes
        self.own_clock = OwnClock(self.episode, self.task, publish_tick, republish, self.log)

    @property
    def cfg(self):
        """Return the node's validated parameters (dict)."""
        return self.episode.cfg

    def now_ns(self):
        """Return the node time (ns): the own clock with publish_clock, else the ROS clock."""
        return self.own_clock.sim_ns if self.owns_time else self._clock_ns()

    # -- inputs -------------------------------------------------------------------------
    def valid(self, topic, value):
        """Return True for a finite value; warn (throttled) and return False otherwise."""
        if math.isfinite(value):
            return True
        self.log('warning', f'{topic}: rejected non-finite value {value}; keeping the last '
                 'valid one', key=f'{topic} non-finite')
        return False

    def power_command(self, value):
        """Take power_cmd (W): clamped to [0, max_power] with a warning."""
        if not self.valid('power_cmd', value):
            return
        if value < 0.0 or value > self.cfg['max_power']:
            self.log('warning', f'power_cmd {value:g} W outside [0, {self.cfg["max_power"]:g}] '
                     'W: clamped', key='power_cmd clamp')
        self._command('power', value)

    def voltage_command(self, value):
        """Take voltage_cmd (V): the power is V^2 / R(T, x), clamped at each step."""
        if self.valid('voltage_cmd', value):
            self._command('voltage', value)

    def _command(self, kind, value):
        self.own_clock.command(
            lambda: self.episode.commands.set(kind, value, self.command_time()))

    def command_time(self):
        """Return the node time (ns) of a command, the physics caught up to it."""
        if not self.owns_time:
            self.catch_up()  # the old command holds up to now (zero-order hold)
        return self.now_ns()

    def load_command(self, value):
        """Take the load (N): clamped to [0, max_load] with a warning."""
        if not self.valid('load', value):
            return
        load = min(max(value, 0.0), self.cfg['max_load'])
        if load != value:
            self.log('warning', f'load {value:g} N outside [0, {self.cfg["max_load"]:g}] N: '
                     'clamped', key='load clamp')
        if not self.owns_time:
            self.catch_up()
        self.episode.load = load

    def reset(self):
        """Back to the loaded equilibrium at ambient, 0 W; raises (state kept) if none."""
        if not self.owns_time:
            self.catch_up()
        self.episode.reset()
        self.episode.commands.clear()
        self.task.holding = False  # a scored run's hold ends: lockstep goes on

    def muscle_state(self, now_ns=None):
        """Return the MuscleState of /diagnostics, with what the physics waits for."""
        if self.owns_time:
            waiting = '' if self.own_clock.started else (
                'a controller (lockstep)' if self.cfg['lockstep'] else 'the first tick')
        else:  # the clock read costs ~10 us: a tick passes its own time
            now = self.now_ns() if now_ns is None else now_ns
            waiting = 'the first /clock message' if now == 0 else ''
        return self.episode.muscle_state(waiting)

    # -- node clock ---------------------------------------------------------------------
    def catch_up(self):
        """Step the physics up to the ROS clock (modes without publish_clock)."""
        self.node_clock.catch_up(self.episode, self.now_ns)

    # -- own clock ----------------------------------------------------------------------
    def retimed(self):
        """Restart the real-time pacing (a new tick timer): ticks due count from now."""
        self.own_clock.retimed()

    def clock_tick(self, peers_matched):
        """Tick the own clock at real_time_factor; ``peers_matched()``: a controller is there."""
        self.own_clock.tick(peers_matched)

    def start_task(self, load):
        """Start a task: the loaded equilibrium at ambient under load (N), TASK_GAP on."""
        ep = self.episode
        if not (self.owns_time and self.cfg['lockstep'] and ep.rig.mode == 'dead_weight'):
            raise ValueError('task: needs publish_clock, lockstep and rig.mode dead_weight')
        ep.load = load
        ep.reset()
        ep.commands.clear()
        self.own_clock.skip(TASK_GAP)

    def time_summary(self):
        """Return (sim s, wall s) since the first tick of the own clock, or None."""
        return self.own_clock.summary() if self.owns_time else None

    # -- parameters ---------------------------------------------------------------------
    def reconfigure(self, tca_values, node_values, changed):
        """Validate and apply new parameter values; return a Change (never raises for input).

        ``tca_values`` maps every TCA parameter (params_schema.SCHEMA) to its value,
        ``node_values`` every node parameter; ``changed`` names those just set. A new
        TCA rebuilds the simulator at the node's load and temperature; a new step
        (physics_rate, publish_rate) keeps the whole state.
        """
        ep = self.episode
        if not self.owns_time:
            self.catch_up()  # up to now with the old values
        cfg = ep.cfg
        try:
            params = from_flat_dict(tca_values, source='ros parameters')
            cfg = validate_node_values(node_values)
            rebuild = params != ep.params or any(cfg[k] != ep.cfg[k] for k in REBUILD)
            if rebuild and params == ep.params:
                ep.sim.set_dt(physics_dt(cfg))  # set_dt keeps the old step on failure
            elif rebuild:
                sim, temperature, load = rebuilt_simulator(ep, params, cfg, changed)
        except StabilityError as exc:
            return Change(False, f'{exc} (physics_rate = {cfg["physics_rate"]:g} Hz)')
        except ParameterError as exc:
            return Change(False, str(exc))
        old_cfg, ep.cfg = ep.cfg, cfg
        new_tca = rebuild and params != ep.params
        if new_tca:
            ep.params, ep.sim, ep.load = params, sim, load
            ep.reset(temperature)
            ep.rows.stop()
            ep.rows = table_rows(params)
            ep.rows.start(muscle_temperatures(ep.sim))
        if rebuild:
            self.node_clock.rebase()
        if cfg['noise.seed'] != old_cfg['noise.seed']:
            ep.rng = np.random.default_rng(int(cfg['noise.seed']))
        if not cfg['lockstep']:
            self.own_clock.release()
        return Change(True, retime=any(cfg[k] != old_cfg[k] for k in (
            'publish_rate', 'real_time_factor', 'lockstep')), rebuilt=new_tca)


def rebuilt_simulator(ep, params, cfg, changed):
    """Return (simulator, temperature, load) of a new TCA at the state of Episode ep."""
    sim = build_simulator(params, cfg, changed=changed)
    temperature = ep.start_temperature()
    load = ep.load if params.rig == ep.params.rig else start_load(params)
    try:  # the node's load and temperature, not the file's: refuse if no state
        sim.reset(load=load, temperature=temperature)
        if non_finite(sim.state):
            raise ValueError(f'{non_finite(sim.state)} is not finite')
    except (ValueError, ArithmeticError) as exc:
        raise ParameterError(
            f'{str(exc).splitlines()[0]} (at the applied load {load:g} N, '
            f'{temperature if temperature is not None else "ambient"} degC)') from None
    return sim, temperature, load
