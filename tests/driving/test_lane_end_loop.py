"""The SV on a lane that ends through the whole loop (real SUMO, plant, controller):
the straight test road with `RoadParams.lane_ends` set for lane 0 at END (SUMO's lane
runs on: the SV alone believes it ends; the ramp networks are the road side's tests).
All the driving side needs is that field: the mandatory change at speed into a free
lane, and with a queue braking to a standstill beside it the stop before the end, the
wait and the merge from a standstill, tracked by the plant."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cosim.planning.deadline import END_MARGIN
from cosim.run.loop import simulate
from cosim.scenario import load_scenario
from cosim.scenario.model import TVBrake, TVSpec

SCENARIO = Path(__file__).parents[1] / "data" / "tv_stops_and_goes.toml"
END = 550.0  # m, where the SV's lane 0 ends (it starts at 300 m)


def run(policy: str, blocked: bool):  # type: ignore[no-untyped-def]
    sc = load_scenario(SCENARIO)
    tvs: tuple[TVSpec, ...] = ()
    if blocked:
        # eight TVs in lane 1 from 25 m ahead to 59 m behind the SV at its 20 m/s brake
        # at 2 m/s^2 from t = 5 s to a standstill beside the ramp's last 100 m, stand 15 s
        tvs = tuple(TVSpec(id=f"q{k}", lane=1, gap=25.0 - 12.0 * k, speed=20.0, accel=0.0,
                           length=4.32, width=1.8, lane_change=None,
                           brake=TVBrake(at=5.0, decel=2.0, hold=15.0, restart_accel=1.5,
                                         restart_speed=15.0))
                    for k in range(8))
    sv = replace(sc.sv, lane=0, position=300.0, speed=20.0, desired_speed=20.0)
    return simulate(replace(sc, road=replace(sc.road, lane_ends=(END,)), sv=sv, tvs=tvs,
                            duration=60.0,
                            planner=replace(sc.planner, policy=policy, replanning=True)))


@pytest.mark.parametrize("policy", ["paper", "gap"])
@pytest.mark.parametrize("blocked", [False, True])
def test_the_sv_leaves_a_lane_that_ends_before_its_end(policy: str, blocked: bool) -> None:
    r = run(policy, blocked)
    tr, road = r.trace, r.road
    assert r.metrics["collisions"] == 0 and r.metrics["sumo_collisions"] == 0
    s, d, vx = (np.asarray(tr[k]) for k in ("s_m", "d_m", "vx_mps"))
    front = s + 0.5 * 4.32
    on_ramp = d - 0.9 < road.lane_width  # the body touches lane 0 (y_right = 0)
    assert front[on_ramp].max() <= END - END_MARGIN  # never past the end in its lane
    assert abs(d[-1] - road.lane_center(1)) < 0.05  # merged
    ok = [p for p in r.plans if p["ok"] == 1]
    assert ok and ok[0]["trigger"] == "mandatory"
    assert np.abs(np.asarray(tr["delta_f_deg"])).max() < 30.0  # within the steering
    if blocked:
        # it stops before the end and waits until the queue drives off (about 30 s), then
        # merges from the standstill (gap 38.4 s, paper 36.0 s)
        assert vx.min() < 0.05
        assert ok[0]["t_s"] > 30.0
    else:
        assert ok[0]["t_s"] == 0.0 and vx.min() > 19.0  # at once, at speed
