"""The co-simulation loop: our SV (planner + controller + plant) in SUMO traffic.

One step of `dt = scenario.step` (DESIGN.md "One co-simulation step"); at the
top of step k SUMO and the plant are both at t_k = k dt:

1. snapshot of every vehicle SUMO has (one pass, numpy arrays),
2. record row k: SV state, reference, errors, inputs, our exact overlap check
   of the SV against every TV, SUMO's collisions of the last step, gap / TTC,
3. V2V: messages of the TVs near the SV (scripted TVs: `scripted.message`),
   through the channel (range, latency, loss),
4. plan when a lane change is wanted (scripted request due, or the decision
   rule) and the SV is not already changing lanes; no collision-free tau:
   keep the lane, follow the leader, ask again `retry_interval` later,
5. control + plant: `scenario.substeps` substeps from t_k to t_k+1 tracking the
   plan, or, keeping the lane, a straight reference on the lane centre whose
   speed follows the IDM law (cosim.decision),
6. write back: SV and scripted TVs to SUMO with moveToXY (through the adapter),
7. `simulationStep()`: SUMO moves its own vehicles to t_k+1.

Controller "sumo" is the baseline: the SV is an ordinary SUMO vehicle of the
SV's size; scripted requests become `changeLane` calls, the decision rule is
SUMO's own lane-change model; the same trace columns (those SUMO has) and the
same metrics.

`run_scenario` runs one scenario and writes trace.csv, plans.csv,
metrics.csv, timing.csv and the figures (all atomically, all but timing.csv
byte-identical between two runs of the same scenario and seed).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cosim import metrics as mx
from cosim.decision import DecisionConfig, LaneChangeTimer, decide
from cosim.errors import SimulationError
from cosim.params import G, RoadParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.scenario import Scenario
from cosim.traffic.sumo import SumoSim, TrafficSnapshot

Array = NDArray[np.float64]

SV_ID = "sv"
SV_LENGTH_MARGIN = 2.0  # SV lengths kept free of random traffic around the SV at t = 0
NEAR_RANGE = 150.0  # m, TVs within this x distance of the SV are recorded for the figures
SETTLE_TOL = 0.1  # m, |y - target lane centre| below which a lane change counts as done
FOLLOW_HORIZON = 1.0  # s, horizon of the straight lane-keeping reference
IAE_WINDOW = 10.0  # s, IAE from the start of the first lane change (cosim track's default)
FOLLOW_GRIP = 0.7  # -, share of mu g the car-following reference may brake with
MAX_FOLLOW_JERK = 15.0  # m/s^3, rate limit of the car-following acceleration
REF_SPEED_BAND = 0.5  # m/s, the lane-keeping reference speed stays this close to Vx
BRAKE_GRIP = 0.7  # -, share of mu g an emergency brake (no replan, no abort) may use
BRAKE_TAU = 3.0  # s, emergency brake's duration when the planner gave no tau_min
BRAKE_TAU_MIN = 1.5  # s, shortest emergency brake (lateral move to the nearest centre)
UNCERTAIN_CLOSING_SPEED = 5.0  # m/s, closing speed assumed for the V2V latency margin

# ----------------------------------------------------------------------------- columns

TRACE_COLUMNS: dict[str, str] = {
    "t_s": "simulation time (s)",
    "x_m": "SV centre (= CG) global x (m)",
    "y_m": "SV centre global y (m)",
    "psi_deg": "SV heading, 0 along +x, counter-clockwise positive (deg)",
    "vx_mps": "SV body longitudinal speed Vx (m/s)",
    "vy_mps": "SV body lateral speed Vy (m/s)",
    "yaw_rate_degps": "SV yaw rate Omega_z (deg/s)",
    "ax_mps2": "SV body longitudinal acceleration (m/s^2)",
    "ay_mps2": "SV body lateral acceleration (m/s^2)",
    "x_ref_m": "reference point global x (m); NaN for the SUMO baseline",
    "y_ref_m": "reference point global y (m)",
    "psi_ref_deg": "reference path heading (deg)",
    "vx_ref_mps": "reference speed Vx* (eq. 14) (m/s)",
    "curvature_ref_1pm": "reference path curvature KL (eq. 15) (1/m)",
    "ex_mps": "speed error ex = Vx - Vx* (eq. 28) (m/s)",
    "ye_m": "lateral offset from the reference path ye (eq. 16) (m)",
    "phie_deg": "heading error phi_e (eq. 16) (deg)",
    "delta_f_deg": "front road-wheel steering angle delta_f (deg)",
    "dmz_nm": "yaw moment demand dMz (eq. 22) (N m)",
    "fa_n": "total longitudinal force demand Fa (eq. 28) (N)",
    "fx_fl_n": "front-left wheel longitudinal force (eq. 30) (N)",
    "fx_fr_n": "front-right wheel longitudinal force (N)",
    "fx_rl_n": "rear-left wheel longitudinal force (N)",
    "fx_rr_n": "rear-right wheel longitudinal force (N)",
    "fx_total_n": "sum of the four wheel longitudinal forces (N)",
    "lane": "lane the SV's centre is in, from its y (SUMO index)",
    "sumo_lane": "SV's lane index as SUMO has it (-1 off the network)",
    "target_lane": "lane the SV is heading for (= lane when keeping its lane)",
    "changing": "1 while a planned lane change is under way, else 0",
    "leader_gap_m": "bumper-to-bumper gap to the leader in the SV's lane (m; inf: none)",
    "idm_accel_mps2": "car-following (IDM) acceleration when keeping the lane (m/s^2)",
    "gap_min_m": "smallest along-lane gap to a TV sharing the SV's strip (m; inf: none)",
    "ttc_min_s": "smallest along-lane time-to-collision to such a TV (s; inf: none)",
    "collisions": "number of TVs whose rectangle overlaps the SV's (our exact check)",
    "sumo_collisions": "number of collisions involving the SV SUMO reported this step",
    "n_tvs": "number of TVs within 150 m (x) of the SV",
}
COLUMN = {name: i for i, name in enumerate(TRACE_COLUMNS)}

PLAN_COLUMNS: dict[str, str] = {
    "t_s": "simulation time of the planning request (s)",
    "trigger": "scripted | decision | retry",
    "origin_lane": "lane the SV is in (SUMO index)",
    "target_lane": "lane requested (SUMO index)",
    "vx0_mps": "SV speed at the request (m/s)",
    "vxf_mps": "target speed at the end of the lane change (band rule) (m/s)",
    "n_candidates": "number of tau values on the grid",
    "tau_min_stable_s": "smallest stable tau (handling envelope) (s)",
    "stable_set_s": "stable tau set as intervals a-b;c-d (s)",
    "collision_free_set_s": "collision-free tau set (intervals) (s)",
    "tau_opt_s": "tau_opt of eq. 13 over the collision-free set (s)",
    "tau_s": "tau chosen (collision-free tau nearest tau_opt) (s; NaN: no plan)",
    "ok": "1: a plan was adopted, 0: no collision-free tau (the SV keeps its lane)",
    "rejected_unstable": "candidates rejected by the handling envelope",
    "rejected_collision": "candidates rejected for a collision",
    "rejections": "collisions per TV id, id:count;id:count (or why the request was dropped)",
    "reason": "replan | abort | brake rows: why the plan under way was dropped (the re-check's "
    "first collision); else empty",
}

METRIC_DOCS: dict[str, str] = {
    "scenario": "scenario name",
    "seed": "random seed (SUMO and traffic)",
    "controller": "mimo | siso | sumo (SUMO-native baseline)",
    "plant": "twotrack | bicycle (none for the baseline)",
    "duration_s": "simulated time (s)",
    "steps": "number of SUMO steps",
    "lane_change_requests": "lane changes requested (scripted or by the decision rule; "
    "for the SUMO baseline with decision = true, also the changes SUMO made on its own)",
    "plans": "planner calls",
    "plans_failed": "planner calls that found no collision-free tau",
    "replans": "plans under way replaced by a new plan to the same target lane (re-check "
    "found a collision; [planner] replanning)",
    "aborts": "plans under way given up for a return to the origin lane",
    "emergency_brakes": "plans under way given up for braking in the nearest lane (neither a "
    "replan nor an abort was collision-free)",
    "lane_changes": "lane changes completed (ended within 0.1 m of the target lane centre)",
    "lane_change_completed": "1 if at least one lane change was requested and all started ones "
    "completed, else 0",
    "lane_change_duration_s": "mean duration of the completed lane changes, start to settled "
    "within 0.1 m of the target lane centre (s; NaN: none)",
    "lane_change_duration_max_s": "longest such duration (s; NaN: none)",
    "lane_change_durations_s": "every lane change's duration in order, ';'-separated (s; "
    "nan: did not settle before the next change or the end)",
    "tau_first_s": "tau of the first adopted plan (s; NaN: none)",
    "collisions": "collision events by our exact overlap check (SV against every TV; one "
    "contact counts once)",
    "collision": "1 if collisions > 0, else 0",
    "collisions_sv": "collision events the SV caused: at the onset it was changing lanes "
    "(a planned manoeuvre under way), or the TV's centre was ahead of the SV's (the SV ran "
    "into it); the rest are TVs running into a lane-keeping SV from behind or the side",
    "collisions_manoeuvre": "collision events whose onset fell while the SV was changing lanes "
    "(a planned manoeuvre under way, replans and aborts included; the SUMO-driven SV: moving "
    "sideways faster than 0.05 m/s)",
    "sumo_collisions": "collision events involving the SV reported by SUMO (cross-check)",
    "min_gap_m": "smallest along-lane gap to a TV sharing the SV's strip (m; inf: none)",
    "min_ttc_s": "smallest along-lane time-to-collision (s; inf: never closing on anyone)",
    "max_abs_lat_accel_mps2": "largest |body lateral acceleration| (m/s^2)",
    "max_abs_long_accel_mps2": "largest |body longitudinal acceleration| (m/s^2)",
    "max_jerk_mps3": "largest |d(ax, ay)/dt| between steps (m/s^3)",
    "iae_vx_mps_s": "IAE of ex = Vx - Vx* over the 10 s from the start of the first lane "
    "change (the whole run without one) (Table 2 column Vx) ((m/s) s)",
    "iae_ye_m_s": "IAE of ye, same window (Table 2 column ye) (m s)",
    "iae_phie_deg_s": "IAE of phi_e, same window (Table 2 column phi_e) (deg s)",
    "iae_deltaf_deg_s": "integral of |delta_f|, same window (Table 2 column delta_f) (deg s)",
    "iae_fx_kn_s": "integral of the sum of the four wheels' |Fx|, same window (Table 2 "
    "column Fx) (kN s)",
    "final_lane": "SV's lane at the end (SUMO index, from y)",
    "final_offset_m": "SV's y minus its lane centre at the end (m)",
    "mean_speed_mps": "SV's mean speed (m/s)",
    "sumo_events": "SUMO teleports / lost vehicles during the run",
}

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


def _fmt_intervals(spans: list[tuple[float, float]]) -> str:
    return ";".join(f"{a:.2f}-{b:.2f}" for a, b in spans)


def plan_row(plan: Any, trigger: str, vx0: float) -> dict[str, Any]:
    """One plans.csv row of a planner's Plan (see PLAN_COLUMNS)."""
    per_tv: dict[str, int] = {}
    n_unstable = 0
    for rej in plan.rejections:
        if rej.reason == "unstable":
            n_unstable += 1
        else:
            key = rej.vehicle_id or "?"
            per_tv[key] = per_tv.get(key, 0) + 1
    return {
        "t_s": plan.t,
        "trigger": trigger,
        "origin_lane": plan.origin_lane,
        "target_lane": plan.target_lane,
        "vx0_mps": vx0,
        "vxf_mps": plan.vxf,
        "n_candidates": int(plan.taus.size),
        "tau_min_stable_s": plan.tau_min,
        "stable_set_s": _fmt_intervals(plan.stable_intervals),
        "collision_free_set_s": _fmt_intervals(plan.collision_free_intervals),
        "tau_opt_s": plan.tau_opt,
        "tau_s": math.nan if plan.tau is None else float(plan.tau),
        "ok": int(plan.tau is not None),
        "rejected_unstable": n_unstable,
        "rejected_collision": sum(per_tv.values()),
        "rejections": ";".join(f"{k}:{v}" for k, v in sorted(per_tv.items())),
        "reason": "",
    }


# ----------------------------------------------------------------------------- records


@dataclass
class LaneChange:
    """One adopted lane-change plan and how it went."""

    t0: float  # s, start
    tau: float  # s, planned duration
    origin_lane: int  # lane the manoeuvre under way leaves (after an abort: the one it aborted)
    target_lane: int  # lane it heads for (after an abort: the lane it started in)
    y_target: float  # m, target lane centre
    trajectory: LaneChangeTrajectory
    plan: Any  # the planner's Plan (for the tau-set figure)
    t_next: float = math.inf  # s, when the next manoeuvre started (window end)
    trigger: str = ""  # what asked for it (scripted | decision | retry)
    aborted: bool = False  # given up for a return to the origin lane (not a lane change)
    start_lane: int = -1  # lane it started in
    wanted_lane: int = -1  # lane first asked for


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


class _Tracks:
    """TV positions near the SV, appended per step as arrays (for Fig. 16)."""

    def __init__(self) -> None:
        self.chunks: list[tuple[float, tuple[str, ...], Array, Array]] = []

    def add(self, t: float, snap: TrafficSnapshot) -> None:
        if len(snap):
            self.chunks.append((t, snap.ids, snap.x, snap.y))  # snapshots are never modified

    def result(self) -> dict[str, tuple[Array, Array, Array]]:
        """id -> (t, x, y) arrays in time order."""
        if not self.chunks:
            return {}
        ids = np.array([vid for _, chunk_ids, _, _ in self.chunks for vid in chunk_ids])
        t = np.concatenate([np.full(len(c[1]), c[0]) for c in self.chunks])
        x = np.concatenate([c[2] for c in self.chunks])
        y = np.concatenate([c[3] for c in self.chunks])
        names, inverse = np.unique(ids, return_inverse=True)
        order = np.argsort(inverse, kind="stable")  # by vehicle, in time order within
        bounds = np.searchsorted(inverse[order], np.arange(names.size + 1))
        return {
            str(name): (t[order[a:b]], x[order[a:b]], y[order[a:b]])
            for name, a, b in zip(names, bounds[:-1], bounds[1:], strict=True)
        }


def lane_keeping_reference(
    t: float, x: float, y_centre: float, speed: float, accel: float
) -> LaneChangeTrajectory:
    """A straight reference along a lane centre whose speed starts at `speed` and
    changes at `accel` (m/s^2) over the next FOLLOW_HORIZON (a 'lane change' of width 0)."""
    return LaneChangeTrajectory(
        t0=t, tau=FOLLOW_HORIZON, x0=x, y0=y_centre, vx0=speed,
        vxf=max(speed + accel * FOLLOW_HORIZON, 0.0), width=0.0, ax0=accel,
    )


def reference_state(trajectory: LaneChangeTrajectory, t: float, lane: int) -> Any:
    """The reference's state at t as a planning start (position, velocity and
    acceleration of the reference, not of the plant: a new plan from it continues the
    reference without a jump, and the controller's errors carry over unchanged)."""
    from cosim.planning.planner import SVPlanState

    x, y = trajectory.position(t)
    xd, yd = trajectory.derivative(t, 1)
    xdd, ydd = trajectory.derivative(t, 2)
    return SVPlanState(x=float(x), y=float(y), heading=math.atan2(float(yd), float(xd)),
                       vx=float(xd), ax=float(xdd), vy=float(yd), ay=float(ydd), lane=lane)


def uncertain_config(scenario: Scenario) -> Any:
    """The planner's settings with the safety margin widened for what V2V does not
    tell exactly ([planner] uncertainty_margin): latency (and the extra age of lost
    messages) times an assumed closing speed, plus, without V2V, two standard
    deviations of the measured position and the speed noise over one second."""
    cfg, v2v = scenario.planner, scenario.v2v
    if not cfg.uncertainty_margin:
        return cfg
    age = v2v.latency + scenario.step * v2v.loss / max(1.0 - v2v.loss, 1e-3)
    extra = age * UNCERTAIN_CLOSING_SPEED
    if v2v.mode == "perception":
        extra += 2.0 * v2v.noise_position + v2v.noise_speed * 1.0
    if extra <= 0.0:
        return cfg
    return replace(cfg, safety_margin=cfg.safety_margin + extra)


ProgressFn = Callable[[int], None]


# ----------------------------------------------------------------------------- the loop


class CoSimulation:
    """One run of a scenario: SUMO (through SumoSim) + planner + controller + plant."""

    def __init__(self, scenario: Scenario, *, gui: bool = False,
                 decision: DecisionConfig | None = None) -> None:
        self.sc = scenario
        self.gui = gui
        self.cfg = decision or DecisionConfig()
        self.baseline = scenario.sv.controller == "sumo"
        self.dt = scenario.step
        self.n_steps = scenario.n_steps
        self.timer = LaneChangeTimer(self.cfg)
        self.pending = list(scenario.sv.lane_changes)  # scripted requests not yet served
        self.lane_changes: list[LaneChange] = []
        self.active: LaneChange | None = None
        self.plans: list[dict[str, Any]] = []
        self.requests = 0
        self.wall = {"sumo": 0.0, "planning": 0.0, "control": 0.0}
        self.tracks = _Tracks()
        self.data = np.full((self.n_steps + 1, len(TRACE_COLUMNS)), np.nan)
        self.sumo_pairs: set[tuple[str, ...]] = set()
        self.sumo_new = 0  # SUMO collision events involving the SV (onsets)
        self.sumo_step_collisions = 0  # SUMO collisions involving the SV in the last step
        self.collision_flags: list[frozenset[str]] = []
        self.v_cruise = scenario.sv.speed  # m/s, speed kept without a leader (no decision rule)
        self.idm_accel = 0.0
        self.leader_gap = math.inf

        self.sv_length = scenario.vehicle.length
        self.sv_width = scenario.vehicle.width
        self.sv_diag = math.hypot(self.sv_length, self.sv_width)  # m, body diagonal
        self.started = False
        self.cpu = 0.0  # s, process CPU time of the run
        self.first_plan: Any = None
        self.records: list[Any] = []
        self.last_failed: tuple[int, int] | None = None  # (origin, target) of a failed plan
        self.replanning = scenario.planner.replanning and not self.baseline
        self.next_check = math.inf  # s, next re-check of the plan under way
        self.outcomes = {"replan": 0, "abort": 0, "brake": 0}  # re-check outcomes
        self.sv_fault = 0  # collision onsets the SV caused (see METRIC_DOCS)
        self.manoeuvre_hits = 0  # collision onsets during a lane change of the SV

    # ------------------------------------------------------------------ set-up
    def _start(self) -> None:
        sc = self.sc
        tr = sc.traffic
        self.sumo = SumoSim(
            sc.network, sc.step, sc.seed,
            lanechange_duration=tr.lanechange_duration, sublane=tr.sublane, gui=self.gui,
            speed_bands=sc.road.speed_bands,  # sumo-gui's pace: cosim.traffic.gui
        )
        self.sumo.start()
        self.started = True
        hw = self.sumo.highway
        self.road = sc.road  # lane geometry: the network's, read once by the scenario
        road = self.road
        x0 = hw.x_start + sc.sv.position  # sv.position_m: from the road's start
        y0 = road.lane_center(sc.sv.lane)
        self.x0 = x0
        if tr.density > 0:
            from cosim.traffic.demand import populate, start_zone

            margin = SV_LENGTH_MARGIN * self.sv_length
            # in its own lane the SV starts at its scenario speed, often faster than
            # the queue SUMO inserts: keep room to brake (and for its follower)
            zone = start_zone(x0, self.sv_length, sc.sv.speed,
                              road.speed_bands[sc.sv.lane][1])
            populate(self.sumo, road, tr.density, sc.seed, tr.length,
                     exclude_zone=(x0 - margin, x0 + margin), lane_zones={sc.sv.lane: zone})
        self._start_scripted(x0)
        if self.baseline:
            self._add_baseline_sv(x0, sc.sv.lane)
        else:
            from cosim.control.closed_loop import ClosedLoop
            from cosim.planning.planner import LaneChangePlanner

            self.loop = ClosedLoop(sc.sv.plant, sc.sv.controller, sc.vehicle, sc.gains,
                                   road.mu, x0, y0, 0.0, sc.sv.speed)
            self.planner = LaneChangePlanner(sc.vehicle, road, uncertain_config(sc))
            self.sumo.add_controlled(SV_ID, x0, y0, 0.0, sc.sv.speed, self.sv_length,
                                     self.sv_width, sc.sv.lane)
            self.loop.set_reference(lane_keeping_reference(0.0, x0, y0, sc.sv.speed, 0.0))
            self.record = self.loop.record(0.0)
            self.records = [self.record]
        from cosim.traffic.v2v import V2VChannel

        self.channel = V2VChannel.from_spec(sc.v2v, road, sc.seed)
        # without latency or loss the messages at a planning call are exactly those
        # published then: build them only when planning (they are the costly part)
        v2v = sc.v2v
        self.v2v_every_step = v2v.latency > 0 or v2v.loss > 0 or v2v.mode != "v2v"
        # the per-step read covers what the rule, the records and the collision check
        # need; a planning call reads everyone in V2V range once more
        self.radius = (max(NEAR_RANGE, v2v.range) if self.v2v_every_step else NEAR_RANGE) \
            + 2.0 * self.sv_length
        # the first step inserts every vehicle at its place
        self.sumo.step()
        if self.baseline:
            self.sumo.release(SV_ID)  # from now on SUMO drives it
        self.t_offset = self.sumo.time  # SUMO's clock when our t = 0
        self.sumo.follow_in_gui(SV_ID)
        self.v_ref = sc.sv.speed  # m/s, lane-keeping reference speed (integrated IDM)

    # ------------------------------------------------------------------ scripted TVs
    def _start_scripted(self, x_sv: float) -> None:
        """Add the scenario's [[tv]] vehicles as controlled vehicles on their scripts."""
        self.scripted: list[Any] = []
        self.scripted_ids: tuple[str, ...] = tuple(tv.id for tv in self.sc.tvs)
        self.scripted_poses: list[list[tuple[float, ...]]] = []
        if not self.sc.tvs:
            return
        from cosim.traffic import scripted

        # the scripts are known in advance: evaluate them once for every step time
        times = self.dt * np.arange(self.n_steps + 2)
        for spec in self.sc.tvs:
            tv = scripted.ScriptedTV(spec, self.road, x_sv)
            k = tv.kinematics(times)
            poses = list(zip(k.x.tolist(), k.y.tolist(), k.heading.tolist(), k.speed.tolist(),
                             k.accel.tolist(), strict=True))
            x, y, h, v, _a = poses[0]
            self.sumo.add_controlled(spec.id, x, y, h, v, spec.length, spec.width, spec.lane,
                                     vtype="tv_scripted")
            self.scripted.append(tv)
            self.scripted_poses.append(poses)

    def _move_scripted(self, t: float) -> None:
        k = int(round(t / self.dt))
        for tv, poses in zip(self.scripted, self.scripted_poses, strict=True):
            x, y, h, v, a = poses[k]
            self.sumo.move(tv.spec.id, x, y, h, v, a)

    def _scripted_accel(self, snap: TrafficSnapshot, t: float) -> TrafficSnapshot:
        """The snapshot with the scripted TVs' true accelerations: SUMO reports a wrong
        one for vehicles moved by moveToXY (+4 m/s^2 for a TV braking at 8 m/s^2)."""
        accel = np.array(snap.accel, dtype=float)
        k = int(round(t / self.dt))
        for tv, poses in zip(self.scripted, self.scripted_poses, strict=True):
            if tv.spec.id in snap.ids:
                accel[snap.index(tv.spec.id)] = poses[k][4]
        return replace(snap, accel=accel)

    def _scripted_messages(self, t: float) -> list[Any]:
        if self.sc.v2v.mode == "perception":  # measured through the channel like the rest
            return []
        return [m for m in (tv.message(t) for tv in self.scripted) if m is not None]

    # ------------------------------------------------------------------ baseline SV
    def _add_baseline_sv(self, x0: float, lane: int) -> None:
        """The SV as an ordinary SUMO vehicle of the SV's size (controller 'sumo')."""
        sc = self.sc
        desired = sc.sv.desired_speed or sc.road.speed_bands[lane][1]
        self.sumo.add_driven(SV_ID, lane, x0, sc.sv.speed, desired, self.sv_length,
                             self.sv_width, own_lane_changes=sc.sv.decision)

    # ------------------------------------------------------------------ one run
    def run(self, progress: ProgressFn | None = None) -> RunResult:
        wall0 = time.perf_counter()
        cpu0 = time.process_time()
        try:
            self._start()
            for k in range(self.n_steps + 1):
                t = k * self.dt
                w0 = time.perf_counter()
                snap_all = self.sumo.snapshot_near(SV_ID, self.radius)
                self.wall["sumo"] += time.perf_counter() - w0
                sv = self._sv_view(snap_all)
                near, tvs = self._near(snap_all, sv)
                self._record_row(k, t, sv, tvs)
                if k == self.n_steps:
                    break
                if self.baseline:
                    self._baseline_step(t, sv, tvs)
                else:
                    self._step(t, sv, tvs, snap_all)
                self._move_scripted(t + self.dt)
                w0 = time.perf_counter()
                self.sumo.step()
                self.wall["sumo"] += time.perf_counter() - w0
                self._sumo_collisions()
                if progress is not None:
                    progress(1)
            events = [f"{e.time - self.t_offset:.2f} s {e.kind} {e.vehicle_id}: {e.detail}"
                      for e in self.sumo.events]
        finally:
            if self.started:
                self.sumo.close()
        wall = time.perf_counter() - wall0
        self.cpu = time.process_time() - cpu0
        return self._result(wall, events)

    def _sv_view(self, snap_all: TrafficSnapshot) -> dict[str, float]:
        """The SV now: ours from the closed loop, the baseline's from SUMO."""
        if SV_ID not in snap_all.ids:  # the baseline SV reached the road's end
            raise SimulationError(snap_all.time - self.t_offset,
                                  "the SV is no longer on the network (end of the road?)")
        i = snap_all.index(SV_ID)
        lane = float(snap_all.lane[i])
        if not self.baseline:
            r = self.record
            return {"x": r.x, "y": r.y, "h": r.heading, "vx": r.vx, "vy": r.vy, "lane": lane}
        h = float(snap_all.heading[i])
        v = float(snap_all.speed[i])
        vlat = float(snap_all.lateral_speed[i])
        return {"x": float(snap_all.x[i]), "y": float(snap_all.y[i]), "h": h,
                "vx": v, "vy": vlat, "ax": float(snap_all.accel[i]),
                "lane": lane}

    def _near(self, snap_all: TrafficSnapshot, sv: dict[str, float]
              ) -> tuple[NDArray[np.bool_], TrafficSnapshot]:
        near = (np.abs(snap_all.x - sv["x"]) <= NEAR_RANGE) & (snap_all.lane >= 0)
        near[snap_all.index(SV_ID)] = False
        tvs = snap_all.select(near)
        self.tv_vx = tvs.speed * np.cos(tvs.heading)  # m/s, global x velocities
        return near, tvs

    def _record_row(self, k: int, t: float, sv: dict[str, float], tvs: TrafficSnapshot) -> None:
        from cosim.planning.collision import overlap_sat

        row = self.data[k]
        C = COLUMN
        x, y, h, vx, vy = sv["x"], sv["y"], sv["h"], sv["vx"], sv["vy"]
        row[C["t_s"]] = t
        row[C["x_m"]] = x
        row[C["y_m"]] = y
        row[C["psi_deg"]] = math.degrees(h)
        row[C["vx_mps"]] = vx
        row[C["vy_mps"]] = vy
        if self.baseline:
            row[C["ax_mps2"]] = sv["ax"]
        else:
            r = self.record
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
        lane = self.road.lane_of(y)
        row[C["lane"]] = lane
        row[C["sumo_lane"]] = sv["lane"]
        row[C["target_lane"]] = self.active.target_lane if self.active is not None else lane
        row[C["changing"]] = 1.0 if self.active is not None else 0.0
        row[C["leader_gap_m"]] = self.leader_gap
        row[C["idm_accel_mps2"]] = self.idm_accel if self.active is None else math.nan
        # gap / TTC along the lane, and our exact overlap check against every TV near
        c, s_ = abs(math.cos(h)), abs(math.sin(h))
        hx = 0.5 * (self.sv_length * c + self.sv_width * s_)
        hy = 0.5 * (self.sv_length * s_ + self.sv_width * c)
        tv_hx, tv_hy = mx.half_extents(tvs.length, tvs.width, tvs.heading)
        sv_vxg = vx * math.cos(h) - vy * math.sin(h)
        gap, ttc = mx.gap_ttc(x, y, sv_vxg, hx, hy, tvs.x, tvs.y,
                             self.tv_vx, tv_hx, tv_hy)
        row[C["gap_min_m"]] = float(gap.min()) if gap.size else math.inf
        row[C["ttc_min_s"]] = float(ttc.min()) if ttc.size else math.inf
        # exact test only where the bounding circles meet (most steps: nobody)
        reach = 0.5 * (np.hypot(tvs.length, tvs.width) + self.sv_diag)
        near = np.flatnonzero(np.hypot(tvs.x - x, tvs.y - y) <= reach)
        hits: frozenset[str] = frozenset()
        if near.size:
            hit = overlap_sat(x, y, h, self.sv_length, self.sv_width, tvs.x[near], tvs.y[near],
                              tvs.heading[near], tvs.length[near], tvs.width[near])
            hits = frozenset(tvs.ids[i] for i, c in zip(near, hit, strict=True) if c)
        prev = self.collision_flags[-1] if self.collision_flags else frozenset()
        for vid in hits - prev:  # onsets: was the SV at fault? (changing lanes, or hit ahead)
            i = tvs.index(vid)
            # the SUMO-driven SV has no plan: moving sideways is its lane change
            changing = self.active is not None or (self.baseline and abs(vy) > 0.05)
            if changing or float(tvs.x[i]) > x:
                self.sv_fault += 1
            self.manoeuvre_hits += int(changing)
        self.collision_flags.append(hits)
        row[C["collisions"]] = len(hits)
        row[C["sumo_collisions"]] = self.sumo_step_collisions
        row[C["n_tvs"]] = len(tvs)
        self.tracks.add(t, tvs)

    def _sumo_collisions(self) -> None:
        """SUMO's collisions of the last step that involve the SV (cross-check)."""
        pairs = {tuple(sorted(p)) for p in self.sumo.collisions() if SV_ID in p}
        self.sumo_new += len(pairs - self.sumo_pairs)
        self.sumo_pairs = pairs  # type: ignore[assignment]
        self.sumo_step_collisions = len(pairs)

    # ------------------------------------------------------------------ decisions
    def _desired_speed(self, lane: int) -> float:
        sv = self.sc.sv
        if sv.desired_speed is not None:
            return sv.desired_speed
        if sv.decision:
            return self.road.speed_bands[lane][1]
        return self.v_cruise

    def _decide(self, t: float, sv: dict[str, float], tvs: TrafficSnapshot,
                allow_scripted: bool, allow_decision: bool) -> tuple[int | None, str]:
        """Car-following acceleration for this step, and a lane change wanted now
        (a due scripted request first, else the decision rule)."""
        lane = self.road.lane_of(sv["y"])
        speed = self.v_ref
        d = decide(sv["x"], sv["y"], speed, self.sv_length, self._desired_speed(lane),
                   tvs.x, tvs.y, self.tv_vx, tvs.length, tvs.width,
                   self.road, self.cfg, allow_change=allow_decision and self.sc.sv.decision,
                   tv_lateral_speed=tvs.lateral_speed)
        # a reference the car can follow: braking within the road's grip, and the
        # acceleration changing at most MAX_FOLLOW_JERK (a new leader cutting in)
        lo = -min(self.cfg.max_brake, FOLLOW_GRIP * self.road.mu * G)
        step = MAX_FOLLOW_JERK * self.dt
        a = min(max(d.accel, lo, self.idm_accel - step), self.idm_accel + step)
        self.idm_accel = a
        self.leader_gap = d.leader_gap
        if not allow_scripted:
            return None, ""
        # scripted requests first (due, in time order); one already satisfied is dropped
        while self.pending and self.pending[0].at <= t + 1e-9:
            target = self.pending[0].target_lane
            if target == lane:
                self.pending.pop(0)
                continue
            if abs(target - lane) != 1:  # an earlier change never happened: drop it
                self.pending.pop(0)
                row = dict.fromkeys(PLAN_COLUMNS, math.nan)
                row.update(t_s=t, trigger="scripted", origin_lane=lane, target_lane=target,
                           vx0_mps=sv["vx"], ok=0, stable_set_s="", collision_free_set_s="",
                           rejections="not an adjacent lane")
                self.plans.append(row)
                self.requests += 1
                continue
            return target, "scripted"
        if allow_decision and d.target_lane is not None:
            return d.target_lane, "decision"
        return None, ""

    def _step(self, t: float, sv: dict[str, float], tvs: TrafficSnapshot,
              snap_all: TrafficSnapshot) -> None:
        """Our SV: V2V, maybe plan, then control + plant over one step, then write back."""
        sc = self.sc
        if self.active is not None and t >= self.active.t0 + self.active.tau - 1e-9:
            done = self.active
            self.active = None
            self.v_ref = float(done.trajectory.vxf)
            self.v_cruise = self.v_ref
            self.timer.manoeuvre_done(t)
            self.sumo.set_blinker(SV_ID, 0)
        free = self.active is None
        target, trigger = self._decide(
            t, sv, tvs, free and self.timer.may_request(t, decision=False),
            free and self.timer.may_request(t))
        check = self.active is not None and self.replanning and t >= self.next_check - 1e-9
        if self.v2v_every_step or target is not None or check:
            if not self.v2v_every_step and self.sc.v2v.range > NEAR_RANGE:
                snap_all = self.sumo.snapshot()  # everyone: the channel keeps those in range
            perceived = self.sc.v2v.mode == "perception"  # scripted TVs are measured too
            public = snap_all.select(np.array(
                [vid != SV_ID and (perceived or vid not in self.scripted_ids)
                 for vid in snap_all.ids],
                dtype=bool))
            if perceived and self.scripted:
                public = self._scripted_accel(public, t)
            messages = self.channel.exchange(public, sv["x"], sv["y"])
        if target is not None:
            messages = messages + self._scripted_messages(t)
            self._plan(t, target, trigger, messages)
        elif check:
            self._recheck(t, messages + self._scripted_messages(t))
        if self.active is not None:
            reference = self.active.trajectory
        else:
            lane = self.road.lane_of(sv["y"])
            # anti-windup of the reference: never far from the speed the car has
            self.v_ref = min(max(self.v_ref, sv["vx"] - REF_SPEED_BAND), sv["vx"] + REF_SPEED_BAND)
            reference = lane_keeping_reference(t, sv["x"], self.road.lane_center(lane),
                                               self.v_ref, self.idm_accel)
            self.v_ref = max(self.v_ref + self.idm_accel * self.dt, 0.0)
        w0 = time.perf_counter()
        self.record = self.loop.advance(t, self.dt, sc.substeps, reference)
        self.records.append(self.record)
        self.wall["control"] += time.perf_counter() - w0
        r = self.record
        self.sumo.move(SV_ID, r.x, r.y, r.heading, r.vx, r.ax)

    def _plan(self, t: float, target: int, trigger: str, messages: list[Any]) -> None:
        """Ask the planner for a lane change to `target`; adopt the plan, or keep the
        lane and ask again after `retry_interval`."""
        from cosim.planning.planner import SVPlanState

        r = self.record
        lane = self.road.lane_of(r.y)
        # the paper's boundary conditions (x'' = y' = y'' = 0 at the start): the SV plans
        # only while keeping its lane, where these are ~0; the measured values carry
        # the plant's transients (at t = 0: drag with no force yet) into the plan
        state = SVPlanState(x=r.x, y=r.y, heading=r.heading, vx=r.vx, ax=0.0, vy=0.0, ay=0.0,
                            lane=lane)
        if trigger != "decision" and self.last_failed == (lane, target):
            trigger = "retry"
        if trigger != "retry":
            self.requests += 1
        w0 = time.perf_counter()
        plan = self.planner.plan(t, state, target, messages, self.sc.sv.occupant)
        self.wall["planning"] += time.perf_counter() - w0
        self.plans.append(plan_row(plan, trigger, state.vx))
        if self.first_plan is None:
            self.first_plan = plan
        if plan.trajectory is None:
            self.timer.planning_failed(t)
            self.last_failed = (lane, target)
            return
        self.last_failed = None
        if trigger != "decision" and self.pending:
            self.pending.pop(0)
        self.active = LaneChange(
            t0=t, tau=float(plan.tau), origin_lane=lane, target_lane=target,
            y_target=self.road.lane_center(target), trajectory=plan.trajectory, plan=plan,
        )
        self.active.trigger = trigger
        self.active.start_lane, self.active.wanted_lane = lane, target
        self.lane_changes.append(self.active)
        self.sumo.set_blinker(SV_ID, 1 if target > lane else -1)
        self.next_check = t + self.sc.planner.recheck_interval

    # ------------------------------------------------------------------ replanning
    def _recheck(self, t: float, messages: list[Any]) -> None:
        """Beyond the paper (S2): re-check the rest of the plan under way against fresh
        predictions; if it now collides, replan to the target lane from the reference's
        state at t, else abort to the origin lane, else brake in the nearest lane."""
        lc = self.active
        assert lc is not None
        self.next_check = t + self.sc.planner.recheck_interval
        w0 = time.perf_counter()
        rejection = self.planner.check(lc.trajectory, t, messages)
        self.wall["planning"] += time.perf_counter() - w0
        if rejection is None:
            return
        when = math.nan if rejection.time is None else rejection.time
        reason = f"re-check: collision with {rejection.vehicle_id} at {when:.2f} s"
        frm, to = lc.origin_lane, lc.target_lane
        state = reference_state(lc.trajectory, t, frm)
        occupant = self.sc.sv.occupant
        w0 = time.perf_counter()
        # continuing keeps the driver's intent, so it is tried first; the abort only
        # when no collision-free tau to the target lane is left
        again = self.planner.plan(t, state, to, messages, occupant)
        back = None
        if again.trajectory is None:
            back = self.planner.plan(t, replace(state, lane=to), frm, messages, occupant)
        self.wall["planning"] += time.perf_counter() - w0
        if again.trajectory is not None:
            kind, plan, trajectory = "replan", again, again.trajectory
        elif back is not None and back.trajectory is not None:
            kind, plan, trajectory = "abort", back, back.trajectory
        else:
            kind, plan = "brake", back if back is not None else again
            trajectory = self._brake_trajectory(t, lc, plan)
        self.outcomes[kind] += 1
        if kind == "brake":
            self.next_check = math.inf  # the last resort: not re-checked into another one
        row = plan_row(plan, kind, state.vx)
        row.update(reason=reason)
        if kind == "brake":
            row.update(tau_s=trajectory.tau, ok=1, target_lane=self.road.lane_of(
                trajectory.y_final))
        self.plans.append(row)
        lc.trajectory = trajectory
        lc.plan = plan
        lc.tau = trajectory.t_end - lc.t0
        end_lane = self.road.lane_of(trajectory.y_final)
        if end_lane != to:  # heading back: the manoeuvre now leaves `to` for `end_lane`
            lc.origin_lane, lc.target_lane = to, end_lane
            lc.y_target = self.road.lane_center(end_lane)
            self.sumo.set_blinker(SV_ID, 1 if end_lane > to else -1)
        was_aborted = lc.aborted
        lc.aborted = lc.target_lane == lc.start_lane  # back where it started: no lane change
        if lc.aborted and not was_aborted and lc.trigger in ("scripted", "retry"):
            from cosim.scenario import LaneChangeCommand  # ask again once back in the lane

            self.pending.insert(0, LaneChangeCommand(at=t, target_lane=lc.wanted_lane))

    def _brake_trajectory(self, t: float, lc: LaneChange, plan: Any) -> LaneChangeTrajectory:
        """Neither replan nor abort is collision-free: brake (within BRAKE_GRIP mu g at the
        quartic's peak) while steering to the nearest lane centre, from the reference's
        state at t (eq. 2 / eq. 4 with general start values)."""
        st = reference_state(lc.trajectory, t, lc.origin_lane)  # lane unused here
        lane = self.road.lane_of(st.y)
        tau = plan.tau_min if math.isfinite(plan.tau_min) else BRAKE_TAU
        tau = max(tau, BRAKE_TAU_MIN)
        # the quartic from a = ax0 to a(tau) = 0 peaks at about 1.5x its mean deceleration
        decel = BRAKE_GRIP * self.road.mu * G / 1.5
        vxf = max(st.vx - decel * tau, 0.0)
        return LaneChangeTrajectory(
            t0=t, tau=tau, x0=st.x, y0=st.y, vx0=st.vx, vxf=vxf,
            width=self.road.lane_center(lane) - st.y, ax0=st.ax, vy0=st.vy, ay0=st.ay,
        )

    def _baseline_step(self, t: float, sv: dict[str, float], tvs: TrafficSnapshot) -> None:
        """SUMO drives the SV; scripted requests become changeLane calls."""
        lane = self.road.lane_of(sv["y"])
        while self.pending and self.pending[0].at <= t + 1e-9:
            target = self.pending.pop(0).target_lane
            if target == lane:
                continue
            self.requests += 1
            self.sumo.change_lane(SV_ID, target)
            row = dict.fromkeys(PLAN_COLUMNS, math.nan)
            row.update(t_s=t, trigger="scripted", origin_lane=lane, target_lane=target,
                       vx0_mps=sv["vx"], ok=1, stable_set_s="", collision_free_set_s="",
                       rejections="")
            self.plans.append(row)
            break
        # the gap to the leader, for the trace (SUMO's own model follows it)
        self.v_ref = sv["vx"]
        self._decide(t, sv, tvs, allow_scripted=False, allow_decision=False)

    # ------------------------------------------------------------------ results
    def _result(self, wall: float, events: list[str]) -> RunResult:
        sc = self.sc
        trace = {name: self.data[:, i].copy() for name, i in COLUMN.items()}
        t = trace["t_s"]
        if self.baseline:
            _baseline_accelerations(trace)
        # lane changes: ours from each adopted plan's start, the baseline's from the path
        if self.baseline:
            starts, targets, ends = _excursions(t, trace["y_m"], self.road)
        else:
            for a, b in zip(self.lane_changes, self.lane_changes[1:], strict=False):
                a.t_next = b.t0
            # an aborted manoeuvre is not a lane change (the SV went back)
            flown = [lc for lc in self.lane_changes if not lc.aborted]
            starts = [lc.t0 for lc in flown]
            targets = [lc.y_target for lc in flown]
            ends = [min(lc.t_next, t[-1]) for lc in flown]
        durations = mx.lane_change_durations(t, trace["y_m"], starts, targets, ends, SETTLE_TOL)
        done = durations[np.isfinite(durations)]
        collisions = 0
        prev: frozenset[str] = frozenset()
        for hits in self.collision_flags:
            collisions += len(hits - prev)
            prev = hits
        ok_plans = [p for p in self.plans if p["ok"] == 1]
        requests = self.requests
        if self.baseline and sc.sv.decision:
            # SUMO's own lane-change model decided: each change it made was its request
            requests += max(len(starts) - self.requests, 0)
        y_end = float(trace["y_m"][-1])
        lane_end = self.road.lane_of(y_end)
        m: dict[str, Any] = {
            "scenario": sc.name,
            "seed": sc.seed,
            "controller": sc.sv.controller,
            "plant": "none" if self.baseline else sc.sv.plant,
            "duration_s": float(t[-1]),
            "steps": self.n_steps,
            "lane_change_requests": requests,
            "plans": 0 if self.baseline else len(self.plans),
            "plans_failed": sum(1 for p in self.plans if p["ok"] == 0),
            "replans": self.outcomes["replan"],
            "aborts": self.outcomes["abort"],
            "emergency_brakes": self.outcomes["brake"],
            "lane_changes": int(done.size),
            "lane_change_completed": int(requests > 0 and len(starts) > 0
                                         and done.size == len(starts)),
            "lane_change_duration_s": float(done.mean()) if done.size else math.nan,
            "lane_change_duration_max_s": float(done.max()) if done.size else math.nan,
            "lane_change_durations_s": ";".join(
                "nan" if not np.isfinite(d) else f"{d:.2f}" for d in durations),
            "tau_first_s": float(ok_plans[0]["tau_s"]) if ok_plans else math.nan,
            "collisions": collisions,
            "collision": int(collisions > 0),
            "collisions_sv": self.sv_fault,
            "collisions_manoeuvre": self.manoeuvre_hits,
            "sumo_collisions": self.sumo_new,
            "min_gap_m": float(np.min(trace["gap_min_m"])),
            "min_ttc_s": float(np.min(trace["ttc_min_s"])),
            "max_abs_lat_accel_mps2": mx.max_abs(trace["ay_mps2"]),
            "max_abs_long_accel_mps2": mx.max_abs(trace["ax_mps2"]),
            "max_jerk_mps3": mx.max_abs(mx.jerk(t, trace["ax_mps2"], trace["ay_mps2"])),
        }
        if self.baseline:
            m.update(dict.fromkeys(mx.IAE_COLUMNS, math.nan))
        else:
            # over the first lane change (Table 2: "the single lane change"), as long
            # as `cosim track` runs; the whole run when there is none
            t0 = self.lane_changes[0].t0 if self.lane_changes else 0.0
            t1 = t0 + IAE_WINDOW if self.lane_changes else float(t[-1])
            m.update(mx.iae_row(t, trace, t0, t1))
        m.update(
            final_lane=lane_end,
            final_offset_m=y_end - self.road.lane_center(lane_end),
            mean_speed_mps=float(np.mean(trace["vx_mps"])),
            sumo_events=len(events),
        )
        timing = {
            "scenario": sc.name,
            "wall_time_s": wall,
            "wall_sumo_s": self.wall["sumo"],
            "wall_planning_s": self.wall["planning"],
            "wall_control_s": self.wall["control"],
            "wall_realtime_factor": float(t[-1]) / wall if wall > 0 else math.nan,
            "cpu_time_s": self.cpu,
        }
        return RunResult(sc, self.road, trace, self.plans, self.lane_changes,
                         self.tracks.result(), m, timing, events,
                         records=[] if self.baseline else self.records,
                         first_plan=self.first_plan)


def _baseline_accelerations(trace: dict[str, Array]) -> None:
    """Body accelerations and yaw rate of the SUMO-driven SV from its path (finite
    differences of the recorded poses; SUMO does not report lateral acceleration)."""
    t, x, y = trace["t_s"], trace["x_m"], trace["y_m"]
    psi = np.radians(trace["psi_deg"])
    if t.size < 3:
        return
    vxg, vyg = np.gradient(x, t), np.gradient(y, t)
    axg, ayg = np.gradient(vxg, t), np.gradient(vyg, t)
    c, s = np.cos(psi), np.sin(psi)
    trace["ay_mps2"] = -axg * s + ayg * c
    trace["yaw_rate_degps"] = np.degrees(np.gradient(np.unwrap(psi), t))


def _excursions(t: Array, y: Array, road: RoadParams) -> tuple[list[float], list[float],
                                                               list[float]]:
    """Lane changes read off a path: each time the SV leaves one lane centre band
    (|y - centre| < SETTLE_TOL) and next enters another's. Returns starts, target
    centres and window ends (the run's end)."""
    centres = np.array([road.lane_center(k) for k in range(road.n_lanes)])
    dist = np.abs(y[:, None] - centres[None, :])
    home = np.where(dist.min(axis=1) < SETTLE_TOL, dist.argmin(axis=1), -1)
    starts: list[float] = []
    targets: list[float] = []
    last_home, last_t = -1, 0.0
    for i in np.flatnonzero(home >= 0):
        k = int(home[i])
        if last_home >= 0 and k != last_home:
            starts.append(last_t)
            targets.append(float(centres[k]))
        last_home, last_t = k, float(t[i])
    return starts, targets, [float(t[-1])] * len(starts)


def run_scenario(
    scenario: Scenario,
    out_dir: Path | None,
    *,
    write_trace: bool = True,
    write_figures: bool = True,
    progress: bool = False,
    gui: bool = False,
) -> dict[str, Any]:
    """Run one scenario (one libsumo simulation in this process); write its outputs
    into `out_dir` (None: write nothing); return the metrics row merged with the
    wall-time columns (names starting `wall_`)."""
    result = simulate(scenario, progress=progress, gui=gui)
    if out_dir is not None:
        from cosim.run_output import write_outputs

        write_outputs(result, Path(out_dir), write_trace=write_trace,
                      write_figures=write_figures)
    return {**result.metrics, **{k: v for k, v in result.timing.items() if k != "scenario"}}


def simulate(scenario: Scenario, *, progress: bool = False, gui: bool = False,
             decision: DecisionConfig | None = None) -> RunResult:
    """Run one scenario and return everything it produced (nothing written)."""
    sim = CoSimulation(scenario, gui=gui, decision=decision)
    if not progress:
        return sim.run()
    from tqdm import tqdm

    with tqdm(total=sim.n_steps, desc=scenario.name, unit="step", file=sys.stderr,
              leave=False) as bar:
        return sim.run(bar.update)
