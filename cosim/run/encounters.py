"""Our own surrogate safety measures for every automated vehicle (the SV and the fleet's),
beside SUMO's SSM device (cosim.traffic.ssm): TTC and PET from the vehicles' rectangles,
per encounter, written into fleet_conflicts.csv.

Per step (`observe`, SUMO's state after its step, as SUMO's device sees it) every
automated vehicle is an ego (from its takeover to its hand-back, the SV throughout), and
every vehicle whose rectangle is within `[ssm] range_m` of its rectangle along the road
(SUMO's device looks as far, front to back) and beside or in its strip of road
(STRIP_MARGIN) a foe; for all of them at once
(arrays, one row per ego: cosim.run.metrics.gap_ttc, the trace's rule) the along-road gap
between the rectangles and the TTC (gap over closing speed, for a foe whose rectangle
shares some of the ego's strip of road). The pairs' rows are kept as arrays; `table`
cuts them into encounters at the end: a pair's run of consecutive steps so (SUMO's
encounter, but for vehicles a lane or more apart), each with its minimum TTC and its PET:

- PET (post-encroachment time) where one of the two moves into the other's strip while
  within range (a lane change, a merge: the step its rectangle first overlaps the
  other's strip): the time the rear vehicle needs, at its speed then, to reach where the
  front one's rear is (gap / rear speed; 0 with no gap left). SUMO's PET needs a conflict
  area where lanes cross or merge and is NA for lane changes on one road.

An encounter is a conflict when its TTC fell below `[ssm] ttc_s` or its PET below
`pet_s`. With two automated vehicles an encounter is written from each side, as SUMO's
device does. Where ours and SUMO's differ and why: docs/outputs.md, "fleet_conflicts.csv".
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cosim.run.metrics import gap_ttc, half_extents
from cosim.scenario.model import SsmSpec
from cosim.traffic.snapshot import TrafficSnapshot

COLUMNS: dict[str, str] = {
    "begin_s": "first step of the encounter: the pair within range_m along the road (s)",
    "end_s": "its last step (s)",
    "ego": "the automated vehicle (SUMO id; `sv`: the SV)",
    "foe": "the other vehicle",
    "ttc_min_s": "our smallest TTC over the encounter: gap between the rectangles along "
                 "the road over the closing speed, the foe sharing some of the ego's strip "
                 "(s; NaN: never closing there)",
    "ttc_min_t_s": "when (s)",
    "ttc_min_gap_m": "the gap then (m)",
    "pet_s": "our post-encroachment time: where one moved into the other's strip within "
             "range, the rear vehicle's time to reach the front one's rear at its speed "
             "then (s; NaN: no such move)",
    "pet_t_s": "when the move reached the strip (s)",
    "ttc_conflict": "ttc_min_s < ssm.ttc_s",
    "pet_conflict": "pet_s < ssm.pet_s",
}


# m, how far apart two rectangles' lateral extents may be for their pair to be kept: a
# vehicle moving into another's strip is seen beside it first (a lane change's lateral
# speed moves it 1 m in well over a step), one a lane away is not (3.75 m lanes: 1.9 m)
STRIP_MARGIN = 1.0


class Encounters:
    """Every automated vehicle's pairs per step (module docstring)."""

    def __init__(self, spec: SsmSpec) -> None:
        self.spec = spec
        # per step with pairs: (step, t, the snapshot's ids, ego index, foe index, gap,
        # TTC, the rear one's speed), indices into those ids (kept, not copied, per step)
        self._rows: list[tuple[Any, ...]] = []
        self._steps = 0

    def observe(self, snap: TrafficSnapshot, automated: tuple[str, ...]) -> None:
        """One step: `snap` every vehicle in road coordinates, `automated` the egos' ids."""
        step = self._steps
        self._steps += 1
        if len(snap.ids) < 2:
            return
        ego = np.flatnonzero(np.isin(np.asarray(snap.ids), automated))
        if ego.size == 0:
            return
        x, y, v = snap.x, snap.y, snap.speed
        hx, hy = half_extents(snap.length, snap.width, snap.heading)
        col = ego[:, None]
        gap, ttc = gap_ttc(x[col], y[col], v[col], (hx[col], hy[col]), x, y, v, (hx, hy))
        dx = x[None, :] - x[col]
        near = ((np.abs(dx) - (hx[col] + hx) <= self.spec.range)  # their rectangles' gap
                & (np.abs(y[None, :] - y[col]) - (hy[col] + hy) < STRIP_MARGIN))
        near[np.arange(ego.size), ego] = False  # not itself
        i, j = np.nonzero(near)
        if i.size == 0:
            return
        rear_speed = np.where(dx[i, j] >= 0.0, v[ego[i]], v[j])
        self._rows.append((step, snap.time, snap.ids, ego[i], j, gap[i, j].astype(np.float32),
                           ttc[i, j].astype(np.float32), rear_speed.astype(np.float32)))

    def steps(self) -> Any:
        """Every pair's rows (a pandas DataFrame: step, t_s, ego, foe, gap_m, ttc_s,
        rear_speed_mps; gap and TTC inf where the foe is outside the ego's strip)."""
        import pandas as pd

        names = ("step", "t_s", "ego", "foe", "gap_m", "ttc_s", "rear_speed_mps")
        if not self._rows:
            return pd.DataFrame({n: [] for n in names})
        n = [len(r[3]) for r in self._rows]
        ids = [np.asarray(r[2]) for r in self._rows]
        return pd.DataFrame({
            "step": np.repeat([r[0] for r in self._rows], n),
            "t_s": np.repeat([r[1] for r in self._rows], n),
            "ego": np.concatenate([k[r[3]] for k, r in zip(ids, self._rows, strict=True)]),
            "foe": np.concatenate([k[r[4]] for k, r in zip(ids, self._rows, strict=True)]),
            **{name: np.concatenate([r[c] for r in self._rows]).astype(float)
               for c, name in ((5, "gap_m"), (6, "ttc_s"), (7, "rear_speed_mps"))}})

    def table(self) -> Any:
        """fleet_conflicts.csv's rows (COLUMNS): the encounters past a threshold, by
        begin time, ego, foe."""
        import pandas as pd

        rows = self.steps().sort_values(["ego", "foe", "step"], kind="stable")
        if rows.empty:
            return pd.DataFrame({c: [] for c in COLUMNS})
        ego, foe = rows["ego"].to_numpy(), rows["foe"].to_numpy()
        step = rows["step"].to_numpy()
        same = np.zeros(len(rows), dtype=bool)  # the pair's previous step is the row before
        same[1:] = (ego[1:] == ego[:-1]) & (foe[1:] == foe[:-1]) & (step[1:] == step[:-1] + 1)
        gap = rows["gap_m"].to_numpy(float)
        strip = np.isfinite(gap)
        moved_in = same & strip & ~np.roll(strip, 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            pet = np.where(moved_in, np.maximum(gap, 0.0) / rows["rear_speed_mps"].to_numpy(),
                           np.nan)
        ttc = rows["ttc_s"].to_numpy(float)
        rows = rows.assign(encounter=np.cumsum(~same), pet=np.where(np.isfinite(pet), pet,
                                                                     np.nan),
                           ttc=np.where(np.isfinite(ttc), ttc, np.nan))
        groups = rows.groupby("encounter", sort=False)
        first = groups.first()
        out = pd.DataFrame({"begin_s": first["t_s"], "end_s": groups["t_s"].last(),
                            "ego": first["ego"], "foe": first["foe"]})
        # each encounter's row of its smallest TTC, of its smallest PET (none: NaN)
        low = rows.dropna(subset=["ttc"]).sort_values("ttc", kind="stable").groupby(
            "encounter").first()
        out["ttc_min_s"] = low["ttc"]
        out["ttc_min_t_s"] = low["t_s"]
        out["ttc_min_gap_m"] = low["gap_m"]
        low = rows.dropna(subset=["pet"]).sort_values("pet", kind="stable").groupby(
            "encounter").first()
        out["pet_s"] = low["pet"]
        out["pet_t_s"] = low["t_s"]
        out["ttc_conflict"] = out["ttc_min_s"] < self.spec.ttc
        out["pet_conflict"] = out["pet_s"] < self.spec.pet
        out = out[out["ttc_conflict"] | out["pet_conflict"]]
        return out.sort_values(["begin_s", "ego", "foe"], kind="stable").reset_index(
            drop=True)[list(COLUMNS)]

