"""The node's time: its tick timer, the node-owned clock, lockstep and scored tasks.

A mixin of tca_ros.node.TcaSimNode (docs/node.md, "Time modes"). Without publish_clock
the physics catches up to the ROS clock at each timer tick or command; with it the node
owns the time, advances it by one tick per publish period (at real_time_factor, or as
fast as it can at 0), publishes /clock, and in lockstep waits for a command after each
state it publishes. Uses the node's _cfg, _sim, _task, _rig and publishers.
"""
import time

from builtin_interfaces.msg import Time as TimeMsg
import rclpy
from rosgraph_msgs.msg import Clock as ClockMsg

from tca_ros.node_params import physics_steps_per_tick
from tca_ros.node_task import TASK_GAP

MAX_CATCH_UP = 1.0  # s of physics run at most per callback after a stall or a clock jump
MAX_CATCH_UP_WALL = 0.2  # s of wall time a callback may spend stepping (services must answer)
CATCH_UP_CHUNK = 50  # physics steps between checks of that wall-time budget
FAST_BATCH = 0.02  # s of wall time spent ticking per callback at real_time_factor 0
FAST_PERIOD = 1e-3  # s, wall period of the tick timer in publish_clock mode, factor 0
LOCKSTEP_POLL = 0.01  # s, wall period of that timer in lockstep (wake-ups cost ~0.1 ms)
WARN_PERIOD = 1.0  # s between repeats of a throttled warning

NS = 1_000_000_000  # ns per s


def time_msg(ns):
    """Return builtin_interfaces/Time for a node time of ``ns`` nanoseconds."""
    return TimeMsg(sec=ns // NS, nanosec=ns % NS)


class ClockMixin:
    """Tick timer, node-owned clock and lockstep of TcaSimNode."""

    def _make_timer(self):
        """(Re)create the tick timer for the time mode and rates."""
        if self._timer is not None:
            self.destroy_timer(self._timer)
        if self._owns_time:
            rtf = self._cfg['real_time_factor']
            period = FAST_PERIOD if rtf == 0.0 else min(
                FAST_PERIOD * 10, 1.0 / (self._cfg['publish_rate'] * rtf))
            if self._cfg['lockstep']:
                # Commands drive the ticks; the timer only starts them and times out.
                period = max(period, LOCKSTEP_POLL)
            self._timer = self.create_timer(period, self._on_clock_timer, clock=self._wall)
            self._wall_t0, self._ticks_done = None, 0
        else:
            self._timer = self.create_timer(1.0 / self._cfg['publish_rate'], self._on_timer)

    def _now_ns(self):
        """Return the node time (ns): own sim time with publish_clock, else the ROS clock."""
        if self._owns_time:
            return self._sim_ns
        return self.get_clock().now().nanoseconds

    def _catch_up(self):
        """Step the physics up to the node clock (modes without publish_clock)."""
        now = self._now_ns()
        if now == 0:  # use_sim_time and no /clock received yet
            return
        if self._t0_ns is None or now < self._t0_ns:
            if self._t0_ns is not None:
                self.get_logger().warning('clock jumped backwards: physics time rebased')
            self._t0_ns, self._steps_done = now, 0
        target = int((now - self._t0_ns) / (self._sim.dt * NS))
        n = target - self._steps_done
        limit = int(MAX_CATCH_UP / self._sim.dt)
        if n > limit:
            self.get_logger().warning(
                f'physics {n * self._sim.dt:.3g} s behind the clock: skipped to now',
                throttle_duration_sec=WARN_PERIOD)
            self._steps_done += n - limit
            n = limit
        if self._physics_waits():  # a table row is being built: no physics meanwhile
            self._steps_done += n
            return
        wall = time.monotonic()
        if wall < self._stepping_paused_until:
            # the last catch-up ran out of its budget: every callback (each command
            # message steps too) would spend another budget and requests would wait
            # behind them, so no stepping until the pause ends (physics skips to now)
            self._steps_done += n
            return
        deadline = wall + MAX_CATCH_UP_WALL
        for start in range(0, n, CATCH_UP_CHUNK):
            if time.monotonic() > deadline:
                # A physics_rate this machine cannot keep up with: drop physics time
                # rather than leave services and commands waiting behind the stepper.
                self.get_logger().warning(
                    f'physics {(n - start) * self._sim.dt:.3g} s behind the clock after '
                    f'{MAX_CATCH_UP_WALL:g} s of stepping: skipped to now (lower '
                    'physics_rate?)', throttle_duration_sec=WARN_PERIOD)
                self._stepping_paused_until = time.monotonic() + MAX_CATCH_UP_WALL
                break
            self._advance(min(CATCH_UP_CHUNK, n - start))
        self._steps_done += n

    def _on_timer(self):
        try:
            self._catch_up()
            self._publish_state(self._now_ns())
        except Exception as exc:  # noqa: B902  a tick must never end the node
            self._fail_unless_stopping(exc)

    def _on_clock_timer(self):
        """Tick the node-owned clock; a failure marks the muscle broken, never raises."""
        try:
            self._clock_tick()
        except Exception as exc:  # noqa: B902  a tick must never end the node
            self._fail_unless_stopping(exc)

    def _fail_unless_stopping(self, exc):
        """Fail the episode on exc, unless a signal shut the context down meanwhile."""
        if self.context.ok():
            self._fail(f'{type(exc).__name__}: {exc}')

    def _clock_tick(self):
        """Tick the node-owned clock at real_time_factor (publish_clock mode)."""
        if self._task.queued and (not self._awaiting_command
                                  or time.monotonic() >= self._await_deadline):
            self._task.start()
        if self._task.holding:
            return
        if not self._started:
            if self._cfg['lockstep'] and not self._peers_matched():
                return
            self._started = True
            self._wall_first_tick = time.monotonic()
            self._publish_tick()
            return
        if self._awaiting_command:
            if time.monotonic() < self._await_deadline:
                return
            if self._last_command_ns is None:
                # The controller's reader may not have matched yet when the first state
                # went out: repeat it (same values) rather than advance without a reply.
                self._publish_clock()
                self._emit_sample()
                self._await_deadline = time.monotonic() + self._cfg['lockstep_timeout']
                return
            self.get_logger().warning(
                f'lockstep: no command within {self._cfg["lockstep_timeout"]:g} s: '
                'advancing with the last one', throttle_duration_sec=WARN_PERIOD)
            self._awaiting_command = False
            self._task.missed += self._task.active
        self._run_ticks()

    def log_time_summary(self):
        """Log the sim time reached and its ratio to wall time (publish_clock mode)."""
        if self._owns_time and self._wall_first_tick is not None:
            wall = time.monotonic() - self._wall_first_tick
            sim = self._sim_ns / NS
            # Not the node's logger: at shutdown its /rosout publisher is already gone.
            rclpy.logging.get_logger('tca.time').info(
                f'simulated {sim:.3f} s in {wall:.3f} s of wall time '
                f'({sim / max(wall, 1e-9):.1f}x real time)')

    def _peers_matched(self):
        """Return True when a controller reads the state and writes commands."""
        readers = self._joint_pub.get_subscription_count() \
            + self._disp_pub.get_subscription_count()
        writers = self._power_sub.get_publisher_count() \
            + self._voltage_sub.get_publisher_count()
        return readers > 0 and writers > 0

    def _run_ticks(self):
        """Run the ticks that are due (or a wall-time batch at factor 0)."""
        rtf = self._cfg['real_time_factor']
        tick_s = 1.0 / self._cfg['publish_rate']
        start = time.monotonic()
        if self._wall_t0 is None:
            self._wall_t0, self._ticks_done = start, 0
        while not self._awaiting_command:
            if rtf == 0.0:
                if time.monotonic() - start > FAST_BATCH:
                    break
            else:
                due = int((time.monotonic() - self._wall_t0) * rtf / tick_s)
                if self._ticks_done >= due:
                    break
                if due - self._ticks_done > MAX_CATCH_UP / tick_s:
                    self._wall_t0 = time.monotonic() - self._ticks_done * tick_s / rtf
            if self._physics_waits():  # the clock holds until the table row is built
                break
            if self._task.at_end():
                self._task.finish(self._command_power(self._sim_ns), self._broken)
                return
            self._ticks_done += 1
            self._advance(self._steps_per_tick())
            self._sim_ns += round(tick_s * NS)
            self._publish_tick()

    def _publish_clock(self):
        self._clock_pub.publish(ClockMsg(clock=time_msg(self._sim_ns)))

    def _publish_tick(self):
        """Publish /clock and the state; in lockstep, then wait for a command.

        In a scored task the tick's load is set and its stamped reference published
        first, and the published state recorded after (tca_ros.node_task).
        """
        if self._task.active:
            self._load = self._task.before_state(time_msg(self._sim_ns))
        self._publish_clock()
        self._publish_state(self._sim_ns)
        if self._task.active:
            self._task.after_state(self._sample[1], self._sample[5], self._power)
        if self._cfg['lockstep']:
            self._awaiting_command = True
            self._await_deadline = time.monotonic() + self._cfg['lockstep_timeout']

    def _steps_per_tick(self):
        return physics_steps_per_tick(self._cfg)

    def _start_task(self, load):
        """Start a task: the loaded equilibrium at ambient under load (N), TASK_GAP on."""
        if not (self._owns_time and self._cfg['lockstep'] and self._rig.mode == 'dead_weight'):
            raise ValueError('task: needs publish_clock, lockstep and rig.mode dead_weight')
        self._load = load
        self._reset_sim()
        self._drive, self._last_command_ns, self._watchdog_tripped = ('power', 0.0), None, False
        self._sim_ns += round(TASK_GAP * NS)
        self._wall_t0 = None
        self._started = self._awaiting_command = False
