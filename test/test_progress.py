"""The progress of a stage: a bar with times on a terminal, one quiet line elsewhere."""
import io
import re

from tca_ros.calibration import progress as progress_module
from tca_ros.calibration.progress import BAR_CAP, Progress


class Terminal(io.StringIO):
    """A text stream that says it is a terminal."""

    def isatty(self):
        return True


class Clock:
    """A settable perf_counter (s)."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def _bars(text):
    """Return the (filled, width) of each drawn bar."""
    return [(m.count('#'), len(m)) for m in re.findall(r'\[([#.]+)\]', text)]


def test_off_a_terminal_one_quiet_line_per_stage():
    stream = io.StringIO()
    bar = Progress(True, total=10, stream=stream, stage='calibration')
    for _ in range(20):
        bar.tick('fit')
    bar.close()
    bar.close()  # a second close writes nothing
    assert '\r' not in stream.getvalue()
    assert re.fullmatch(r'calibration: 20 simulations in \d+\.\d s\n', stream.getvalue())


def test_disabled_is_silent_everywhere():
    for stream in (io.StringIO(), Terminal()):
        bar = Progress(False, total=10, stream=stream)
        bar.tick()
        bar.close()
        assert stream.getvalue() == ''


def test_redraws_stay_throttled_after_the_count_passes_its_estimate(monkeypatch):
    clock = iter(range(10 ** 6))  # a frozen-ish clock: 1 us per call
    monkeypatch.setattr(progress_module.wallclock, 'perf_counter', lambda: next(clock) * 1e-6)
    stream = Terminal()
    bar = Progress(True, total=10, stream=stream)
    for _ in range(500):
        bar.tick('fit')
    assert stream.getvalue().count('\r') == 2  # the first tick, the one reaching the estimate
    bar.close()
    assert stream.getvalue().count('\r') == 3 and stream.getvalue().endswith('\n')


def test_the_bar_is_full_only_when_the_stage_ends(monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress_module.wallclock, 'perf_counter', clock)
    stream = Terminal()
    bar = Progress(True, total=168, width=30, stream=stream)
    for _ in range(377):  # the estimate was 168, the stage needed 377 (issue 27)
        clock.now += 1.0
        bar.tick('search')
    drawn = _bars(stream.getvalue())
    assert len(drawn) > 100
    assert all(filled < width for filled, width in drawn)
    assert max(filled for filled, _ in drawn) == int(30 * BAR_CAP)
    bar.close()
    assert _bars(stream.getvalue())[-1] == (30, 30)
    assert 'done' in stream.getvalue().splitlines()[-1]


def test_elapsed_and_remaining_time_at_the_mean_pace(monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress_module.wallclock, 'perf_counter', clock)
    stream = Terminal()
    bar = Progress(True, total=100, stream=stream)
    for _ in range(25):
        clock.now += 2.0  # 2 s per simulation
        bar.tick('fit')
    last = stream.getvalue().split('\r')[-1]
    # 25 done in 50 s: 75 left at 2 s each
    assert '50.0 s elapsed' in last and 'left ~2 min 30 s' in last and '  25 sims' in last
    for _ in range(80):
        clock.now += 2.0
        bar.tick('fit')
    last = stream.getvalue().split('\r')[-1]
    assert '210.0' not in last and '3 min 30 s elapsed' in last
    assert 'left ?, past the estimate' in last
