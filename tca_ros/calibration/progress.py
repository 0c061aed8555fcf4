"""Progress of a stage that counts simulations (calibration, effect search).

On a terminal: a one-line bar redrawn in place, with the count, the elapsed time and
the time left at the mean pace so far. Off a terminal (a file, a pipe, a log): one
quiet line per stage when it ends (carriage-return redraws would pile up into one
huge line there).
"""
import math
import sys
import time as wallclock

PROGRESS_INTERVAL = 0.25  # s between progress-bar redraws
BAR_CAP = 0.95  # fraction the bar shows at most before close(): full only when done


class Progress:
    """Progress of one stage on stderr, counting simulations.

    ``total`` is an estimate of the simulations the stage needs: the bar fills
    in proportion to it but never completely before close(), and past it the time
    left is shown as unknown. Redraws are at most every PROGRESS_INTERVAL seconds
    (s). ``enabled`` False: silent everywhere. ``stage`` names the stage in the
    line written off a terminal.
    """

    def __init__(self, enabled, total, width=30, stream=None, stage='simulations'):
        self.stream = stream or sys.stderr
        self.requested = bool(enabled)
        self.enabled = self.requested and _is_terminal(self.stream)  # the bar is drawn
        self.total = max(total, 1)
        self.width = width
        self.stage = stage
        self.count = 0
        self.label = ''
        self.start = wallclock.perf_counter()
        self._drawn = -math.inf
        self._closed = False

    def tick(self, label=None):
        """Count one simulation and redraw."""
        self.count += 1
        if label is not None:
            self.label = label
        if not self.enabled:
            return
        now = wallclock.perf_counter()
        if now - self._drawn < PROGRESS_INTERVAL and self.count != self.total:
            return
        self._drawn = now
        self._draw(now - self.start)

    def fraction(self):
        """Return the share of the bar to fill (-): count / total, below BAR_CAP."""
        return min(self.count / self.total, BAR_CAP)

    def remaining(self, elapsed):
        """Return the seconds left at the mean pace so far, or None past the estimate."""
        if self.count >= self.total:
            return None
        return elapsed * (self.total - self.count) / max(self.count, 1)

    def _draw(self, elapsed, done=False):
        filled = self.width if done else min(self.width - 1, int(self.width * self.fraction()))
        if done:
            left = 'done'
        else:
            seconds = self.remaining(elapsed)
            left = ('left ?, past the estimate' if seconds is None else
                    f'left ~{_clock(seconds)}')
        self.stream.write(f'\r[{"#" * filled}{"." * (self.width - filled)}] '
                          f'{self.count:4d} sims  {_clock(elapsed)} elapsed, {left:<26s} '
                          f'{self.label:<28s}')
        self.stream.flush()

    def close(self):
        """End the stage: the full bar on a terminal, else one line (when enabled)."""
        if self._closed:
            return
        self._closed = True
        elapsed = wallclock.perf_counter() - self.start
        if self.enabled:
            self._draw(elapsed, done=True)
            self.stream.write('\n')
        elif self.requested:
            self.stream.write(f'{self.stage}: {self.count} simulations in {_clock(elapsed)}\n')
        else:
            return
        self.stream.flush()


def _clock(seconds):
    """Return a duration (s) as '12.3 s' or '4 min 05 s'."""
    if seconds < 100.0:
        return f'{seconds:.1f} s'
    minutes, rest = divmod(int(round(seconds)), 60)
    return f'{minutes} min {rest:02d} s'


def _is_terminal(stream):
    """Return True when ``stream`` is an interactive terminal."""
    isatty = getattr(stream, 'isatty', None)
    return bool(isatty and isatty())
