"""The SV as one interface, two implementations.

- `PlannedEgo`: our SV, the plant driven by the controller (cosim.control.closed_loop)
  tracking the reference the policy hands it; its pose is written to SUMO with
  moveToXY after each step's `scenario.substeps` substeps.
- `SumoDrivenEgo`: the baseline (controller "sumo"): an ordinary SUMO vehicle of the
  SV's size that SUMO's own car-following and lane-change models drive; its state
  is read from SUMO, and its lateral acceleration and yaw rate, which SUMO does not
  report, are taken from its recorded path at the end.

Both put the SV into the world, give its state at the top of a step, write their
own trace columns (cosim.run.recorder.TRACE_COLUMNS) and advance one step.
"""

from __future__ import annotations

import math
import time
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.run.recorder import COLUMN
from cosim.scenario import Scenario
from cosim.traffic.road_view import is_identity, stretch
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.world import SV_ID, SVState, World

Array = NDArray[np.float64]


class Ego(Protocol):
    """The SV the loop steps (see the module docstring)."""

    plant: str  # the plant's name in the metrics row ("none": SUMO drives)
    tracks_reference: bool  # it tracks a reference (the IAE columns mean something)
    records: list[Any]  # the closed loop's StepRecords (empty when SUMO drives)
    wall: float  # s, wall time in controller + plant

    def inserted(self) -> None: ...
    def start_speed(self, speed: float, reference: LaneChangeTrajectory) -> None: ...
    def state(self, everyone: TrafficSnapshot) -> SVState: ...
    def write_trace(self, row: Array) -> None: ...
    def advance(self, t: float, dt: float, reference: LaneChangeTrajectory | None) -> None: ...
    def finish_trace(self, trace: dict[str, Array]) -> None: ...


class PlannedEgo:
    """Our SV: plant + controller (`scenario.sv.plant`, `scenario.sv.controller`)."""

    tracks_reference = True
    vehicle_id = SV_ID  # its SUMO id (an automated vehicle of the fleet: its own)
    keeps_records = True  # every step's StepRecord kept (for the tracking figures)

    def __init__(self, scenario: Scenario, world: World, y0: float,
                 first_reference: LaneChangeTrajectory) -> None:
        sc = scenario
        x0 = world.sv_start_x  # m, s and d of the start (road coordinates)
        self.plant = sc.sv.plant
        self.substeps = sc.substeps
        self.world = world
        self._start = (sc, x0, y0)
        self.start_speed(sc.sv.speed, first_reference)
        world.add_controlled(SV_ID, x0, y0, 0.0, sc.sv.speed,
                             (sc.vehicle.length, sc.vehicle.width), sc.sv.lane)
        self.wall = 0.0

    def start_speed(self, speed: float, reference: LaneChangeTrajectory) -> None:
        """(Re)start the closed loop at t = 0 at `speed` (m/s) tracking `reference` (SUMO
        gets the speed with the first pose written)."""
        from cosim.control.closed_loop import ClosedLoop, LoopConfig
        from cosim.vehicle.plant import PlantStart

        sc, x0, y0 = self._start
        # the plant is Cartesian; the reference and the scene are in road coordinates
        # (speed along s: at the start's offset the car drives q times it)
        cx, cy, ch, q = self.world.cartesian(x0, y0, 0.0)
        # on a curve the car starts turning with its lane (the lane's curvature is the
        # line's over q, its speed q times the plan's: speed x the line's curvature)
        yaw_rate = speed * float(self.world.frame.curvature(x0))
        self.loop = ClosedLoop(LoopConfig(sc.sv.plant, sc.sv.controller), sc.vehicle, sc.gains,
                               sc.road.mu, PlantStart(cx, cy, ch, speed * q, yaw_rate=yaw_rate),
                               frame=self.world.frame)
        self.loop.set_reference(reference)
        self.record = self.loop.record(0.0)
        self.records: list[Any] = [self.record]

    def inserted(self) -> None:
        """Nothing to do: the SV stays under our control."""

    def state(self, everyone: TrafficSnapshot) -> SVState:
        r = self.record
        road_id, lane = self.world.sv_lane(self.vehicle_id)
        if is_identity(self.world.frame):
            return SVState(r.x, r.y, r.heading, r.vx, r.vy, lane, road_id)
        s, d, rel = self.loop.road_pose
        q = float(stretch(self.world.frame, s, d))
        return SVState(s, d, rel, r.vx / q, r.vy, lane, road_id,
                       cartesian=(r.x, r.y, r.heading), stretch=q)

    def write_trace(self, row: Array) -> None:
        r = self.record
        C = COLUMN
        row[C["yaw_rate_degps"]] = math.degrees(r.yaw_rate)
        row[C["ax_mps2"]] = r.ax
        row[C["ay_mps2"]] = r.ay
        row[C["x_ref_m"]] = r.x_ref
        row[C["y_ref_m"]] = r.y_ref
        row[C["psi_ref_deg"]] = math.degrees(r.heading - r.phi_e)
        row[C["vx_ref_mps"]] = r.vx_ref
        row[C["curvature_ref_1pm"]] = r.kappa_ref
        row[C["ex_mps"]] = r.ex
        row[C["ye_m"]] = r.ye
        row[C["phie_deg"]] = math.degrees(r.phi_e)
        row[C["delta_f_deg"]] = math.degrees(r.delta_f)
        row[C["dmz_nm"]] = r.dmz
        row[C["fa_n"]] = r.fa
        row[C["fx_fl_n"]], row[C["fx_fr_n"]], row[C["fx_rl_n"]], row[C["fx_rr_n"]] = r.fx
        row[C["fx_total_n"]] = sum(r.fx)

    def advance(self, t: float, dt: float, reference: LaneChangeTrajectory | None) -> None:
        """Control + plant from t to t + dt tracking `reference`, then the pose to SUMO."""
        assert reference is not None, "the planned SV always tracks a reference"
        w0 = time.perf_counter()
        r = self.record = self.loop.advance(t, dt, self.substeps, reference)
        if self.keeps_records:
            self.records.append(r)
        self.wall += time.perf_counter() - w0
        self.world.move_xy(self.vehicle_id, r.x, r.y, r.heading, r.vx, r.ax,
                           road_pose=self.loop.road_pose)

    def finish_trace(self, trace: dict[str, Array]) -> None:
        """Nothing to add: every column came from the closed loop."""


class SumoDrivenEgo:
    """The baseline SV (controller "sumo"): SUMO drives it (see the module docstring)."""

    plant = "none"
    tracks_reference = False

    def __init__(self, scenario: Scenario, world: World) -> None:
        sc = scenario
        lane = sc.sv.lane
        desired = sc.sv.desired_speed or sc.road.speed_bands[lane][1]
        world.add_sumo_driven_sv(lane, sc.sv.speed, desired, sc.vehicle.length,
                                 sc.vehicle.width, own_lane_changes=sc.sv.decision)
        self.world = world
        self.records: list[Any] = []
        self.wall = 0.0
        self.ax = math.nan  # m/s^2, SUMO's longitudinal acceleration of the SV now

    def inserted(self) -> None:
        """From now on SUMO drives it."""
        self.world.hand_sv_to_sumo()

    def start_speed(self, speed: float, reference: LaneChangeTrajectory) -> None:
        """Its speed at t = 0 (m/s), as if it had driven it over the insertion step (at
        zero acceleration: SUMO would otherwise report the jump as one)."""
        self.world.set_sv_previous_speed(speed)

    def state(self, everyone: TrafficSnapshot) -> SVState:
        i = everyone.index(SV_ID)
        self.ax = self.world.sv_acceleration()  # not in every read
        x, y, h = float(everyone.x[i]), float(everyone.y[i]), float(everyone.heading[i])
        road_id, lane = self.world.sv_lane()
        speed, lateral = float(everyone.speed[i]), float(everyone.lateral_speed[i])
        if everyone.cx is None:
            return SVState(x, y, h, speed, lateral, lane, road_id)
        cx, cy, ch = everyone.cartesian
        q = float(stretch(self.world.frame, x, y))
        return SVState(x, y, h, speed, lateral, lane, road_id,
                       cartesian=(float(cx[i]), float(cy[i]), float(ch[i])), stretch=q)

    def write_trace(self, row: Array) -> None:
        row[COLUMN["ax_mps2"]] = self.ax

    def advance(self, t: float, dt: float, reference: LaneChangeTrajectory | None) -> None:
        """Nothing to do: SUMO moves it in its own step."""

    def finish_trace(self, trace: dict[str, Array]) -> None:
        """Body lateral acceleration and yaw rate from the path (finite differences of
        the recorded poses; SUMO does not report lateral acceleration)."""
        t, x, y = trace["t_s"], trace["x_m"], trace["y_m"]
        psi = np.radians(trace["psi_deg"])
        if t.size < 3:
            return
        vxg, vyg = np.gradient(x, t), np.gradient(y, t)
        axg, ayg = np.gradient(vxg, t), np.gradient(vyg, t)
        c, s = np.cos(psi), np.sin(psi)
        trace["ay_mps2"] = -axg * s + ayg * c
        trace["yaw_rate_degps"] = np.degrees(np.gradient(np.unwrap(psi), t))
