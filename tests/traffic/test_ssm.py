"""SUMO's SSM device (`[ssm]`, cosim.traffic.ssm), in real SUMO: conflicts.csv holds
SUMO's own values (read here from its raw XML, apart from ours), the counts count each
encounter once, the device changes no vehicle's motion, and SUMO's TTC for the SV (moved
by moveToXY) against our own exact-geometry TTC on the same steps (docs/outputs.md,
"conflicts.csv": where and why they differ)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cosim.errors import InputError
from cosim.run.loop import CoSimulation, run_scenario
from cosim.run.metrics import gap_ttc, half_extents
from cosim.scenario import load_scenario, with_overrides
from cosim.traffic.ssm import COLUMNS, COUNT_DOCS, OUTPUT_FILE, VEHICLE_KM_DOCS, conflict_counts

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"


def _run(sc: Any, folder: Path) -> dict[str, Any]:
    """The run with SUMO's SSM output kept in `folder` and every vehicle's state after
    every SUMO step (SUMO's clock -> snapshot), as SSM sees them."""
    steps: dict[float, Any] = {}
    sim = CoSimulation(sc, detector_output=folder)
    sim.world.sumo.add_hook(lambda sumo: steps.__setitem__(round(sumo.time, 6),
                                                           sumo.snapshot()))
    result = sim.run()
    return {"result": result, "steps": steps, "dt": sc.step, "folder": folder}


@pytest.fixture(scope="module")
def overtaking(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Paper case 5.1 (the SV passes close behind its slower leader), every vehicle
    equipped, TTC threshold 10 s so that the pass is logged."""
    sc = with_overrides(load_scenario(SCENARIOS / "paper_case1_overtaking.toml"),
                        **{"ssm.enabled": True, "ssm.ttc_s": 10.0})
    return _run(sc, tmp_path_factory.mktemp("ssm_case1"))


@pytest.fixture(scope="module")
def dense(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """traffic_high, 15 s, the SV in the slow lane at 90 km/h closing on its leaders and
    leaving to the left by the decision rule; the device on the SV alone, 100 m range,
    TTC threshold 60 s (SUMO's drivers keep their distance: nothing closer is logged)."""
    sc = with_overrides(load_scenario(SCENARIOS / "traffic_high.toml"), duration=15.0,
                        **{"ssm.enabled": True, "ssm.vehicles": "sv", "ssm.ttc_s": 60.0,
                           "ssm.range_m": 100.0, "sv.lane": 0, "sv.speed_kmh": 90.0})
    return _run(sc, tmp_path_factory.mktemp("ssm_dense"))


def _ours(run: dict[str, Any], foe: str, begin: float, end: float) -> np.ndarray:
    """Per step of [begin, end] (SUMO's clock) where both exist: (t, our TTC from the SV
    to `foe`, our gap, the SV's SUMO lane): cosim.run.metrics.gap_ttc's rectangles (the
    trace's rule), speeds along the lane as SUMO has them."""
    rows = []
    for t, s in sorted(run["steps"].items()):
        if not begin - 1e-9 <= t <= end + 1e-9 or foe not in s.ids or "sv" not in s.ids:
            continue
        i, j = s.ids.index("sv"), s.ids.index(foe)
        hx, hy = half_extents(s.length, s.width, s.heading)
        gap, ttc = gap_ttc(s.x[i], s.y[i], s.speed[i], (hx[i], hy[i]), s.x[j:j + 1],
                           s.y[j:j + 1], s.speed[j:j + 1], (hx[j:j + 1], hy[j:j + 1]))
        rows.append((t, float(ttc[0]), float(gap[0]), int(s.lane[i])))
    return np.array(rows)


def test_the_table_holds_sumos_own_values_and_counts_each_encounter_once(
        overtaking: dict[str, Any]) -> None:
    """Every conflict SUMO wrote is one row with its values (NA: NaN); with every vehicle
    equipped the SV-pvc encounter is written from both sides (follower and leader), and
    counted once; its TTC and DRAC passed their thresholds, PET (no crossing) is NA."""
    result = overtaking["result"]
    table = result.conflicts
    assert list(table.columns) == list(COLUMNS)
    raw = list(ET.parse(overtaking["folder"] / OUTPUT_FILE).getroot().iter("conflict"))
    assert len(table) == len(raw) == 2
    for node in raw:
        row = table[(table.ego == node.get("ego")) & (table.foe == node.get("foe"))].iloc[0]
        ttc = node.find("minTTC").attrib
        assert row.ttc_min_s == float(ttc["value"]) and row.ttc_min_t_s == float(ttc["time"])
        assert (row.ttc_min_x_m, row.ttc_min_y_m) == tuple(
            float(v) for v in ttc["position"].split(","))
        assert row.drac_max_mps2 == float(node.find("maxDRAC").get("value"))
        assert math.isnan(row.pet_s) and row.pet_type == ""
        assert row.sv and row.ttc_conflict and row.drac_conflict and not row.pet_conflict
    assert set(table.ttc_min_type) == {"following_follower", "following_leader"}
    m = result.metrics
    assert list(k for k in m if k.startswith("ssm_")) == list(COUNT_DOCS)
    assert (m["ssm_conflicts"], m["ssm_ttc_conflicts"], m["ssm_drac_conflicts"],
            m["ssm_pet_conflicts"], m["ssm_sv_conflicts"]) == (1, 1, 1, 0, 1)
    assert m["ssm_min_ttc_s"] == table.ttc_min_s.min()


def test_without_ssm_a_run_writes_what_it_wrote_before(tmp_path: Path) -> None:
    """[ssm] off writes no conflicts.csv and the same files; on, the vehicles move alike
    (trace.csv and plans.csv the same bytes; metrics.csv the same columns and values,
    the SSM counts added)."""
    import pandas as pd

    base = load_scenario(SCENARIOS / "paper_case1_overtaking.toml")
    runs = {"absent": base, "on": with_overrides(base, **{"ssm.enabled": True})}
    for name, sc in runs.items():
        run_scenario(sc, tmp_path / name, write_figures=False)
    assert sorted(p.name for p in (tmp_path / "absent").iterdir()) == [
        "metrics.csv", "plans.csv", "timing.csv", "trace.csv"]
    assert (tmp_path / "on" / "conflicts.csv").is_file()
    for name in ("plans.csv", "trace.csv"):
        assert (tmp_path / "on" / name).read_bytes() == (tmp_path / "absent" / name
                                                         ).read_bytes()
    before = pd.read_csv(tmp_path / "absent" / "metrics.csv")
    after = pd.read_csv(tmp_path / "on" / "metrics.csv")
    assert list(after.columns) == [*before.columns, *COUNT_DOCS, *VEHICLE_KM_DOCS]
    # every vehicle's km: at least the SV's own distance, at most all driving flat out
    hours = float(before["duration_s"].iloc[0]) / 3600.0
    assert 15.0 * 3.6 * hours < after["vehicle_km"].iloc[0] < 40 * 40.0 * 3.6 * hours
    pd.testing.assert_frame_equal(after[before.columns], before)


def test_sumos_ttc_for_the_sv_against_ours_on_a_close_pass(overtaking: dict[str, Any]
                                                           ) -> None:
    """The SV passes its slower leader pvc: at SUMO's minimum (the last step before SUMO
    moves the SV to the target lane), our gap is SUMO's plus at most one step of closing
    (SUMO's SSM sees the pair a step apart); after that step SUMO's encounter is over
    (another lane) while our rectangles still share pvc's strip: ours goes on falling,
    to a few centimetres, far below SUMO's minimum."""
    row = overtaking["result"].conflicts.query("ego == 'sv'").iloc[0]
    ours = _ours(overtaking, "pvc", row.begin_s, row.end_s)
    at = ours[np.argmin(np.abs(ours[:, 0] - row.ttc_min_t_s))]
    closing = at[2] / at[1]  # m/s
    assert at[3] == 0  # SUMO still has the SV in pvc's lane
    assert 0.0 <= at[2] - row.ttc_min_s * closing <= closing * overtaking["dt"] + 0.01
    low = ours[np.argmin(ours[:, 1])]
    assert low[0] > row.ttc_min_t_s and low[3] == 1  # after SUMO's lane switch
    assert low[1] < 0.25 * row.ttc_min_s and low[2] < 0.15  # s, m


def test_sumos_ttc_for_the_sv_against_ours_in_dense_traffic(dense: dict[str, Any]) -> None:
    """Every conflict of the SV's device in dense traffic is a following one; at SUMO's
    minimum ours is within 2 % of SUMO's (SUMO's two decimals) plus one step's change of
    our TTC (SUMO's SSM sees the pair a step apart: where the TTC still falls fast, as in
    an encounter the run's end cuts off, that step is most of the difference), and over
    the encounter ours is never above SUMO's minimum by more (ours sees the TV until the
    SV's rectangle leaves its strip)."""
    table = dense["result"].conflicts
    assert len(table) >= 2 and table.sv.all() and (table.ego == "sv").all()
    assert set(table.ttc_min_type) <= {"following_follower", "following_leader"}
    for row in table.itertuples():
        ours = _ours(dense, row.foe, row.begin_s, row.end_s)
        k = int(np.argmin(np.abs(ours[:, 0] - row.ttc_min_t_s)))
        step = abs(ours[k, 1] - ours[k - 1, 1]) if k > 0 else 0.0  # s, our TTC's last step
        assert abs(ours[k, 1] - row.ttc_min_s) <= 0.02 * row.ttc_min_s + step, row.foe
        assert ours[:, 1].min() <= 1.01 * row.ttc_min_s + step


def test_bad_ssm_keys_are_refused_in_one_line() -> None:
    base = load_scenario(SCENARIOS / "traffic_high.toml")
    for keys, allowed in (({"ssm.ttc_s": 0.0}, "60] s"),
                          ({"ssm.drac_mps2": -1.0}, "100] m/s^2"),
                          ({"ssm.pet_s": 100.0}, "60] s"),
                          ({"ssm.vehicles": "near"}, "all"),
                          ({"ssm.vehicles": "fleet"}, "without fleet.vtypes"),
                          ({"ssm.range_m": 0.0}, "[1, 1000] m")):
        with pytest.raises(InputError, match=r"ssm\.") as info:
            with_overrides(base, **keys)
        assert allowed in str(info.value) and "\n" not in str(info.value)


def test_counts_leave_out_what_came_during_the_warm_up(overtaking: dict[str, Any]) -> None:
    """A measure whose extreme came before the run's t = 0 (a warm-up) counts for nothing;
    the pass's two rows, moved 5 s earlier, count no conflict and no extreme."""
    table = overtaking["result"].conflicts
    shifted = table.assign(**{c: table[c] - 5.0 for c in table.columns if c.endswith("_t_s")})
    m = conflict_counts(shifted)
    assert m["ssm_conflicts"] == m["ssm_ttc_conflicts"] == m["ssm_sv_conflicts"] == 0
    assert math.isnan(m["ssm_min_ttc_s"]) and math.isnan(m["ssm_max_drac_mps2"])
    assert conflict_counts(table)["ssm_conflicts"] == 1
