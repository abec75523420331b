"""The run's metrics row (METRIC_DOCS): what the recorder recorded (the trace, the
collision counts, the TVs near the SV), why the run stopped (cosim.run.stop) and what
the policy did (cosim.driving.base.Manoeuvres), reduced with cosim.run.metrics.

For our drivers and SUMO's alike: lane changes and their durations, collisions by both
checks, gap and TTC, the new follower's braking, the paper's Table 2 IAE columns (an SV
that tracks a reference), riding comfort, the outcome, the merge out of a lane that ends.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cosim.driving.base import Manoeuvres
from cosim.params import RoadParams
from cosim.road.road import Road
from cosim.run import metrics as mx
from cosim.run.metrics import SETTLE_TOL
from cosim.run.recorder import Recorder, Tracks
from cosim.run.stop import StopRules
from cosim.scenario import Scenario

Array = NDArray[np.float64]

IAE_WINDOW = 10.0  # s, IAE from the start of the first lane change (cosim track's default)

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
    "speed as SUMO reports it, step to step), from the start of the change until 3 s after "
    "it settles, over all lane changes (m/s^2; NaN: no lane change with a follower)",
    "max_abs_lat_accel_mps2": "largest |body lateral acceleration| (m/s^2)",
    "max_abs_long_accel_mps2": "largest |body longitudinal acceleration| (m/s^2)",
    "max_jerk_mps3": "largest |d(ax, ay)/dt| between steps (m/s^3)",
    **mx.ENTRY_DOCS,  # the entry as the new follower sees it
    "iae_vx_mps_s": "IAE of ex = Vx - Vx* over the 10 s from the start of the first lane "
    "change (the whole run without one) (Table 2 column Vx) ((m/s) s)",
    "iae_ye_m_s": "IAE of ye, same window (Table 2 column ye) (m s)",
    "iae_phie_deg_s": "IAE of phi_e, same window (Table 2 column phi_e) (deg s)",
    "iae_deltaf_deg_s": "integral of |delta_f|, same window (Table 2 column delta_f) (deg s)",
    "iae_fx_kn_s": "integral of the sum of the four wheels' |Fx|, same window (Table 2 "
    "column Fx) (kN s)",
    "final_lane": "SV's lane at the end (SUMO index, from y)",
    "final_offset_m": "SV's y minus its lane centre at the end (m)",
    "lane_keeping_max_offset_m": "largest distance of the SV's centre from SUMO's centre line "
    "of the lane it is in (its track's SUMO lane polylines joined, kinks and all), over the "
    "steps where it keeps its lane (no planned lane change under way) (m; NaN: none on a "
    "lane of the route)",
    "mean_speed_mps": "SV's mean speed (m/s)",
    "start_speed_mps": "SV's speed at t = 0 (m/s): sv.speed_kmh, or lower where its leader at "
    "t = 0 is random traffic it could not brake for from that speed (SUMO's departSpeed rule: "
    "docs/outputs.md)",
    "curve_speed_mps": "the fastest our SV drives this route: sqrt(a / kappa) at its "
    "tightest curve, a = sv.curve_lat_accel_mps2 (at most half of mu g); its start, desired "
    "and band speeds are capped there (m/s; inf: a straight route, or SUMO drives the SV)",
    "sumo_events": "SUMO teleports / lost vehicles during the run",
    "vehicles_asked": "random-traffic vehicles placed at t = 0 ([traffic] density over its "
    "length_m, every through lane, less the SV's zones)",
    "vehicles_inserted": "of them, those SUMO inserted at t = 0 (SUMO leaves out a vehicle "
    "with no room at its minimum gap: fewer than asked means the density was not reached; "
    "docs/outputs.md)",
    "rms_long_accel_mps2": "RMS of the SV's longitudinal acceleration ax over the run (m/s^2)",
    "rms_long_jerk_mps3": "RMS of its jerk d(ax)/dt between steps (m/s^3)",
    "max_long_jerk_mps3": "largest |d(ax)/dt| between steps (m/s^3)",
    "long_accel_jump_share": "share of steps whose ax changes by more than 5 m/s^2 (-; a "
    "measure of chatter)",
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
    **mx.MERGE_DOCS,  # a start lane that ends: the merge out of it
    "lane_end_reached": "1 if the run stopped because our SV's front reached the end of "
    "the lane it was in (an acceleration lane, a dropped lane: SUMO would drop a vehicle "
    "moved past it; duration_s and steps are then up to it), else 0 (SUMO's own driver "
    "stops there by itself)",
}


class MetricsRow:
    """The metrics row of one run on `road` (the scenario's RoadParams) of an SV
    `sv_length` m long, with the TVs near it as the recorder kept them (`tracks`)."""

    def __init__(self, road: RoadParams, sv_length: float, tracks: Tracks,
                 route_road: Road | None = None) -> None:
        self.road = road
        self.sv_length = sv_length  # m
        self.tracks = tracks
        self.route_road = route_road  # the route's lanes (None: no SUMO lane shapes)

    def row(self, sc: Scenario, trace: dict[str, Array], done: Manoeuvres,
            recorder: Recorder, stop: StopRules, *, plant: str, tracks_reference: bool,
            events: int, vehicles: tuple[int, int], curve_speed: float) -> dict[str, Any]:
        """The metrics row (METRIC_DOCS, in its order) of a run's trace and what the
        policy did; `plant` its name ("none": SUMO drives), `tracks_reference` whether
        the SV tracked a reference (the IAE columns), `events` SUMO's teleports and
        lost vehicles, `vehicles` the random traffic's (asked, inserted) at t = 0,
        `curve_speed` the SV's (m/s, cosim.driving.curve_speed)."""
        t = trace["t_s"]
        durations = mx.lane_change_durations(t, trace["d_m"], done.starts, done.targets,
                                             done.ends, SETTLE_TOL)
        m: dict[str, Any] = {
            "scenario": sc.name,
            "seed": sc.seed,
            "controller": sc.sv.controller,
            "plant": plant,
            "duration_s": float(t[-1]),
            "steps": stop.last_row,
        }
        m.update(self._lane_changes(done, durations))
        m.update(self._collisions(recorder, stop))
        m.update(
            min_gap_m=float(np.min(trace["gap_min_m"])),
            min_ttc_s=float(np.min(trace["ttc_min_s"])),
            follower_max_decel_mps2=self.follower_decel(
                trace, done.starts, done.targets, done.ends, durations),
            max_abs_lat_accel_mps2=mx.max_abs(trace["ay_mps2"]),
            max_abs_long_accel_mps2=mx.max_abs(trace["ax_mps2"]),
            max_jerk_mps3=mx.max_abs(mx.jerk(t, trace["ax_mps2"], trace["ay_mps2"])),
        )
        m.update(self.entry(trace, done))
        m.update(self._iae(trace, done, tracks_reference))
        y_end = float(trace["d_m"][-1])
        final_lane = self.road.lane_of(y_end)
        m.update(
            final_lane=final_lane,
            final_offset_m=y_end - self.road.lane_center(final_lane),
            lane_keeping_max_offset_m=self.lane_keeping_offset(trace),
            mean_speed_mps=float(np.mean(trace["vx_mps"])),
            start_speed_mps=float(trace["vx_mps"][0]),
            curve_speed_mps=curve_speed,
            sumo_events=events,
            vehicles_asked=vehicles[0],
            vehicles_inserted=vehicles[1],
        )
        m.update(self.comfort(sc, trace, done, durations))
        end = mx.LaneChangeEnd(
            requests=done.requests, completed=bool(m["lane_change_completed"]),
            durations=durations, ends=done.ends, t_end=float(t[-1]), y_end=y_end,
            stopped=stop.by_collision)
        centres = np.array([self.road.lane_center(k) for k in range(self.road.n_lanes)])
        m.update(mx.outcome_columns(recorder.collisions, recorder.sumo_new, end, centres,
                                    SETTLE_TOL))
        m.update(self.merge(trace))
        m["lane_end_reached"] = int(stop.at_lane_end)
        return m

    @staticmethod
    def _lane_changes(done: Manoeuvres, durations: Array) -> dict[str, Any]:
        """The plans' and lane changes' columns (lane_change_requests to tau_first_s)."""
        settled = durations[np.isfinite(durations)]
        ok_plans = [p for p in done.plans if p["ok"] == 1]
        requests = done.requests
        return {
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
        }

    @staticmethod
    def _collisions(recorder: Recorder, stop: StopRules) -> dict[str, Any]:
        """The collision columns (collisions to stopped_by_collision)."""
        first = recorder.first_collision
        return {
            "collisions": recorder.collisions,
            "collision": int(recorder.collisions > 0),
            "collisions_sv": recorder.sv_fault,
            "collisions_manoeuvre": recorder.manoeuvre_hits,
            "sumo_collisions": recorder.sumo_new,
            "collision_t_s": math.nan if first is None else first[0],
            "collision_with": "" if first is None else first[1],
            "stopped_by_collision": int(stop.by_collision),
        }

    @staticmethod
    def _iae(trace: dict[str, Array], done: Manoeuvres, tracks_reference: bool
             ) -> dict[str, float]:
        """The IAE columns (Table 2) over the first lane change, IAE_WINDOW long as
        `cosim track` runs (Table 2: "the single lane change"); the whole run when there
        is none; NaN for an SV that tracks no reference."""
        if not tracks_reference:
            return dict.fromkeys(mx.IAE_COLUMNS, math.nan)
        t = trace["t_s"]
        t0 = done.first_start if done.first_start is not None else 0.0
        t1 = t0 + IAE_WINDOW if done.first_start is not None else float(t[-1])
        return mx.iae_row(t, trace, t0, t1)

    def lane_keeping_offset(self, trace: dict[str, Array]) -> float:
        """m, `lane_keeping_max_offset_m` (METRIC_DOCS; metrics.lane_keeping_offset): from
        the centre line of the SV's track, its SUMO lanes' polylines joined (SUMO's lane
        of a vehicle crossing a junction may lag its position by a step)."""
        if self.route_road is None:
            return math.nan
        shapes = {str(t.id): [pt for p in t.pieces for pt in p.shape]
                  for t in self.route_road.tracks}
        ids = [str(k) for k in trace["track"].astype(int).tolist()]
        return mx.lane_keeping_offset(trace["x_m"], trace["y_m"], ids,
                                      trace["changing"] == 0, shapes)

    def _new_follower(self, trace: dict[str, Array], start: float, y_target: float,
                      end: float) -> tuple[float, str | None, float]:
        """When the SV's centre entered the target lane of a change (NaN: never), the id
        of its new follower then (the nearest TV behind it in that lane; None: none, or
        nobody near) and its length (m)."""
        t = trace["t_s"]
        lane, enter, k = self._entered(t, trace["lane"], start, y_target, end)
        if k is None:
            return enter, None, math.nan
        _, ids, x, _ = self.tracks.chunks[k]
        sv_x = float(np.interp(enter, t, trace["s_m"]))
        behind = np.where(self._in_lane(k, lane) & (x < sv_x), x, -np.inf)
        if not np.isfinite(behind.max()):
            return enter, None, math.nan
        i = int(np.argmax(behind))
        return enter, str(ids[i]), float(self.tracks.lengths[k][i])

    def follower_decel(self, trace: dict[str, Array], starts: list[float],
                       targets: list[float], ends: list[float], durations: Array) -> float:
        """m/s^2, `follower_max_decel_mps2` (METRIC_DOCS; metrics.follower_max_decel)
        over the lane changes starting at `starts` toward the lane centres `targets`."""
        tracks: dict[str, tuple[Array, Array, Array, Array]] | None = None
        worst = math.nan
        for s, y_target, e, d in zip(starts, targets, ends, durations, strict=True):
            _, follower, _ = self._new_follower(trace, s, y_target, e)
            if follower is None:
                continue  # never entered, nobody near then, or no follower
            tracks = tracks if tracks is not None else self.tracks.by_vehicle()
            tt, _, _, v = tracks[follower]
            decel = mx.follower_max_decel(tt, v, s, s + d)
            if math.isfinite(decel):
                worst = decel if math.isnan(worst) else max(worst, decel)
        return worst

    def entry(self, trace: dict[str, Array], done: Manoeuvres) -> dict[str, float]:
        """The entry columns (metrics.ENTRY_DOCS) over the lane changes of `done`."""
        t = trace["t_s"]
        m = dict.fromkeys(mx.ENTRY_COLUMNS, math.nan)
        tracks: dict[str, tuple[Array, Array, Array, Array]] | None = None
        for s, y_target, e in zip(done.starts, done.targets, done.ends, strict=True):
            enter, follower, length = self._new_follower(trace, s, y_target, e)
            if math.isnan(enter):
                continue
            ttc = mx.window_min(t, trace["ttc_min_s"], enter, mx.ENTRY_WINDOW)
            m["entry_min_ttc_s"] = float(np.nanmin([m["entry_min_ttc_s"], ttc]))
            gap, time_gap, need = math.inf, math.inf, math.nan
            if follower is not None:
                tracks = tracks if tracks is not None else self.tracks.by_vehicle()
                tt, xx, _, v = tracks[follower]
                k = int(np.clip(np.searchsorted(tt, enter - 1e-9), 0, len(tt) - 1))
                sv_x = float(np.interp(enter, t, trace["s_m"]))
                sv_v = float(np.interp(enter, t, trace["vx_mps"]))
                gap = sv_x - float(xx[k]) - 0.5 * (self.sv_length + length)
                speed = float(v[k])
                time_gap = gap / speed if speed > 0.0 else math.inf
                need = (mx.follower_needed_decel(gap, speed, sv_v) if math.isfinite(speed)
                        else math.nan)
            m["entry_follower_gap_m"] = float(np.nanmin([m["entry_follower_gap_m"], gap]))
            m["entry_follower_time_gap_s"] = float(np.nanmin(
                [m["entry_follower_time_gap_s"], time_gap]))
            if not math.isnan(need):
                m["entry_follower_needed_decel_mps2"] = float(np.nanmax(
                    [m["entry_follower_needed_decel_mps2"], need]))
        return m

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
        # next change begins, an aborted one too): watched to the run's end, the merge's
        # follower would be charged with braking in later manoeuvres
        t_end = mx.merge_end(t, trace["d_m"], lane, cross, centre)
        durations = mx.lane_change_durations(t, trace["d_m"], [start], [centre], [t_end],
                                             SETTLE_TOL)
        m["merge_follower_max_decel_mps2"] = self.follower_decel(
            trace, [start], [centre], [t_end], durations)
        return m
