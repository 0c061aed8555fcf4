"""The diagnosis progress bar: drawn on a terminal only, and throttled past its estimate."""
import io

from tca_ros.diagnosis import progress as progress_module
from tca_ros.diagnosis.progress import Progress


class Terminal(io.StringIO):
    """A text stream that says it is a terminal."""

    def isatty(self):
        return True


def test_nothing_is_drawn_into_a_file_or_pipe():
    stream = io.StringIO()
    bar = Progress(True, total=10, stream=stream)
    for _ in range(20):
        bar.tick('fit')
    bar.close()
    assert stream.getvalue() == ''


def test_redraws_stay_throttled_after_the_count_passes_its_estimate(monkeypatch):
    clock = iter(range(10 ** 6))  # a frozen-ish clock: 1 us per call
    monkeypatch.setattr(progress_module.wallclock, 'perf_counter', lambda: next(clock) * 1e-6)
    stream = Terminal()
    bar = Progress(True, total=10, stream=stream)
    for _ in range(500):
        bar.tick('fit')
    bar.close()
    draws = stream.getvalue().count('\r')
    assert draws == 2  # the first tick and the one reaching the estimate; none past it
    assert stream.getvalue().endswith('\n')
