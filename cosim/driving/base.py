"""What every lane-change policy is and what it is handed.

A policy decides when the SV changes lanes (and, while it keeps its lane, how it
follows); it is one class behind `LaneChangePolicy`, registered by name
(cosim.driving.registry), built from one `DrivingContext`:

- the pieces of the scenario it needs (the SV's spec, its length, the step, the
  decision rule's and the re-check's settings),
- the road as lanes (`LaneLayout`: lane membership, centres, gaps along a lane, speed
  bands) and its friction,
- the planner (None for a policy that hands the SV to SUMO),
- named ports to the world (`WorldPorts`): the SV's blinker, a lane change for SUMO
  to make, a request to a TV to open a gap. A policy reaches SUMO only through them.

Each step the loop calls `status` (what the recorder reads at the top of the step),
then `update` (the step's decisions; returns the reference the ego tracks, None when
SUMO drives), then, when the world carries gap requests, `gaps_held` (whether the TVs
yielding to the SV go on making room at their full braking), and at the end `summary`
(what it did, for the metrics row). Nothing here needs SUMO: a policy can be tested on
hand-made scenes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from cosim.driving.layout import LaneLayout
from cosim.driving.rule import DecisionConfig

if TYPE_CHECKING:
    from cosim.driving.cadence import CadenceConfig
    from cosim.params import RoadParams
    from cosim.planning.planner import PredictionOptions
    from cosim.planning.trajectory import LaneChangeTrajectory
    from cosim.scenario.model import Scenario, SVSpec
    from cosim.traffic.world import Scene, SVState


class Messages(Protocol):
    """What the SV knows of the TVs this step (cosim.run.observer.Inbox)."""

    def read(self) -> list[Any]: ...


def _nothing(*_: object) -> None:
    return None


@dataclass(frozen=True)
class WorldPorts:
    """The policy's named calls into the world (cosim.traffic.world.World provides them)."""

    blinker: Callable[[int], None] = _nothing  # the SV's blinker: -1 right, 0 off, +1 left
    change_lane: Callable[[int], None] = _nothing  # SUMO changes the SV to this lane
    ask_gap: Callable[[float, str], bool | None] = _nothing  # (t, TV id): ask a TV to open
    # a gap; true: some channel carries the request (courtesy, cooperative V2V)


@dataclass(frozen=True)
class DrivingContext:
    """Everything a policy is built from (module docstring)."""

    sv: SVSpec  # the scenario's [sv]: speed, desired speed, decision, requests, occupant
    sv_length: float  # m
    step: float  # s, the loop's step
    lanes: LaneLayout
    mu: float  # -, road friction
    decision: DecisionConfig = field(default_factory=DecisionConfig)
    planner: Any = None  # cosim.planning.planner.LaneChangePlanner (None: SUMO drives)
    replanning: bool = False  # [planner] replanning: re-check the plan under way
    recheck_interval: float = 0.1  # s
    ports: WorldPorts = field(default_factory=WorldPorts)
    sv_width: float = 1.8  # m, the SV's body width
    notice: float = 0.0  # s, how long it signals before it starts a lane change (its V2V
    # partners' time to hear its intention: cosim.run.announcements.notice; 0: none)
    cadence: CadenceConfig | None = None  # how often it decides while keeping its lane
    # (cosim.driving.cadence; None: every step, as the SV)

    @classmethod
    def of(cls, scenario: Scenario, road: RoadParams, *, decision: DecisionConfig | None = None,
           planner: Any = None, ports: WorldPorts | None = None,
           notice: float = 0.0, cadence: CadenceConfig | None = None) -> DrivingContext:
        """The pieces of a scenario a policy needs, on `road` (the network's lanes)."""
        sc = scenario
        return cls(sv=sc.sv, sv_length=sc.vehicle.length, step=sc.step,
                   lanes=LaneLayout(road), mu=road.mu, decision=decision or DecisionConfig(),
                   planner=planner, replanning=sc.planner.replanning,
                   recheck_interval=sc.planner.recheck_interval, ports=ports or WorldPorts(),
                   sv_width=sc.vehicle.width, notice=notice, cadence=cadence)


@dataclass(frozen=True)
class PolicyStatus:
    """What the recorder reads of the lane-change policy at the top of a step."""

    target_lane: int | None  # lane a planned manoeuvre heads for (None: keeping its lane)
    changing: bool  # a planned manoeuvre is under way (trace column `changing`)
    manoeuvring: bool  # a collision onset now is the SV's fault (a lane change under way)
    leader_gap: float  # m, bumper-to-bumper gap to the leader (inf: none)
    idm_accel: float  # m/s^2, car-following acceleration (NaN while changing lanes)


@dataclass
class Manoeuvres:
    """What the policy did over a run, for the metrics row."""

    lane_changes: list[Any]  # adopted plans (cosim.driving.manoeuvre.LaneChange; empty
    # for the SUMO-driven SV)
    starts: list[float]  # s, start of each lane change counted
    targets: list[float]  # m, its target lane centre
    ends: list[float]  # s, end of its settling window
    requests: int  # lane changes requested
    planner_calls: int  # plans.csv rows that are planner calls
    outcomes: dict[str, int]  # re-check outcomes: replan, abort, brake
    first_start: float | None  # s, start of the first adopted plan (IAE window); None: none
    plans: list[dict[str, Any]]  # plans.csv rows
    first_plan: Any = None  # the planner's first Plan (for the tau-set figure)


class LaneChangePolicy(Protocol):
    """A lane-change policy (module docstring). Class attributes: `name` (given by the
    registry), `listens` (it reads V2V messages: the channel must run), `needs_planner`
    (it flies planned manoeuvres; False: SUMO drives the SV), `asks_for_gaps` (it asks
    TVs to open gaps: the world opens the request channels), `prediction` (the
    planner's prediction options this policy's traffic model needs)."""

    name: ClassVar[str]
    listens: ClassVar[bool]
    needs_planner: ClassVar[bool]
    asks_for_gaps: ClassVar[bool]
    prediction: ClassVar[PredictionOptions | None]
    wall: float  # s, wall time in the planner

    def __init__(self, ctx: DrivingContext) -> None: ...
    def status(self, sv: SVState) -> PolicyStatus: ...
    def gaps_held(self, sv: SVState) -> bool:
        """Whether the TVs yielding to the SV go on making room at their full braking
        (cosim.traffic.cooperation): while it waits for its gap, and while the change
        under way counts on their courtesy until it is in their lane; false once a
        change under way asks nothing more of them. The loop asks only a policy that
        `asks_for_gaps`."""
        ...
    def update(self, t: float, scene: Scene, messages: Messages
               ) -> LaneChangeTrajectory | None: ...
    def summary(self, t: np.ndarray, y: np.ndarray) -> Manoeuvres: ...
