"""A one-line terminal progress bar that counts simulations (diagnosis, calibration)."""
import math
import sys
import time as wallclock

PROGRESS_INTERVAL = 0.25  # s between progress-bar redraws


class Progress:
    """A one-line progress bar on stderr, counting simulations.

    Drawn only on a terminal: redirected to a file or a pipe, carriage-return redraws
    would pile up into one huge line, so the bar stays silent there. Redraws are at most
    every PROGRESS_INTERVAL seconds, also once the count passes its estimate ``total``.
    """

    def __init__(self, enabled, total, width=30, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = enabled and _is_terminal(self.stream)
        self.total = max(total, 1)
        self.width = width
        self.count = 0
        self.label = ''
        self.start = wallclock.perf_counter()
        self._drawn = -math.inf

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
        filled = min(self.width, int(self.width * self.count / self.total))
        elapsed = wallclock.perf_counter() - self.start
        self.stream.write(f'\r[{"#" * filled}{"." * (self.width - filled)}] '
                          f'{self.count:4d} sims {elapsed:5.1f} s  {self.label:<28s}')
        self.stream.flush()

    def close(self):
        """End the bar's line."""
        if self.enabled:
            self.stream.write('\n')
            self.stream.flush()


def _is_terminal(stream):
    """Return True when ``stream`` is an interactive terminal."""
    isatty = getattr(stream, 'isatty', None)
    return bool(isatty and isatty())
