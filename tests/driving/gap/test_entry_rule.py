"""The entry rule against SUMO's own follower, through real SUMO: the follower the SV
gets is predicted as it is when the SV's body enters its lane (its braking, its minimum
gap, its reaction; cosim.planning.interaction.check_follower), and its real braking
after the entry stays within what the rule allowed."""

from __future__ import annotations

from cosim.driving.gap.geometry import GapConfig
from cosim.run.loop import simulate
from cosim.run.metrics import SUMO_MIN_GAP
from cosim.scenario import load_scenario, project_root, with_overrides

BASE = project_root() / "scenarios" / "study_density_base.toml"
DAWDLING = 0.6  # m/s^2, SUMO's dawdling on top of any braking (up to 0.52 a step)


def test_a_cut_in_beside_a_yielding_follower_waits_until_it_has_room() -> None:
    # the density study's base at 65 veh/km/lane, seed 16: at 8.6 m/s the SV signals to a
    # TV alongside in lane 2 braking for it at about 2.2 m/s^2; a plan whose centre would
    # enter 2.2 m ahead of it (its side 0.4 m) made it brake at 9 m/s^2 at the side's
    # entry. The rule waits until the follower has its room at the side's entry.
    sc = with_overrides(load_scenario(BASE), density=65.0, seed=16, duration=11.0)
    m = simulate(sc).metrics
    cfg = GapConfig()
    assert m["lane_changes"] == 1 and m["lane_change_completed"] == 1
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0
    # the follower's real response: no more than the rule's limit (and the courtesy's
    # braking before the change) with SUMO's dawdling, and never within its minimum gap
    assert m["follower_max_decel_mps2"] <= max(cfg.insist_decel, 2.0) + DAWDLING
    assert m["entry_follower_gap_m"] >= SUMO_MIN_GAP
    assert m["entry_follower_needed_decel_mps2"] <= cfg.insist_decel


def test_an_insisted_entry_is_not_held_back_by_an_earlier_refusal() -> None:
    # the density study's base at 15 veh/km/lane, seed 2: the TV behind the SV in lane 2
    # closes fast and is refused (it would brake at 4.5-9 m/s^2) until the courtesy and
    # the SV's speed-up bring it within insist_decel; the entry then holds with the TVs
    # behind 1 m/s faster (its margin) and is taken, not refused again as a follower
    # refused moments ago (which held it until 4.0 s: request to lane 3.9 s)
    sc = with_overrides(load_scenario(BASE), seed=2, duration=6.5)
    m = simulate(sc).metrics
    cfg = GapConfig()
    assert m["lane_change_completed"] == 1 and m["collisions"] == 0
    assert m["request_to_lane_s"] <= 3.5
    assert m["follower_max_decel_mps2"] <= cfg.insist_decel + DAWDLING
    assert m["entry_follower_gap_m"] >= SUMO_MIN_GAP
