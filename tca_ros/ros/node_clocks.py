"""The ``tca`` node's two kinds of time, plain classes: no rclpy.

``NodeClock``: the physics caught up to a clock the node is given (the ROS clock, or
/clock with use_sim_time), within a budget of physics and wall time per call.
``OwnClock``: the node's own clock (publish_clock), ticked at real_time_factor;
in lockstep each tick waits for the controller's command. Both step a
tca_ros.ros.node_episode.Episode; tca_ros.ros.node_core.NodeCore holds one of each
and routes the inputs to them. Time modes and their rules: docs/node.md, "Time".
"""
import time

from tca_ros.ros.node_schema import physics_steps_per_tick

NS = 1_000_000_000  # ns per s
MAX_CATCH_UP = 1.0  # s of physics run at most per callback after a stall or a clock jump
MAX_CATCH_UP_WALL = 0.2  # s of wall time a callback may spend stepping (services must answer)
CATCH_UP_CHUNK = 50  # physics steps between checks of that wall-time budget
FAST_BATCH = 0.02  # s of wall time spent ticking per callback at real_time_factor 0


class NodeClock:
    """The physics caught up to a clock it is given (modes without publish_clock).

    At most MAX_CATCH_UP s of physics per call (more is skipped, with a warning) and
    MAX_CATCH_UP_WALL s of wall time; a call that runs out of that budget pauses the
    stepping for as long, so that services and commands are always served.
    """

    def __init__(self, log):
        self._log = log
        self.t0_ns = None  # ROS time (ns) of physics time 0
        self.steps_done = 0
        self.paused_until = 0.0  # monotonic s: no catch-up before (overload)

    def rebase(self):
        """Count physics time from the next call (a new step or simulator)."""
        self.t0_ns, self.steps_done = None, 0

    def catch_up(self, ep, now_ns):
        """Step the Episode ep up to ``now_ns()`` (ROS time, ns)."""
        now = now_ns()
        if now == 0:  # use_sim_time and no /clock received yet
            return
        if self.t0_ns is None or now < self.t0_ns:
            if self.t0_ns is not None:
                self._log('warning', 'clock jumped backwards: physics time rebased')
            self.t0_ns, self.steps_done = now, 0
        dt = ep.sim.dt
        n = int((now - self.t0_ns) / (dt * NS)) - self.steps_done
        limit = int(MAX_CATCH_UP / dt)
        if n > limit:
            self._log('warning', f'physics {n * dt:.3g} s behind the clock: skipped to now',
                      key='behind')
            self.steps_done += n - limit
            n = limit
        if ep.physics_waits():  # a table row is being built: no physics meanwhile
            self.steps_done += n
            return
        wall = time.monotonic()
        if wall < self.paused_until:
            # the last catch-up ran out of its budget: every callback (each command
            # message steps too) would spend another budget and requests would wait
            # behind them, so no stepping until the pause ends (physics skips to now)
            self.steps_done += n
            return
        deadline = wall + MAX_CATCH_UP_WALL
        for start in range(0, n, CATCH_UP_CHUNK):
            if time.monotonic() > deadline:
                # A physics_rate this machine cannot keep up with: drop physics time
                # rather than leave services and commands waiting behind the stepper.
                self._log('warning', f'physics {(n - start) * dt:.3g} s behind the clock '
                          f'after {MAX_CATCH_UP_WALL:g} s of stepping: skipped to now (lower '
                          'physics_rate?)', key='budget')
                self.paused_until = time.monotonic() + MAX_CATCH_UP_WALL
                break
            ep.advance(min(CATCH_UP_CHUNK, n - start), now_ns())
        self.steps_done += n


class Settled:
    """Whether a condition has held for ``delay`` s of wall time (monotonic) without a break.

    Lockstep starts once the controller has been matched for a while: its reader may
    match the node's writer tens of ms after the node's writer matched it, and a state
    sent in between is lost (docs/decisions.md N7).
    """

    def __init__(self, delay):
        self.delay = delay  # s
        self.since = None  # monotonic s since the condition holds

    def __call__(self, holds):
        """Return True if ``holds`` and it has held for ``delay`` s since it last did not."""
        if not holds:
            self.since = None
            return False
        now = time.monotonic()
        if self.since is None:
            self.since = now
        return now - self.since >= self.delay


class OwnClock:
    """The node's own clock: ticks at real_time_factor, each a published state.

    Parameters
    ----------
    episode : node_episode.Episode
        What a tick steps (``physics_steps_per_tick`` physics steps) and publishes.
    task : node_task.TaskPlayer or node_core.NoTask
        A scored task's bookkeeping (its loads and references, missed commands).
    publish_tick, republish : callables
        ``publish_tick(now_ns)`` publishes /clock and the state of a tick;
        ``republish()`` the last one again (lockstep, while no controller answered).
    log : node_episode.Log
    """

    def __init__(self, episode, task, publish_tick, republish, log):
        self.episode = episode
        self.task = task
        self._publish_tick = publish_tick
        self._republish = republish
        self._log = log
        self.sim_ns = 0  # the node's time (ns)
        self.started = False
        self.awaiting = False  # lockstep: a state awaits its command
        self.await_deadline = 0.0  # monotonic s
        self.wall_first_tick = None
        self.wall_t0 = None
        self.ticks_done = 0

    def retimed(self):
        """Restart the real-time pacing (a new tick timer): ticks due count from now."""
        self.wall_t0, self.ticks_done = None, 0

    def command(self, store):
        """Take a controller's command: ``store()`` keeps it; lockstep: the next ticks run.

        A command that answers the state before a queued task starts the task instead
        (and is not kept); one a task did not ask for is counted as extra.
        """
        task = self.task
        if task.queued and self.awaiting:
            self.awaiting = False  # the answer to the state before the task
            task.start()
            return
        task.extra += task.active and self.started and not self.awaiting
        store()
        if self.awaiting:
            self.awaiting = False
            self.run_ticks()

    def release(self):
        """Stop waiting for a command (lockstep switched off)."""
        self.awaiting = False

    def tick(self, peers_matched):
        """Tick the own clock at real_time_factor; ``peers_matched()``: a controller is there."""
        task, ep = self.task, self.episode
        if task.queued and (not self.awaiting or time.monotonic() >= self.await_deadline):
            task.start()
        if task.holding:
            return
        if not self.started:
            if ep.cfg['lockstep'] and not peers_matched():
                return
            self.started = True
            self.wall_first_tick = time.monotonic()
            self._tick()
            return
        if self.awaiting:
            if time.monotonic() < self.await_deadline:
                return
            if ep.commands.last_ns is None:
                # The controller's reader may not have matched yet when the first state
                # went out: repeat it (same values) rather than advance without a reply.
                self._republish()
                self.await_deadline = time.monotonic() + ep.cfg['lockstep_timeout']
                return
            self._log('warning', f'lockstep: no command within '
                      f'{ep.cfg["lockstep_timeout"]:g} s: advancing with the last one',
                      key='lockstep')
            self.awaiting = False
            task.missed += task.active
        self.run_ticks()

    def run_ticks(self):
        """Run the ticks that are due (or a wall-time batch at factor 0)."""
        ep = self.episode
        cfg = ep.cfg
        rtf = cfg['real_time_factor']
        tick_s = 1.0 / cfg['publish_rate']
        start = time.monotonic()
        if self.wall_t0 is None:
            self.wall_t0, self.ticks_done = start, 0
        while not self.awaiting:
            if rtf == 0.0:
                if time.monotonic() - start > FAST_BATCH:
                    break
            else:
                due = int((time.monotonic() - self.wall_t0) * rtf / tick_s)
                if self.ticks_done >= due:
                    break
                if due - self.ticks_done > MAX_CATCH_UP / tick_s:
                    self.wall_t0 = time.monotonic() - self.ticks_done * tick_s / rtf
            if ep.physics_waits():  # the clock holds until the table row is built
                break
            if self.task.at_end():
                self.task.finish(ep.command_power(self.sim_ns), ep.broken)
                return
            self.ticks_done += 1
            ep.advance(physics_steps_per_tick(cfg), self.sim_ns)
            self.sim_ns += round(tick_s * NS)
            self._tick()

    def _tick(self):
        """Publish a tick (its load and stamped reference first in a task); lockstep: wait."""
        ep, task = self.episode, self.task
        if task.active:
            ep.load = task.before_state(self.sim_ns)
        self._publish_tick(self.sim_ns)
        if task.active:
            task.after_state(ep.sample.displacement, ep.sample.temperature, ep.power)
        if ep.cfg['lockstep']:
            self.awaiting = True
            self.await_deadline = time.monotonic() + ep.cfg['lockstep_timeout']

    def skip(self, gap_s):
        """Move the clock on by ``gap_s`` (s) and wait for a controller as at the start."""
        self.sim_ns += round(gap_s * NS)
        self.wall_t0 = None
        self.started = self.awaiting = False

    def summary(self):
        """Return (sim s, wall s) since the first tick, or None before it."""
        if self.wall_first_tick is None:
            return None
        return self.sim_ns / NS, time.monotonic() - self.wall_first_tick
