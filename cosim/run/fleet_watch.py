"""The fleet's vehicles as SUMO sees them, whoever drives them (cosim.run.fleet).

`[fleet] driver` says who drives the vehicles the fleet draws automated: `cosim` (the
scenario's driver, cosim.run.fleet's AVs) or a baseline at the same share: `sumo` (they
stay SUMO-driven, only marked), `acc` / `cacc` (SUMO drives them with its ACC / CACC
car-following model: their vType switched to a copy with that model,
cosim.traffic.takeover). The same draws pick the same vehicles whatever the driver, and
each is watched from the same point (its takeover) to the same end (handed back, or
left to SUMO, HANDBACK_DISTANCE before the route's end), so the drivers compare.

Per step `FleetWatch.observe` reads each watched vehicle's row of the road's snapshot
(lane, s, speed, SUMO's acceleration) and the acceleration of its follower (the nearest
vehicle behind it on its lane; none where that follower is one cosim moves, the SV, a
scripted TV or an AV of ours: SUMO's acceleration of a vehicle moved by moveToXY is not
its own), in one pass over arrays; `collided` counts SUMO's
collision onsets with it (caused: it was SUMO's collider). At the end per vehicle: its
lane changes (changes of its lane in SUMO), its peak jerk (cosim.run.metrics.
longitudinal_comfort of SUMO's acceleration, as the SUMO-driven SV's), and its new
followers' braking (`Watched.new_follower_decel`): at each of its lane changes, the
follower then, if it keeps its lane, its largest deceleration within NEW_FOLLOWER_WINDOW
while it stays that follower and keeps its lane (as the SV's new follower: the vehicle
behind it in the target lane as it enters, docs/outputs.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cosim.run.metrics import longitudinal_comfort
from cosim.scenario.model import FLEET_DRIVERS
from cosim.traffic.sumo import TrafficSnapshot

COSIM = FLEET_DRIVERS[0]  # [fleet] driver: the scenario's driver (the fleet's AVs)
# s after a lane change (its centre's crossing into the new lane) its new follower is
# watched: SUMO's lane change lasts 3 s, the follower reacts within about 2 s more
NEW_FOLLOWER_WINDOW = 5.0


@dataclass
class Watched:
    """One fleet vehicle's rows of SUMO's snapshot, from its takeover."""

    id: str
    vtype: str
    inserted: float  # s, when SUMO inserted it
    k0: int  # its first row
    baseline: bool  # driven by SUMO (a baseline), not by cosim
    t: list[float] = field(default_factory=list)  # s
    s: list[float] = field(default_factory=list)  # m, along the route
    speed: list[float] = field(default_factory=list)  # m/s
    accel: list[float] = field(default_factory=list)  # m/s^2, SUMO's
    lane: list[int] = field(default_factory=list)  # track (-1: on none)
    follower_decel: list[float] = field(default_factory=list)  # m/s^2 (NaN: no follower)
    # its follower's row of the road's snapshot: id ("": none), and whether it moved
    # sideways (a lane change of its own under way in SUMO)
    follower: list[str] = field(default_factory=list)
    follower_changing: list[bool] = field(default_factory=list)
    collisions: int = 0  # SUMO's collision onsets involving it
    caused: int = 0  # of them, those it was SUMO's collider in
    lateral: float = 0.0  # m/s, at its last row
    k_end: int = -1
    end: str = "running"

    def lane_changes(self) -> np.ndarray:
        """Row indices where its lane changed (both rows on a track)."""
        lane = np.asarray(self.lane)
        if lane.size < 2:
            return np.zeros(0, dtype=int)
        return np.flatnonzero((lane[1:] != lane[:-1]) & (lane[1:] >= 0) & (lane[:-1] >= 0)) + 1

    def new_follower_decel(self, dt: float) -> float:
        """m/s^2, the largest deceleration of its new followers: at each of its lane
        changes (the row its lane in SUMO changed), the nearest vehicle behind it on its
        new lane then, if SUMO drives it and it was keeping that lane (no lane change of
        its own under way: a vehicle arriving beside the change was not behind it in that
        lane before); its deceleration over NEW_FOLLOWER_WINDOW from that row while it
        stays that follower and keeps its lane (braking for a change of its own, or for
        another vehicle cutting in between, is not the change's). NaN: no change, or no
        such follower."""
        decel = np.asarray(self.follower_decel)
        follower = np.asarray(self.follower, dtype=object)
        keeping = ~np.asarray(self.follower_changing, dtype=bool)
        width = int(round(NEW_FOLLOWER_WINDOW / dt))
        worst = math.nan
        for k in self.lane_changes():
            f = follower[k]
            if not f or not keeping[k] or not math.isfinite(decel[k]):
                continue
            span = slice(k, k + width + 1)
            ok = (follower[span] == f) & keeping[span]
            window = decel[span][ok]
            window = window[np.isfinite(window)]
            if window.size:
                worst = float(np.nanmax([worst, window.max()]))
        return worst


class FleetWatch:
    """The fleet's vehicles in SUMO's snapshot (module docstring)."""

    def __init__(self, dt: float, moved: tuple[str, ...] = ()) -> None:
        self.dt = dt  # s, SUMO's step
        self.moved = moved  # the vehicles cosim moves besides the fleet's (SV, scripted TVs)
        self.active: dict[str, Watched] = {}
        self.done: list[Watched] = []
        self._colliding: set[tuple[str, str]] = set()  # SUMO's pairs in the last step

    def add(self, vid: str, vtype: str, k: int, inserted: float, *, baseline: bool) -> None:
        self.active[vid] = Watched(vid, vtype, inserted, k, baseline)

    def observe(self, t: float, everyone: TrafficSnapshot) -> None:
        """Row t of every watched vehicle; one that left the road is finished."""
        if not self.active:
            return
        index = {vid: i for i, vid in enumerate(everyone.ids)}
        watched = list(self.active.values())
        rows = np.array([index.get(w.id, -1) for w in watched])
        for w, i in zip(watched, rows.tolist(), strict=True):
            if i < 0:  # gone: arrived, or taken off by SUMO
                self.finish(w.id, w.k0 + len(w.t) - 1, "left")
        keep = rows >= 0
        watched = [w for w, ok in zip(watched, keep.tolist(), strict=True) if ok]
        rows = rows[keep]
        if not watched:
            return
        x, lane = everyone.x, everyone.lane
        # the follower: the nearest vehicle behind on the same lane
        behind = (lane[None, :] == lane[rows][:, None]) & (x[None, :] < x[rows][:, None])
        nearest = np.argmax(np.where(behind, x[None, :], -np.inf), axis=1)
        has = behind.any(axis=1)
        follower = np.where(has, -everyone.accel[nearest], np.nan)
        ids = [everyone.ids[i] if h else "" for i, h in zip(nearest.tolist(), has.tolist(),
                                                              strict=True)]
        changing = everyone.changing[nearest] & has
        moved = [index[v] for v in (*self.moved, *(w.id for w in watched if not w.baseline))
                 if v in index]
        if moved:  # SUMO's acceleration of a vehicle moved by moveToXY is not its own
            follower[np.isin(nearest, moved)] = np.nan
        columns = zip(watched, x[rows].tolist(), everyone.speed[rows].tolist(),
                      everyone.accel[rows].tolist(), lane[rows].tolist(), follower.tolist(),
                      everyone.lateral_speed[rows].tolist(), ids, changing.tolist(),
                      strict=True)
        for w, s, v, a, ln, fd, lat, fid, fch in columns:
            w.t.append(t)
            w.s.append(s)
            w.speed.append(v)
            w.accel.append(a)
            w.lane.append(int(ln))
            w.follower_decel.append(fd)
            w.follower.append(fid)
            w.follower_changing.append(fch)
            w.lateral = lat

    def ending(self, route_end: float, distance: float, last: float) -> list[str]:
        """The baselines to leave to SUMO now, as the fleet hands its AVs back: within
        `distance` m of the route's end and not changing lanes, or within `last` m."""
        out = []
        for w in self.active.values():
            if w.baseline and w.s:
                left = route_end - w.s[-1]
                if left <= last or (left <= distance and w.lateral == 0.0):
                    out.append(w.id)
        return out

    def collided(self, events: list[tuple[str, str]]) -> None:
        """SUMO's (collider, victim) pairs of its last step: the onsets (a pair not
        colliding the step before) counted for the watched vehicles in them."""
        pairs = set(events)
        for collider, victim in pairs - self._colliding:
            for vid in (collider, victim):
                w = self.active.get(vid)
                if w is not None:
                    w.collisions += 1
                    w.caused += vid == collider
        self._colliding = pairs

    def finish(self, vid: str, k: int, end: str) -> None:
        w = self.active.pop(vid, None)
        if w is not None:
            w.k_end, w.end = k, end
            self.done.append(w)

    def close(self, last_row: int) -> dict[str, Watched]:
        """Every vehicle watched, by id (those still driving end `running`)."""
        for vid in list(self.active):
            self.finish(vid, last_row, "running")
        return {w.id: w for w in self.done}

    def comfort(self, w: Watched) -> dict[str, float]:
        """fleet.csv's comfort columns of a vehicle from SUMO's rows."""
        return {"max_long_jerk_mps3": longitudinal_comfort(w.t, w.accel)["max_long_jerk_mps3"],
                "follower_max_decel_mps2": w.new_follower_decel(self.dt)}

    def baseline_row(self, w: Watched, driver: str) -> dict[str, Any]:
        """fleet.csv's row of a baseline vehicle (cosim.run.fleet.FLEET_COLUMNS)."""
        return {
            "vehicle_id": w.id, "vtype": w.vtype, "driver": driver,
            "inserted_t_s": w.inserted, "taken_over_t_s": w.t[0] if w.t else math.nan,
            "end_t_s": w.t[-1] if w.t else math.nan,
            "end": "handed_back" if w.end == "handed_back" else w.end,
            "s_start_m": w.s[0] if w.s else math.nan, "s_end_m": w.s[-1] if w.s else math.nan,
            "mean_speed_mps": float(np.mean(w.speed)) if w.speed else math.nan,
            "lane_changes": len(w.lane_changes()),
            "collisions": w.collisions, "caused_collisions": w.caused,
            "sumo_collisions": w.collisions, "gap_min_m": math.nan, "ttc_min_s": math.nan,
            **self.comfort(w),
        }
