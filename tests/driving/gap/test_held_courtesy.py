"""A scripted change that counts on the courtesy held, through real SUMO:
the TV asked to make room goes on braking until the SV is in its lane, and the SV
goes before it has all its room (cosim.driving.gap.yielding, GapDecision.held)."""

from __future__ import annotations

import math

from cosim.driving.gap.geometry import GapConfig
from cosim.run.loop import simulate
from cosim.scenario import load_scenario, project_root, with_overrides
from cosim.traffic.cooperation import COURTESY_DECEL

# the density study's base at 20 veh/km/lane, seed 3: asked at 2 s for lane 2, where a
# TV 22.6 m behind the SV closes at 3.7 m/s (it would brake at 5.2 m/s^2 for an SV
# going at once) and the next one is 34.5 m ahead
BASE = project_root() / "scenarios" / "study_density_base.toml"
DAWDLING = 0.6  # m/s^2, SUMO's dawdling on top of any braking (up to 0.52 a step)


def test_the_sv_goes_on_the_yielding_tvs_braking_and_it_brakes_no_more() -> None:
    sc = with_overrides(load_scenario(BASE), density=20.0, seed=3, duration=9.0)
    m = simulate(sc).metrics
    cfg = GapConfig()
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0
    # in lane 2 half a manoeuvre after its courtesy may be held (the plan at 0.7 s, the
    # centre across 1.73 s later), before it would insist (patience, 1 s); waiting for
    # the TV to have all its room took 2.8 s
    assert m["request_to_lane_s"] <= cfg.hold_after + 0.5 * cfg.nominal_tau + 0.1
    assert m["lane_changes"] == 1 and m["lane_change_completed"] == 1
    # its new follower went on with the courtesy's braking during the change, and was
    # asked for nothing beyond it
    assert 1.0 < m["follower_max_decel_mps2"] <= COURTESY_DECEL + DAWDLING
    assert math.isfinite(m["merge_time_gap_s"]) and m["post_change_max_decel_mps2"] < 2.0
