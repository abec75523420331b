"""SUMO's surrogate safety measures device (`[ssm]`): SUMO measures the conflicts, cosim
configures its device and turns what it wrote into one tidy table (conflicts.csv) and a
few counts (metrics.csv).

The device (`sumo_options`) runs on every vehicle (`vehicles = "all"`,
device.ssm.probability 1), on the SV alone (`"sv"`, device.ssm.explicit: its encounters
with every vehicle within `range`) or on the SV and the fleet's vTypes (`"fleet"`: the
SV and the `<vehicle>` / `<trip>` elements of those vTypes by name, the vehicles of
their flows by the vType's parameter `has.ssm.device`, set after the warm-up
(World.start, `equip_vtypes`: the flows' vehicles SUMO builds from then on): SUMO builds
a vehicle's devices with the vehicle and cannot add one later, so a vehicle the fleet
draws by `share` at its insertion cannot carry one), with the measures TTC, DRAC and PET
and the scenario's thresholds: SUMO logs an encounter as a conflict when any of the
three passes its threshold, with the extreme of each measure over the encounter (when,
where, its encounter type), and writes them all into one file in a folder the caller
gives (run_scenario: its temporary folder). The device only observes: the vehicles move
alike with or without it (tests/traffic/test_ssm.py). The SV moved by moveToXY carries
its device like any vehicle: SUMO takes its lane, position and speed as the move left
them, so its encounters follow SUMO's lane of the SV (docs/outputs.md, "conflicts.csv":
SUMO's TTC for the SV against ours).

With every vehicle equipped, an encounter of two vehicles is logged twice, once from
each side (ego and foe swapped, the type from that side: FOLLOWING_LEADER for the
leader, FOLLOWING_FOLLOWER for the follower); conflicts.csv keeps both rows, as SUMO
wrote them, and the counts count each encounter once (`conflict_counts`).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from cosim.scenario.model import SsmSpec

OUTPUT_FILE = "ssm.xml"  # SUMO's output, in the caller's folder

# SUMO's encounter types (MSDevice_SSM::EncounterType), as conflicts.csv names them
ENCOUNTER_TYPES = {
    0: "noconflict_ahead", 1: "following", 2: "following_follower", 3: "following_leader",
    4: "on_adjacent_lanes", 5: "merging", 6: "merging_leader", 7: "merging_follower",
    8: "merging_adjacent", 9: "crossing", 10: "crossing_leader", 11: "crossing_follower",
    12: "ego_entered_conflict_area", 13: "foe_entered_conflict_area",
    14: "ego_left_conflict_area", 15: "foe_left_conflict_area",
    16: "both_entered_conflict_area", 17: "both_left_conflict_area",
    18: "following_passed", 19: "merging_passed", 20: "oncoming", 100: "collision",
}

# (measure: SUMO's element, conflicts.csv's prefix and unit of its value)
MEASURES = (("minTTC", "ttc_min", "s"), ("maxDRAC", "drac_max", "mps2"), ("PET", "pet", "s"))

COLUMNS = ("begin_s", "end_s", "ego", "foe", "sv",
           *(c for _, p, u in MEASURES
             for c in (f"{p}_{u}", f"{p}_t_s", f"{p}_x_m", f"{p}_y_m", f"{p}_type")),
           "ttc_conflict", "drac_conflict", "pet_conflict")

COUNT_DOCS: dict[str, str] = {
    "ssm_conflicts": "encounters SUMO's SSM device logged as conflicts (any measure past "
                     "its [ssm] threshold on the run's clock, t >= 0: not in a warm-up), "
                     "each pair's encounter once (-)",
    "ssm_ttc_conflicts": "of them, those whose minimum TTC fell below ssm.ttc_s (-)",
    "ssm_drac_conflicts": "those whose maximum DRAC rose above ssm.drac_mps2 (-)",
    "ssm_pet_conflicts": "those whose PET fell below ssm.pet_s (-)",
    "ssm_sv_conflicts": "the conflicts the SV is part of (-)",
    "ssm_min_ttc_s": "the smallest TTC over every conflict (s; NaN: none measured)",
    "ssm_max_drac_mps2": "the largest DRAC over every conflict (m/s^2; NaN: none)",
}


# a vType's parameter that equips every vehicle SUMO builds of it from then on (SUMO
# refuses to add the device to a vehicle it has built: "creating device of type 'ssm' is
# not supported")
EQUIP_PARAMETER = "has.ssm.device"


def sumo_options(spec: SsmSpec, folder: Path, sv_id: str, loaded: Sequence[str] = ()
                 ) -> tuple[tuple[str, str], ...]:
    """SUMO's options for the device, its output going into `folder`; `loaded`: with
    `vehicles = "fleet"`, the fleet's vehicles SUMO builds as it loads its routes
    (`loaded_vehicles`), equipped by name with the SV."""
    who = (("--device.ssm.probability", "1") if spec.vehicles == "all"
           else ("--device.ssm.explicit", ",".join((sv_id, *loaded))))
    return (who,
            ("--device.ssm.measures", "TTC DRAC PET"),
            ("--device.ssm.thresholds", f"{spec.ttc!r} {spec.drac!r} {spec.pet!r}"),
            ("--device.ssm.range", repr(spec.range)),
            ("--device.ssm.file", str(Path(folder) / OUTPUT_FILE)))


def loaded_vehicles(route_files: Sequence[str | Path], vtypes: Sequence[str]
                    ) -> tuple[str, ...]:
    """The `<vehicle>` and `<trip>` elements of those vTypes in SUMO route files: SUMO
    builds them, their devices with them, as it reads its routes (its flows' vehicles
    come one by one as they depart: `equip_vtypes` reaches those)."""
    wanted = set(vtypes)
    ids: list[str] = []
    for path in route_files:
        for _, node in ET.iterparse(path):
            if node.tag in ("vehicle", "trip") and node.get("type") in wanted:
                ids.append(str(node.get("id")))
    return tuple(ids)


def equip_vtypes(api: Any, vtypes: Sequence[str]) -> None:
    """Every vehicle of these vTypes SUMO builds from now on carries the device (libsumo's
    vehicletype API; vTypes SUMO does not know are left out)."""
    known = set(api.vehicletype.getIDList())
    for vtype in vtypes:
        if vtype in known:
            api.vehicletype.setParameter(vtype, EQUIP_PARAMETER, "true")


def _number(value: str | None) -> float:
    """SUMO's value; NA (not measured) is NaN."""
    return math.nan if value in (None, "NA") else float(value)


def _measure(node: ET.Element | None, t0: float) -> tuple[Any, ...]:
    """(value, time on the run's clock, x, y, type name) of one measure's element."""
    if node is None:
        return (math.nan, math.nan, math.nan, math.nan, "")
    a = node.attrib
    x = y = math.nan
    if a.get("position", "NA") != "NA":
        x, y = (float(v) for v in a["position"].split(",")[:2])
    kind = a.get("type", "NA")
    name = "" if kind == "NA" else ENCOUNTER_TYPES.get(int(kind), f"type_{kind}")
    return (_number(a.get("value")), _number(a.get("time")) - t0, x, y, name)


def conflicts_table(folder: Path, spec: SsmSpec, sv_id: str, t0: float = 0.0) -> Any:
    """conflicts.csv's rows (a pandas DataFrame of COLUMNS) from SUMO's output in
    `folder`, one per conflict SUMO wrote, by begin time, ego, foe; times on the run's
    clock (SUMO's minus `t0`, the warm-up); `*_conflict`: that measure passed its
    threshold."""
    import pandas as pd

    path = Path(folder) / OUTPUT_FILE
    rows = []
    if path.is_file():
        for c in ET.parse(path).getroot().iter("conflict"):
            a = c.attrib
            values = [_measure(c.find(tag), t0) for tag, _, _ in MEASURES]
            ttc, drac, pet = (v[0] for v in values)
            rows.append((float(a["begin"]) - t0, float(a["end"]) - t0, a["ego"], a["foe"],
                         sv_id in (a["ego"], a["foe"]), *(x for v in values for x in v),
                         bool(ttc < spec.ttc), bool(drac > spec.drac), bool(pet < spec.pet)))
    rows.sort(key=lambda r: (r[0], r[2], r[3]))
    return pd.DataFrame(rows, columns=list(COLUMNS))


def conflict_counts(table: Any) -> dict[str, float]:
    """metrics.csv's SSM columns (COUNT_DOCS) of a conflicts table: each encounter once
    (its pair and begin time, whichever side logged it), a measure only when its extreme
    came on the run's clock (t >= 0: not during a warm-up)."""
    import numpy as np

    run = table.assign(
        ttc_conflict=table.ttc_conflict & (table.ttc_min_t_s >= 0),
        drac_conflict=table.drac_conflict & (table.drac_max_t_s >= 0),
        pet_conflict=table.pet_conflict & (table.pet_t_s >= 0))
    run = run[run.ttc_conflict | run.drac_conflict | run.pet_conflict]
    if len(run):
        pair = [tuple(sorted(p)) for p in zip(run.ego, run.foe, strict=True)]
        once = run.assign(pair=pair).drop_duplicates(["pair", "begin_s"])
    else:
        once = run
    ttc = table["ttc_min_s"].to_numpy(float)[table["ttc_min_t_s"].to_numpy(float) >= 0]
    drac = table["drac_max_mps2"].to_numpy(float)[table["drac_max_t_s"].to_numpy(float) >= 0]
    return {
        "ssm_conflicts": len(once),
        "ssm_ttc_conflicts": int(once["ttc_conflict"].sum()),
        "ssm_drac_conflicts": int(once["drac_conflict"].sum()),
        "ssm_pet_conflicts": int(once["pet_conflict"].sum()),
        "ssm_sv_conflicts": int(once["sv"].sum()),
        "ssm_min_ttc_s": float(np.nanmin(ttc)) if np.isfinite(ttc).any() else math.nan,
        "ssm_max_drac_mps2": float(np.nanmax(drac)) if np.isfinite(drac).any() else math.nan,
    }


VEHICLE_KM_DOCS = {
    "vehicle_km": "kilometres all vehicles drove on the run's clock (t > 0), summed over "
                  "SUMO's edges of each step's vehicles times their mean speed (km; runs "
                  "with [ssm]: the denominator of conflicts per vehicle-km)",
}


class VehicleDistance:
    """A step hook (SumoSim.add_hook) summing the distance every vehicle drives: per step,
    over SUMO's edges (internal ones too), its vehicles times their mean speed times the
    step. Counts steps ending after `since` (s, SUMO's clock: the run's t = 0 once
    World.insert sets it; nothing before)."""

    def __init__(self) -> None:
        self.since = math.inf
        self.metres = 0.0
        self._edges: tuple[str, ...] | None = None

    def __call__(self, sim: Any) -> None:
        api = sim.api
        if api.simulation.getTime() <= self.since:
            return
        if self._edges is None:
            self._edges = tuple(api.edge.getIDList())
        edge = api.edge
        self.metres += sim.step_length * sum(
            edge.getLastStepVehicleNumber(e) * edge.getLastStepMeanSpeed(e)
            for e in self._edges)

    def columns(self) -> dict[str, float]:
        """metrics.csv's `vehicle_km`."""
        return {"vehicle_km": self.metres / 1000.0}
