"""What one run records, row by row: the trace, collision onsets and the SV's fault,
SUMO's collisions of the SV, and the TVs near the SV (cosim.run.outputs writes them;
cosim.run.metrics_row reduces them to the metrics row).

Per step (`Recorder.record`): the SV's state, the policy's status (target lane,
changing, leader gap, car-following acceleration), gap / TTC along the lane, our
exact overlap check of the SV against every TV near it (only where the bounding
circles meet), SUMO's collisions of the last step; the ego writes its own columns
(reference, errors, inputs) into the same row.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cosim.driving.base import PolicyStatus
from cosim.params import RoadParams
from cosim.road.road import Road
from cosim.run.proximity import gap_ttc_min
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.world import Scene, SVState

Array = NDArray[np.float64]

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


class Tracks:
    """TV positions near the SV, appended per step as arrays (for Fig. 16), with SUMO's
    speed of each (the metrics' follower braking: positions along the road frame jump
    where it departs from SUMO's lanes, at curves and junctions; SUMO's speed does not)."""

    def __init__(self) -> None:
        self.chunks: list[tuple[float, tuple[str, ...], Array, Array]] = []
        self.lengths: list[Array] = []  # m, the TVs' body lengths, one array per chunk
        self.speeds: list[Array] = []  # m/s, SUMO's speed along the lane, one per chunk

    def add(self, t: float, snap: TrafficSnapshot) -> None:
        if len(snap):
            self.chunks.append((t, snap.ids, snap.x, snap.y))  # snapshots are never modified
            self.lengths.append(snap.length)
            self.speeds.append(snap.speed)

    def by_vehicle(self) -> dict[str, tuple[Array, Array, Array, Array]]:
        """id -> (t, x, y, speed) arrays in time order."""
        if not self.chunks:
            return {}
        ids = np.array([vid for _, chunk_ids, _, _ in self.chunks for vid in chunk_ids])
        t = np.concatenate([np.full(len(c[1]), c[0]) for c in self.chunks])
        x = np.concatenate([c[2] for c in self.chunks])
        y = np.concatenate([c[3] for c in self.chunks])
        v = np.concatenate(self.speeds)
        names, inverse = np.unique(ids, return_inverse=True)
        order = np.argsort(inverse, kind="stable")  # by vehicle, in time order within
        bounds = np.searchsorted(inverse[order], np.arange(names.size + 1))
        return {
            str(name): (t[order[a:b]], x[order[a:b]], y[order[a:b]], v[order[a:b]])
            for name, a, b in zip(names, bounds[:-1], bounds[1:], strict=True)
        }

    def result(self) -> dict[str, tuple[Array, Array, Array]]:
        """id -> (t, x, y) arrays in time order."""
        return {vid: (t, x, y) for vid, (t, x, y, _) in self.by_vehicle().items()}


class Recorder:
    """Trace rows, collision onsets and the SV's fault, SUMO's collisions, the TVs near."""

    def __init__(self, n_steps: int, sv_length: float, sv_width: float, road: RoadParams,
                 route_road: Road | None = None, *, keep_tracks: bool = True) -> None:
        self.data = np.full((n_steps + 1, len(TRACE_COLUMNS)), np.nan)
        self.tracks = Tracks()
        self.keep_tracks = keep_tracks  # the TVs near it kept (for the figures)
        self.road = road
        self.route_road = route_road  # the (s, d) frame and tracks (None: s, d NaN)
        self.edges: list[str] = []  # road ids in the order met (the `edge` column's index)
        self._edge_index: dict[str, int] = {}
        self.sv_length, self.sv_width = sv_length, sv_width
        # m, the SV's reach for the exact check's candidates (its body diagonal): in road
        # coordinates distances are stretched by up to 1 / q (<= 1 / 0.85, the frame's limit)
        curved = route_road is not None and route_road.curved
        self.reach = math.hypot(sv_length, sv_width) * (1.25 if curved else 1.0)
        self.collisions = 0  # collision onsets by our exact check
        self.hits: frozenset[str] = frozenset()  # TVs overlapping the SV at the last row
        self.sv_fault = 0  # collision onsets the SV caused (metrics_row.METRIC_DOCS)
        self.manoeuvre_hits = 0  # collision onsets during a lane change of the SV
        self.sumo_pairs: set[tuple[str, ...]] = set()
        self.sumo_new = 0  # SUMO collision events involving the SV (onsets)
        self.sumo_step_collisions = 0  # SUMO collisions involving the SV in the last step
        self.first_collision: tuple[float, str] | None = None  # (t s, TV ids) of the first onset

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
        if self.keep_tracks:
            self.tracks.add(scene.t, tvs)
        return row

    def sumo_collisions(self, pairs: set[tuple[str, ...]]) -> None:
        """SUMO's collisions of the last step that involve the SV (cross-check)."""
        self.sumo_new += len(pairs - self.sumo_pairs)
        self.sumo_pairs = pairs
        self.sumo_step_collisions = len(pairs)

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
        lane = sv.sumo_lane
        row[C["track"]] = rr.track_ids.get(f"{edge}_{lane}", -1) if edge and lane >= 0 else -1

    def trace(self, last_row: int) -> dict[str, Array]:
        """The trace columns as arrays (copies), up to row `last_row` (the run's last)."""
        rows = self.data[:last_row + 1]
        return {name: rows[:, i].copy() for name, i in COLUMN.items()}
