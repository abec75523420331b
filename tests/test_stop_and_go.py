"""Stop-and-go through real SUMO (libsumo): a TV ahead brakes to a standstill, stands,
drives off; the SV stops at least 2 m behind it and follows it off, its control output
finite down to vx -> 0."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cosim.run.loop import simulate
from cosim.scenario import load_scenario, with_overrides

SCENARIO = Path(__file__).parent / "data" / "tv_stops_and_goes.toml"


@pytest.mark.parametrize("controller", ["mimo", "siso"])
def test_sv_stops_behind_a_standing_tv_and_drives_off(controller: str) -> None:
    sc = with_overrides(load_scenario(SCENARIO), controller=controller)
    r = simulate(sc)
    t, vx, gap = r.trace["t_s"], r.trace["vx_mps"], r.trace["leader_gap_m"]
    assert r.metrics["collisions"] == 0 and r.metrics["sumo_collisions"] == 0
    assert np.all(np.isfinite(vx))
    # the TV stops at 2 + 25 / 3 = 10.3 s and stands until 20.3 s: the SV comes to rest
    # behind it, at least 2 m (bumper to bumper) away
    rest = (t > 17.0) & (t < 20.3)
    assert np.all(np.abs(vx[rest]) < 0.05)
    assert gap.min() >= 2.0
    assert np.all(gap[rest] < 4.0)  # and it did close up: a queue, not a far stop
    # the SV never reverses, drives off after the TV (not before) and is back at speed
    # (the TV's 15 m/s at least) 25 s later
    assert vx.min() > -0.05
    off = t[(t > 17.0) & (vx > 0.5)]
    assert off.size and 20.3 < off[0] < 23.0
    assert vx[-1] > 15.0
    assert abs(r.trace["y_m"] - r.trace["y_m"][0]).max() < 0.05  # in its lane throughout


def test_traffic_jam_runs_through_a_queue_that_stops_and_restarts() -> None:
    from cosim.scenario import project_root

    r = simulate(load_scenario(project_root() / "scenarios" / "traffic_jam.toml"))
    m, vx = r.metrics, r.trace["vx_mps"]
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0 and m["sumo_events"] == 0
    # the queue stands (16 s: long enough for its SUMO cars to stop creeping up) and the
    # SV comes to a full stop in it
    assert vx.min() < 0.05
    assert vx.min() > -0.05 and np.all(np.isfinite(vx))
    assert vx[-1] > 15.0  # and it drove off with it
    # it stops at its standstill gap, not inside it: behind a standing leader within s0
    # the reference speed is held at 0 (CarFollowing.holding; the IDM alone closes in
    # below 2 m)
    assert r.trace["leader_gap_m"].min() >= 2.0
    # and no chatter on the way (no step-to-step jump of ax of 2 m/s^2 or more at low speed)
    jumps = np.abs(np.diff(r.trace["ax_mps2"]))
    assert np.all(jumps[vx[1:] < 16.0] < 2.0)
    # no lane change was planned below the planner's minimum speed
    from cosim.driving.manoeuvre import PLANNER_MIN_SPEED

    assert all(p["vx0_mps"] >= PLANNER_MIN_SPEED for p in r.plans)
