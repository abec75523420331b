"""A scenario's planning situation without SUMO: what `cosim plan` and the bench plan.

At the SV's first scripted lane-change request (time `at`), the SV is at
x = position + speed * at (it keeps its lane and speed until then), y = its lane
centre, heading 0, no acceleration; the road's right edge is at y = 0; the TVs
are where their scripts put them (cosim.traffic.scripted) and say what their
scripts broadcast.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from cosim.errors import InputError
from cosim.params import RoadParams
from cosim.planning.planner import SVPlanState
from cosim.traffic import scripted
from cosim.traffic.v2v import V2VMessage

if TYPE_CHECKING:
    from cosim.scenario import Scenario


@dataclass(frozen=True)
class Situation:
    """Everything `LaneChangePlanner.plan` needs, for one scenario."""

    t: float  # s, simulation time of the planning instant
    sv: SVPlanState
    target_lane: int
    messages: tuple[V2VMessage, ...]
    occupant: float  # -, p
    road: RoadParams  # with y_right = 0
    sv_x0: float  # m, SV's x at t = 0 (the TVs' gaps are measured from it)


def situation(scenario: Scenario) -> Situation:
    """The planning situation at the SV's first scripted lane change."""
    if not scenario.sv.lane_changes:
        raise InputError(str(scenario.path), "sv.lane_changes", [],
                         "at least one {at_s, target_lane} to plan")
    cmd = scenario.sv.lane_changes[0]
    road = replace(scenario.road, y_right=0.0)
    sv = scenario.sv
    x0 = sv.position
    state = SVPlanState(
        x=x0 + sv.speed * cmd.at, y=road.lane_center(sv.lane), heading=0.0, vx=sv.speed,
        ax=0.0, vy=0.0, ay=0.0, lane=sv.lane,
    )
    messages = tuple(scripted.message(tv, cmd.at, road, x0) for tv in scenario.tvs)
    return Situation(cmd.at, state, cmd.target_lane, messages, sv.occupant, road, x0)
