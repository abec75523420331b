"""Insertion the SV can survive: behind random traffic it starts at a speed
it can brake from (SUMO's departSpeed rule); scripted scenarios keep their speed."""

from __future__ import annotations

import math

import pytest

from cosim.params import G
from cosim.run.loop import simulate
from cosim.scenario import load_scenario, project_root, with_overrides
from cosim.traffic.demand import (
    START_DECEL,
    START_GRIP,
    START_REACTION,
    TV_MIN_GAP,
    safe_start_speed,
)

SCENARIOS = project_root() / "scenarios"


@pytest.mark.parametrize("mu", [0.4, 0.8])
@pytest.mark.parametrize("leader_speed", [0.0, 8.6, 20.0])
def test_from_the_safe_speed_the_sv_stops_behind_a_leader_that_stops(
        mu: float, leader_speed: float) -> None:
    gap = 61.8
    v = safe_start_speed(50.0, gap, leader_speed, mu)
    b = min(START_DECEL, START_GRIP * mu * G)
    # reaction, then braking at b: it stops minGap behind where the leader stops at b
    sv_stop = v * START_REACTION + v * v / (2 * b)
    leader_stop = gap + leader_speed**2 / (2 * b)
    assert sv_stop == pytest.approx(leader_stop - TV_MIN_GAP)
    assert safe_start_speed(v - 1.0, gap, leader_speed, mu) == v - 1.0  # slower: kept
    assert safe_start_speed(50.0, gap, leader_speed, 0.2) < v  # less grip: slower


def test_a_queue_too_close_and_slow_on_a_wet_road_lowers_the_start_speed() -> None:
    """Wet road, 65 veh/km/lane: SUMO inserts the queue ahead at ~8.6 m/s 62 m ahead of
    the SV; at 100 km/h every seed ended in an SV-caused rear-end collision at 4.8 s."""
    base = load_scenario(SCENARIOS / "study_density_base.toml")
    sc = with_overrides(base, density=65.0, mu=0.4, seed=101, policy="gap", duration=10.0)
    r = simulate(sc)
    m = r.metrics
    assert m["start_speed_mps"] == pytest.approx(r.trace["vx_mps"][0])
    assert 15.0 < m["start_speed_mps"] < 20.0 < sc.sv.speed
    assert m["collisions"] == 0 and m["stopped_by_collision"] == 0
    # SUMO's own driver gets the same start
    sumo = simulate(with_overrides(sc, controller="sumo"))
    s = sumo.metrics
    assert s["start_speed_mps"] == pytest.approx(m["start_speed_mps"])
    assert s["collisions"] == 0
    # set as the speed it drove, not reported as a jump (it was -65 m/s^2 at t = 0)
    assert abs(sumo.trace["ax_mps2"][0]) < 5.0


def test_scripted_and_free_starts_keep_their_speed() -> None:
    for name in ("paper_case1_overtaking", "traffic_high"):
        sc = with_overrides(load_scenario(SCENARIOS / f"{name}.toml"), duration=0.1)
        m = simulate(sc).metrics
        assert m["start_speed_mps"] == pytest.approx(sc.sv.speed, abs=1e-9)
        assert math.isfinite(m["start_speed_mps"])
