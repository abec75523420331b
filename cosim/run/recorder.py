"""What one run records: the trace rows, collision onsets and fault, SUMO's collisions
of the SV, the plans log, and at the end the metrics row (cosim.run.outputs writes them).

Per step (`Recorder.record`): the SV's state, the policy's status (target lane,
changing, leader gap, car-following acceleration), gap / TTC along the lane, our
exact overlap check of the SV against every TV near it (only where the bounding
circles meet), SUMO's collisions of the last step; the ego writes its own columns
(reference, errors, inputs) into the same row. `Recorder.result` turns the trace
and what the policy and the ego report into the metrics row (cosim.run.metrics).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cosim.driving.base import Manoeuvres, PolicyStatus
from cosim.driving.manoeuvre import LaneChange
from cosim.driving.plans import PLAN_COLUMNS  # noqa: F401  (the run's columns, re-exported)
from cosim.params import RoadParams
from cosim.road.road import Road
from cosim.run import metrics as mx
from cosim.run.metrics import SETTLE_TOL
from cosim.run.proximity import gap_ttc_min
from cosim.scenario import Scenario
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.world import Scene, SVState

Array = NDArray[np.float64]

IAE_WINDOW = 10.0  # s, IAE from the start of the first lane change (cosim track's default)

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
    "sumo_lane": "SV's lane index as SUMO has it: SUMO's index on the road in `edge` "
    "(where that index shifts, past an acceleration lane, it differs from `lane` and "
    "`track`; -1 off the network)",
    "target_lane": "lane the SV is heading for (= lane when keeping its lane)",
    "changing": "1 while a planned lane change is under way, else 0",
    "leader_gap_m": "bumper-to-bumper gap to the leader in the SV's lane (m; inf: none)",
    "idm_accel_mps2": "car-following (IDM) acceleration when keeping the lane (m/s^2)",
    "gap_min_m": "smallest along-lane gap to a TV sharing the SV's strip (m; inf: none)",
    "ttc_min_s": "smallest along-lane time-to-collision to such a TV (s; inf: none)",
    "collisions": "number of TVs whose rectangle overlaps the SV's (our exact check)",
    "sumo_collisions": "number of collisions involving the SV SUMO reported this step",
    "n_tvs": "number of TVs within 150 m (x) of the SV",
    # the road frame (cosim.road; on the straight one-edge road s = x - x0, d = y - y0)
    "s_m": "SV centre's arc length s along the route's reference line (m)",
    "d_m": "SV centre's lateral offset d from the reference line, + to the left (m)",
    "edge": "SUMO road id of the SV (a route edge or a junction's internal edge; empty: off "
            "the network)",
    "track": "track of the SV: the physical lane SUMO has it in, followed across edges "
             "(cosim.road; -1: none)",
}
COLUMN = {name: i for i, name in enumerate(TRACE_COLUMNS)}

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
    "collision_t_s": "time of the first collision onset by our check (s; NaN: none)",
    "collision_with": "TV id(s) of that first collision, ';'-separated (empty: none)",
    "stopped_by_collision": "1 if the run stopped at that onset ([scenario] on_collision = "
    "\"stop\", the default: duration_s and steps are then up to it), else 0",
    "min_gap_m": "smallest along-lane gap to a TV sharing the SV's strip (m; inf: none)",
    "min_ttc_s": "smallest along-lane time-to-collision (s; inf: never closing on anyone)",
    "follower_max_decel_mps2": "largest deceleration of the SV's new follower in the target "
    "lane (the nearest TV behind the SV there when the SV's centre enters that lane; its "
    "speed from SUMO's positions step to step), from the start of the change until 3 s after "
    "it settles, over all lane changes (m/s^2; NaN: no lane change with a follower)",
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
    "start_speed_mps": "SV's speed at t = 0 (m/s): sv.speed_kmh, or lower where its leader at "
    "t = 0 is random traffic it could not brake for from that speed (SUMO's departSpeed rule: "
    "README, Output files)",
    "sumo_events": "SUMO teleports / lost vehicles during the run",
    "rms_long_accel_mps2": "RMS of the SV's longitudinal acceleration ax over the run (m/s^2)",
    "rms_long_jerk_mps3": "RMS of its jerk d(ax)/dt between steps (m/s^3)",
    "max_long_jerk_mps3": "largest |d(ax)/dt| between steps (m/s^3)",
    "long_accel_jump_share": "share of steps whose ax changes by more than 5 m/s^2 (-; the "
    "chatter measure of issue 22)",
    "merge_time_gap_s": "time gap to the new leader when the SV's centre enters the target "
    "lane: bumper-to-bumper gap / SV speed, smallest over the lane changes (s; inf: no leader "
    "within 150 m; NaN: no lane change entered)",
    "post_change_max_decel_mps2": "the SV's largest deceleration from its entry into the "
    "target lane until 3 s after the change settles (3 s after the entry if it did not), "
    "largest over the lane changes (m/s^2; NaN: no lane change entered)",
    "request_to_lane_s": "time from the first lane-change request (scripted: its at_s, both "
    "drivers; else our driver's first decision-rule planner call) until the SV's centre is "
    "in the requested lane (s; NaN: no request, or never got there)",
    **mx.OUTCOME_DOCS,  # which check saw a collision; lane changes the end cut short
    **mx.MERGE_DOCS,  # a start lane that ends (issue 24): the merge out of it
    "lane_end_reached": "1 if the run stopped because our SV's front reached the end of "
    "the lane it was in (an acceleration lane, a dropped lane: SUMO would drop a vehicle "
    "moved past it; duration_s and steps are then up to it), else 0 (SUMO's own driver "
    "stops there by itself)",
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


# ----------------------------------------------------------------------------- records


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


class Tracks:
    """TV positions near the SV, appended per step as arrays (for Fig. 16)."""

    def __init__(self) -> None:
        self.chunks: list[tuple[float, tuple[str, ...], Array, Array]] = []
        self.lengths: list[Array] = []  # m, the TVs' body lengths, one array per chunk

    def add(self, t: float, snap: TrafficSnapshot) -> None:
        if len(snap):
            self.chunks.append((t, snap.ids, snap.x, snap.y))  # snapshots are never modified
            self.lengths.append(snap.length)

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


class Recorder:
    """Trace rows, collision onsets and fault, SUMO's collisions, the metrics row."""

    def __init__(self, n_steps: int, sv_length: float, sv_width: float, road: RoadParams,
                 route_road: Road | None = None) -> None:
        self.data = np.full((n_steps + 1, len(TRACE_COLUMNS)), np.nan)
        self.tracks = Tracks()
        self.road = road
        self.route_road = route_road  # the (s, d) frame and tracks (None: s, d NaN)
        self.edges: list[str] = []  # road ids in the order met (the `edge` column's index)
        self._edge_index: dict[str, int] = {}
        self.sv_length, self.sv_width = sv_length, sv_width
        self.sv_diag = math.hypot(sv_length, sv_width)  # m, body diagonal
        # m, the SV's reach for the exact check's candidates: in road coordinates
        # distances are stretched by up to 1 / q (<= 1 / 0.85, the frame's limit)
        curved = route_road is not None and route_road.curved
        self.reach = self.sv_diag * (1.25 if curved else 1.0)
        self.collisions = 0  # collision onsets by our exact check
        self.hits: frozenset[str] = frozenset()  # TVs overlapping the SV at the last row
        self.sv_fault = 0  # collision onsets the SV caused (see METRIC_DOCS)
        self.manoeuvre_hits = 0  # collision onsets during a lane change of the SV
        self.sumo_pairs: set[tuple[str, ...]] = set()
        self.sumo_new = 0  # SUMO collision events involving the SV (onsets)
        self.sumo_step_collisions = 0  # SUMO collisions involving the SV in the last step
        self.first_collision: tuple[float, str] | None = None  # (t s, TV ids) of the first onset
        self.last_row = n_steps  # the run's last trace row (earlier: stopped by a collision)
        self.stopped = False  # the run stopped at its first collision onset
        self.at_lane_end = False  # the run stopped: our SV reached the end of its lane

    def record(self, k: int, scene: Scene, status: PolicyStatus) -> Array:
        """Row k: what every SV has (the ego adds its own columns); returns the row."""
        from cosim.planning.collision import Box, overlap_sat

        row = self.data[k]
        C = COLUMN
        sv, tvs = scene.sv, scene.tvs
        # x, y, h in road coordinates (s, d, heading to the road; the identity on the
        # straight road): lanes, gaps, TTC; the Cartesian pose: the trace, the overlap check
        x, y, h, vx, vy = sv.x, sv.y, sv.heading, sv.vx, sv.vy
        px, py, ph = sv.pose
        row[C["t_s"]] = scene.t
        row[C["x_m"]] = px
        row[C["y_m"]] = py
        row[C["psi_deg"]] = math.degrees(ph)
        row[C["vx_mps"]] = vx * sv.stretch
        row[C["vy_mps"]] = vy
        lane = self.road.lane_of(y)
        row[C["lane"]] = lane
        row[C["sumo_lane"]] = sv.sumo_lane
        row[C["target_lane"]] = status.target_lane if status.target_lane is not None else lane
        row[C["changing"]] = 1.0 if status.changing else 0.0
        row[C["leader_gap_m"]] = status.leader_gap
        row[C["idm_accel_mps2"]] = status.idm_accel
        self._record_road(row, sv)
        # gap / TTC along the lane, and our exact overlap check against every TV near
        c, s_ = abs(math.cos(h)), abs(math.sin(h))
        hx = 0.5 * (self.sv_length * c + self.sv_width * s_)
        hy = 0.5 * (self.sv_length * s_ + self.sv_width * c)
        sv_vxg = vx * math.cos(h) - vy * math.sin(h)
        reach = np.empty(len(tvs), dtype=bool)
        gap, ttc = gap_ttc_min(x, y, sv_vxg, hx, hy, self.reach, tvs.x, tvs.y, scene.tv_vx,
                               tvs.heading, tvs.length, tvs.width, reach)
        row[C["gap_min_m"]] = gap
        row[C["ttc_min_s"]] = ttc
        # exact test only where the bounding circles meet (most steps: nobody)
        near = np.flatnonzero(reach)
        hits: frozenset[str] = frozenset()
        if near.size:  # (the reach test's circles hold a margin for the frame's stretch)
            tx, ty, th = tvs.cartesian
            hit = overlap_sat(Box(px, py, ph, self.sv_length, self.sv_width),
                              Box(tx[near], ty[near], th[near], tvs.length[near], tvs.width[near]))
            hits = frozenset(tvs.ids[i] for i, c in zip(near, hit, strict=True) if c)
        for vid in hits - self.hits:  # onsets: was the SV at fault? (changing lanes, or hit ahead)
            if status.manoeuvring or float(tvs.x[tvs.index(vid)]) > x:
                self.sv_fault += 1
            self.manoeuvre_hits += int(status.manoeuvring)
        if hits - self.hits and self.first_collision is None:
            self.first_collision = (scene.t, ";".join(sorted(hits - self.hits)))
        self.collisions += len(hits - self.hits)
        self.hits = hits
        row[C["collisions"]] = len(hits)
        row[C["sumo_collisions"]] = self.sumo_step_collisions
        row[C["n_tvs"]] = len(tvs)
        self.tracks.add(scene.t, tvs)
        return row

    def stop_at_collision(self, k: int) -> bool:
        """True if row k holds the run's first collision onset: the run ends with this
        row (`[scenario] on_collision = "stop"`; a crash ends the ride, the SV never
        drives on through the TV)."""
        if self.first_collision is None or self.stopped:
            return False
        self.stopped = True
        self.last_row = k
        return True

    def stop_at_lane_end(self, k: int, sv: SVState, dt: float) -> bool:
        """True if row k leaves our SV (driven by moveToXY) in a lane that ends with its
        front within one step of that end: the run ends with this row, as SUMO would drop
        a vehicle moved past the end of its lane (`lane_end_reached`, issue 24). A policy
        that makes the mandatory lane change, or stops before the end, never meets it."""
        end = self.road.lane_end(self.road.lane_of(sv.y))
        if not math.isfinite(end) or self.stopped or self.at_lane_end:
            return False
        if sv.x + 0.5 * self.sv_length + max(sv.vx, 0.0) * dt < end:
            return False
        self.at_lane_end = True
        self.last_row = k
        return True

    def sumo_collisions(self, pairs: set[tuple[str, ...]]) -> None:
        """SUMO's collisions of the last step that involve the SV (cross-check)."""
        self.sumo_new += len(pairs - self.sumo_pairs)
        self.sumo_pairs = pairs
        self.sumo_step_collisions = len(pairs)

    def follower_decel(self, trace: dict[str, Array], starts: list[float],
                       targets: list[float], ends: list[float], durations: Array) -> float:
        """m/s^2, `follower_max_decel_mps2` (METRIC_DOCS; metrics.follower_max_decel)
        over the lane changes starting at `starts` toward the lane centres `targets`."""
        t = trace["t_s"]
        tracks: dict[str, tuple[Array, Array, Array]] | None = None
        worst = math.nan
        for s, y_target, e, d in zip(starts, targets, ends, durations, strict=True):
            lane, enter, k = self._entered(t, trace["lane"], s, y_target, e)
            if k is None:
                continue  # never entered, or nobody near then
            _, ids, x, _ = self.tracks.chunks[k]
            sv_x = float(np.interp(enter, t, trace["s_m"]))
            behind = np.where(self._in_lane(k, lane) & (x < sv_x), x, -np.inf)
            if not np.isfinite(behind.max()):
                continue  # no follower
            tracks = tracks if tracks is not None else self.tracks.result()
            tt, xx, _ = tracks[ids[int(np.argmax(behind))]]
            dt = np.diff(tt)
            step = float(np.min(dt)) if dt.size else math.nan
            # speed over each step (SUMO: x += v dt), only across consecutive samples
            v = np.where(np.abs(dt - step) < 1e-9, np.diff(xx) / np.where(dt > 0, dt, 1.0),
                         np.nan)
            decel = mx.follower_max_decel(tt[1:], v, s, s + d)
            if math.isfinite(decel):
                worst = decel if math.isnan(worst) else max(worst, decel)
        return worst

    def comfort(self, sc: Scenario, trace: dict[str, Array], done: Manoeuvres,
                durations: Array) -> dict[str, float]:
        """The comfort columns (metrics.COMFORT_COLUMNS, METRIC_DOCS): ax and its jerk over
        the run; per lane change entered, the time gap to the new leader at the entry and
        the SV's hardest braking after it; the first request's time to the target lane."""
        t, lane, ax = trace["t_s"], trace["lane"], trace["ax_mps2"]
        m: dict[str, float] = mx.longitudinal_comfort(t, ax)
        gaps, decels = [], []
        for s, y_target, e, d in zip(done.starts, done.targets, done.ends, durations,
                                     strict=True):
            target, enter, k = self._entered(t, lane, s, y_target, e)
            if not math.isfinite(enter):
                continue
            decels.append(mx.post_change_max_decel(t, ax, enter, s + d))
            if k is None:
                gaps.append(math.inf)  # nobody near then
                continue
            x = self.tracks.chunks[k][2]
            in_lane = self._in_lane(k, target)
            gaps.append(mx.time_gap(float(np.interp(enter, t, trace["s_m"])),
                                    float(np.interp(enter, t, trace["vx_mps"])),
                                    self.sv_length, x[in_lane], self.tracks.lengths[k][in_lane]))
        m["merge_time_gap_s"] = min(gaps) if gaps else math.nan
        m["post_change_max_decel_mps2"] = max(decels) if decels else math.nan
        # the first request: scripted (both drivers), else our driver's first planner call
        if sc.sv.lane_changes:
            request, wanted = sc.sv.lane_changes[0].at, sc.sv.lane_changes[0].target_lane
        else:
            first = next((p for p in done.plans if p["trigger"] == "decision"), None)
            request, wanted = ((math.nan, -1) if first is None
                               else (float(first["t_s"]), int(first["target_lane"])))
        m["request_to_lane_s"] = mx.request_to_lane(t, lane, request, wanted)
        return m

    def _entered(self, t: Array, lane: Array, start: float, y_target: float,
                 end: float) -> tuple[int, float, int | None]:
        """A lane change's target lane, when the SV's centre entered it (NaN: never) and
        the index of the TVs' sample (`tracks.chunks`) at that instant (None: never
        entered, or nobody near then)."""
        target = self.road.lane_of(y_target)
        enter = mx.lane_entry_time(t, lane, start, target, end)
        if not math.isfinite(enter):
            return target, enter, None
        chunk_t = np.array([c[0] for c in self.tracks.chunks])
        k = int(np.searchsorted(chunk_t, enter - 1e-9))
        if k >= chunk_t.size or abs(chunk_t[k] - enter) > 1e-9:
            return target, enter, None
        return target, enter, k

    def _in_lane(self, k: int, lane: int) -> Array:
        """Mask of sample k's TVs whose centre lies in `lane`'s strip (unclipped: a TV
        off the road is in no lane)."""
        y = self.tracks.chunks[k][3]
        return np.floor((y - self.road.y_right) / self.road.lane_width) == lane

    def _record_road(self, row: Array, sv: SVState) -> None:
        """The SV's (s, d), its road id (as an index into `edges`) and track."""
        C = COLUMN
        edge = sv.edge
        k = self._edge_index.get(edge)
        if k is None:
            k = self._edge_index[edge] = len(self.edges)
            self.edges.append(edge)
        row[C["edge"]] = k
        rr = self.route_road
        if rr is None:
            row[C["track"]] = -1
            return
        row[C["s_m"]] = sv.x  # the scene is in road coordinates (road_view)
        row[C["d_m"]] = sv.y
        lane = int(sv.sumo_lane)
        row[C["track"]] = rr.track_ids.get(f"{edge}_{lane}", -1) if edge and lane >= 0 else -1

    def trace(self) -> dict[str, Array]:
        """The trace columns as arrays (copies), up to the run's last row."""
        rows = self.data[:self.last_row + 1]
        return {name: rows[:, i].copy() for name, i in COLUMN.items()}

    def metrics(self, sc: Scenario, trace: dict[str, Array], done: Manoeuvres, *,
                plant: str, tracks_reference: bool, n_steps: int, events: int
                ) -> dict[str, Any]:
        """The metrics row (METRIC_DOCS) of a run's trace and what the policy did."""
        t = trace["t_s"]
        durations = mx.lane_change_durations(t, trace["d_m"], done.starts, done.targets,
                                             done.ends, SETTLE_TOL)
        settled = durations[np.isfinite(durations)]
        ok_plans = [p for p in done.plans if p["ok"] == 1]
        requests = done.requests
        y_end = float(trace["d_m"][-1])
        lane_end = self.road.lane_of(y_end)
        m: dict[str, Any] = {
            "scenario": sc.name,
            "seed": sc.seed,
            "controller": sc.sv.controller,
            "plant": plant,
            "duration_s": float(t[-1]),
            "steps": self.last_row if self.stopped or self.at_lane_end else n_steps,
            "lane_change_requests": requests,
            "plans": done.planner_calls,
            "plans_failed": sum(1 for p in done.plans if p["ok"] == 0),
            "replans": done.outcomes["replan"],
            "aborts": done.outcomes["abort"],
            "emergency_brakes": done.outcomes["brake"],
            "lane_changes": int(settled.size),
            "lane_change_completed": int(requests > 0 and len(done.starts) > 0
                                         and settled.size == len(done.starts)),
            "lane_change_duration_s": float(settled.mean()) if settled.size else math.nan,
            "lane_change_duration_max_s": float(settled.max()) if settled.size else math.nan,
            "lane_change_durations_s": ";".join(
                "nan" if not np.isfinite(d) else f"{d:.2f}" for d in durations),
            "tau_first_s": float(ok_plans[0]["tau_s"]) if ok_plans else math.nan,
            "collisions": self.collisions,
            "collision": int(self.collisions > 0),
            "collisions_sv": self.sv_fault,
            "collisions_manoeuvre": self.manoeuvre_hits,
            "sumo_collisions": self.sumo_new,
            "collision_t_s": math.nan if self.first_collision is None
            else self.first_collision[0],
            "collision_with": "" if self.first_collision is None else self.first_collision[1],
            "stopped_by_collision": int(self.stopped),
            "min_gap_m": float(np.min(trace["gap_min_m"])),
            "min_ttc_s": float(np.min(trace["ttc_min_s"])),
            "follower_max_decel_mps2": self.follower_decel(
                trace, done.starts, done.targets, done.ends, durations),
            "max_abs_lat_accel_mps2": mx.max_abs(trace["ay_mps2"]),
            "max_abs_long_accel_mps2": mx.max_abs(trace["ax_mps2"]),
            "max_jerk_mps3": mx.max_abs(mx.jerk(t, trace["ax_mps2"], trace["ay_mps2"])),
        }
        if not tracks_reference:
            m.update(dict.fromkeys(mx.IAE_COLUMNS, math.nan))
        else:
            # over the first lane change (Table 2: "the single lane change"), as long
            # as `cosim track` runs; the whole run when there is none
            t0 = done.first_start if done.first_start is not None else 0.0
            t1 = t0 + IAE_WINDOW if done.first_start is not None else float(t[-1])
            m.update(mx.iae_row(t, trace, t0, t1))
        m.update(
            final_lane=lane_end,
            final_offset_m=y_end - self.road.lane_center(lane_end),
            mean_speed_mps=float(np.mean(trace["vx_mps"])),
            start_speed_mps=float(trace["vx_mps"][0]),
            sumo_events=events,
        )
        m.update(self.comfort(sc, trace, done, durations))
        m.update(mx.outcome_columns(
            collisions=self.collisions, sumo_collisions=self.sumo_new, requests=requests,
            completed=bool(m["lane_change_completed"]), durations=durations, ends=done.ends,
            t_end=float(t[-1]), y_end=y_end,
            centres=np.array([self.road.lane_center(k) for k in range(self.road.n_lanes)]),
            tol=SETTLE_TOL, stopped=self.stopped))
        m.update(self.merge(trace))
        m["lane_end_reached"] = int(self.at_lane_end)
        return m

    def merge(self, trace: dict[str, Array]) -> dict[str, float]:
        """The merge columns (metrics.MERGE_COLUMNS, METRIC_DOCS) from the trace: the SV's
        start lane, where it ends (RoadParams.lane_ends), the first crossing out of it
        before that end; the target lane's follower as for a lane change."""
        t, lane = trace["t_s"], trace["lane"]
        m = dict.fromkeys(mx.MERGE_COLUMNS, math.nan)
        m["stopped_time_s"] = mx.stopped_time(t, trace["vx_mps"])
        start_lane = int(lane[0])
        end = self.road.lane_end(start_lane)
        if not math.isfinite(end):
            return m
        cross, left, target = mx.merge_crossing(t, trace["s_m"], lane, end)
        m["merge_success"] = 0.0 if math.isnan(cross) else 1.0
        if math.isnan(cross):
            return m
        m["merge_distance_to_end_m"] = left
        start = mx.merge_start(t, trace["d_m"], cross, self.road.lane_center(start_lane))
        centre = self.road.lane_center(target)
        # settling is looked for until the SV leaves the target lane's centre again (a
        # next change begins, an aborted one too): to the run's end, its follower was
        # watched through later manoeuvres (6.8 m/s^2 for another vehicle 22 s later;
        # 2.96 through an aborted change 10 s later)
        t_end = mx.merge_end(t, trace["d_m"], lane, cross, centre)
        durations = mx.lane_change_durations(t, trace["d_m"], [start], [centre], [t_end],
                                             SETTLE_TOL)
        m["merge_follower_max_decel_mps2"] = self.follower_decel(
            trace, [start], [centre], [t_end], durations)
        return m
