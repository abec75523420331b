"""What one run produced (`RunResult`: what cosim.run.outputs writes) and the timing
row's columns (timing.csv: the one output that differs between two runs)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cosim.driving.manoeuvre import LaneChange
from cosim.params import RoadParams
from cosim.road.road import Road
from cosim.scenario import Scenario

Array = NDArray[np.float64]

TIMING_DOCS: dict[str, str] = {
    "scenario": "scenario name",
    "wall_time_s": "wall time of the whole run, SUMO start to close (s)",
    "wall_sumo_s": "wall time in SUMO stepping and reading (s)",
    "wall_planning_s": "wall time in the planner (s)",
    "wall_control_s": "wall time in controller + plant (s)",
    "wall_realtime_factor": "simulated time / wall time (-)",
    "cpu_time_s": "CPU time of this process over the run, SUMO included (libsumo runs "
    "in-process) (s): less sensitive than wall time to other load on the machine",
}



@dataclass
class RunResult:
    """Everything one run produced (what run_scenario writes)."""

    scenario: Scenario
    road: RoadParams
    trace: dict[str, Array]
    plans: list[dict[str, Any]]
    lane_changes: list[LaneChange]
    tv_tracks: dict[str, tuple[Array, Array, Array]]
    metrics: dict[str, Any]
    timing: dict[str, Any]
    events: list[str] = field(default_factory=list)
    records: list[Any] = field(default_factory=list)  # closed-loop StepRecords (ours only)
    first_plan: Any = None  # the planner's first Plan (for the tau-set figure)
    edges: tuple[str, ...] = ()  # SUMO road ids the trace's `edge` column indexes
    route_road: Road | None = None  # the route's road and (s, d) frame (cosim.road)
    # detectors.csv's rows (cosim.traffic.detectors; a pandas DataFrame), None: no detectors
    detectors: Any = None
    # conflicts.csv's rows (cosim.traffic.ssm; a pandas DataFrame), None: no SSM device
    conflicts: Any = None
    # fleet_conflicts.csv's rows (cosim.run.encounters; a pandas DataFrame), None: no
    # [ssm] with a [fleet]
    fleet_conflicts: Any = None
    t_warmup: float = 0.0  # s, SUMO's clock at the run's clock's 0 (SUMO's outputs' times)
    # the fleet's trace rows and fleet.csv (cosim.run.fleet.FleetResult), None: no [fleet]
    fleet: Any = None
