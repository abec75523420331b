"""The progress bars' ETA comes from the rate after a warm-up, not the first step."""

from __future__ import annotations

import io

from cosim.progress import Bar, WarmEta, eta_text, warm_units


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


def test_bar_shows_the_warm_eta_and_fields() -> None:
    out = io.StringIO()
    with Bar(4, desc="study", unit="run", warm=1, file=out) as bar:
        bar.postfix(done=0, failed=0)
        for _ in range(4):
            bar.update(1)
    text = out.getvalue()
    assert "done=0, failed=0, ETA --:--" in text and "4/4" in text and "run/s" in text
