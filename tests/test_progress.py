"""The progress bars' ETA comes from the rate after a warm-up, not the first step."""

from __future__ import annotations

import io

from cosim.progress import PLAIN_EVERY, Bar, WarmEta, eta_text, warm_units


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_eta_ignores_a_slow_first_step() -> None:
    """A 200-step run whose first step takes 10 s (SUMO's start) and the rest 0.05 s:
    no ETA during the warm-up, then 0.05 s x the steps left (tqdm's smoothed rate
    says minutes after the first step)."""
    clock = Clock()
    eta = WarmEta(200, warm=10, clock=clock)
    clock.t = 10.0
    assert eta.update() is None
    for _ in range(9):
        clock.t += 0.05
        assert eta.update() is None
    clock.t += 0.05
    assert eta.update() is not None
    for _ in range(39):
        clock.t += 0.05
        left = eta.update()
    assert left is not None and abs(left - 150 * 0.05) < 1e-9
    assert eta_text(None) == "ETA --:--" and eta_text(75.4) == "ETA 01:15"
    assert eta_text(3725) == "ETA 1:02:05"
    assert warm_units(2400) == 50 and warm_units(200) == 10 and warm_units(3) == 1


class Terminal(io.StringIO):
    """A stream that says it is a terminal, as a user's stderr is."""

    def isatty(self) -> bool:
        return True


def test_bar_shows_the_warm_eta_and_fields() -> None:
    out = Terminal()
    with Bar(4, desc="study", unit="run", warm=1, file=out) as bar:
        bar.postfix(done=0, failed=0)
        for _ in range(4):
            bar.update(1)
    text = out.getvalue()
    assert "done=0, failed=0, ETA --:--" in text and "4/4" in text and "run/s" in text


def test_off_a_terminal_progress_is_a_plain_line_every_few_seconds() -> None:
    """In a log or a pipe the bar is not redrawn: one line at the start, one at most every
    PLAIN_EVERY seconds, one at the end (with `leave`); no carriage returns."""
    clock = Clock()
    out = io.StringIO()
    with Bar(800, desc="study", unit="run", warm=1, file=out, clock=clock) as bar:
        bar.postfix(done=0, failed=0)
        for _ in range(800):
            clock.t += 0.125  # 100 s in all
            bar.update(1)
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue() and "\x1b" not in out.getvalue()
    assert len(lines) == 1 + 100 / PLAIN_EVERY + 1
    assert lines[0] == "study: 0/800 run [00:00, ? run/s, ETA --:--]"
    assert lines[1] == "study: 40/800 run [00:05, 8.00 run/s, done=0, failed=0, ETA 01:35]"
    assert lines[-1] == "study: 800/800 run [01:40, 8.00 run/s, done=0, failed=0, ETA 00:00]"


def test_a_run_bar_off_a_terminal_leaves_no_last_line() -> None:
    clock = Clock()
    out = io.StringIO()
    with Bar(10, desc="run", unit="step", file=out, leave=False, clock=clock) as bar:
        for _ in range(10):
            bar.update(1)
    assert out.getvalue() == "run: 0/10 step [00:00, ? step/s, ETA --:--]\n"
