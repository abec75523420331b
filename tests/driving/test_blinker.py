"""A policy's blinker (cosim.driving.blinker): set in the world only when it changes,
and a change started only once the direction has been shown for the notice."""

from __future__ import annotations

from cosim.driving.blinker import Blinker


def test_the_blinker_is_set_once_per_change_and_counts_its_notice() -> None:
    sent: list[int] = []
    b = Blinker(sent.append, notice=0.35)
    b.set(1, 2.0)
    b.set(1, 2.05)  # the same direction: nothing sent, the notice runs on from 2.0
    assert sent == [1]
    assert not b.noticed(2.3) and b.noticed(2.35)
    b.set(1)  # the manoeuvre's own calls carry no time: the notice is not restarted
    b.set(0)
    b.set(-1, 3.0)
    assert sent == [1, 0, -1] and not b.noticed(3.3) and b.noticed(3.4)
    assert Blinker(sent.append).noticed(0.0)  # no notice: at once
