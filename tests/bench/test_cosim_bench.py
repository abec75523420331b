"""`cosim bench cosim`'s parts: the floor replays the path the cosim run drove, and the
phase split times every part of one run's loop."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.bench.cosim import PHASES, cosim_run, phase_split, sumo_floor
from cosim.scenario import load_scenario, project_root, with_overrides
from cosim.traffic.snapshot import TrafficSnapshot
from cosim.traffic.world import NEAR_RANGE, World


def _scenario():  # type: ignore[no-untyped-def]
    return with_overrides(load_scenario(project_root() / "scenarios/traffic_high.toml"),
                          duration=1.0)


def test_floor_and_phase_split_of_a_short_dense_run(monkeypatch: pytest.MonkeyPatch) -> None:
    sc = _scenario()
    reads: list[tuple[float, bool]] = []  # World.read's (radius, full), call by call
    read = World.read

    def counted(self: World, radius: float, *, full: bool = True) -> TrafficSnapshot:
        reads.append((radius, full))
        return read(self, radius, full=full)

    monkeypatch.setattr(World, "read", counted)
    wall, cpu, timing = cosim_run(sc)
    x = timing["path"][0]
    assert x.size == sc.n_steps + 1 and np.all(np.diff(x) > 0)  # the SV's path, driven on
    radius, full = timing["scene_read"]  # the rule's and the records' near scene
    # an ideal V2V channel is read at planning: each step reads only the near scene
    assert radius == NEAR_RANGE + 2.0 * sc.vehicle.length and not full
    loop_reads, reads[:] = list(reads), []
    assert loop_reads == [(radius, full)] * (sc.n_steps + 1)  # k = 0 .. n_steps
    floor_wall, floor_cpu = sumo_floor(sc, timing["path"])
    assert floor_wall > 0 and floor_cpu > 0
    assert reads == []  # the floor reads nothing
    sumo_floor(sc, timing["path"], timing["scene_read"])
    assert reads == loop_reads  # the floor and read reads as the loop did
    monkeypatch.undo()
    phases = phase_split(sc)
    assert list(phases) == [name for name, _, _ in PHASES] + ["other"]
    assert all(v > 0 for v in phases.values())
    # SUMO's steps are a large part of a dense run, the per-step parts each less
    assert phases["sumo_step"] > phases["record"]
