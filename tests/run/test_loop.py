"""The co-simulation loop with real SUMO (libsumo): the paper's three cases end to
end, the planner's tau reproduced, our own collision check, keep-lane-and-retry,
the decision rule, dense traffic with outputs written, and the SUMO baseline."""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cosim.cli import main
from cosim.driving.plans import PLAN_COLUMNS
from cosim.planning.planner import LaneChangePlanner, SVPlanState
from cosim.run.loop import run_scenario, simulate
from cosim.run.metrics_row import METRIC_DOCS
from cosim.run.recorder import TRACE_COLUMNS
from cosim.run.result import RunResult
from cosim.scenario import Scenario, load_scenario, project_root, with_overrides
from cosim.traffic.scripted import ScriptedTV

pytestmark = pytest.mark.sumo

SCENARIOS = project_root() / "scenarios"
PAPER_CASES = ("paper_case1_overtaking", "paper_case2_tv_lane_change",
               "paper_case3_lane_exchange")


@cache
def paper(name: str) -> RunResult:
    return simulate(load_scenario(SCENARIOS / f"{name}.toml"))


def scenario_from(tmp_path: Path, text: str, name: str = "s.toml") -> Scenario:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return load_scenario(path)


@pytest.mark.parametrize("name", PAPER_CASES)
def test_paper_case_changes_lanes_without_collision_and_ends_centred(name: str) -> None:
    r = paper(name)
    m = r.metrics
    assert m["collisions"] == 0 and m["sumo_collisions"] == 0
    assert m["lane_changes"] == 1 and m["lane_change_completed"] == 1
    assert not r.events  # SUMO lost or teleported nobody
    lc = r.lane_changes[-1]
    t, y = r.trace["t_s"], r.trace["y_m"]
    after = t >= lc.t0 + lc.tau + 1.0
    assert after.sum() >= 10
    assert np.max(np.abs(y[after] - lc.y_target)) < 0.1
    assert r.trace["lane"][-1] == lc.target_lane


@pytest.mark.parametrize("name", PAPER_CASES)
def test_sumo_lane_index_agrees_with_the_position(name: str) -> None:
    """SUMO's lane index is the lane of the position we wrote: SUMO takes the front
    bumper's (moveToXY's point), which leads the centre by L/2 sin(psi) in y."""
    r = paper(name)
    psi = np.radians(r.trace["psi_deg"])
    y_front = r.trace["y_m"] + 0.5 * r.scenario.vehicle.length * np.sin(psi)
    lane_front = np.floor((y_front - r.road.y_right) / r.road.lane_width)
    lines = r.road.y_right + r.road.lane_width * np.arange(r.road.n_lanes + 1)
    clear = np.min(np.abs(y_front[:, None] - lines[None, :]), axis=1) > 0.02
    assert clear.sum() > 0.95 * y_front.size
    assert np.array_equal(r.trace["sumo_lane"][clear], lane_front[clear])
    # and once settled, the lane of the centre
    assert r.trace["sumo_lane"][-1] == r.trace["lane"][-1]


@pytest.mark.parametrize("name", PAPER_CASES)
def test_first_plan_is_the_planners_own_answer(name: str) -> None:
    """The co-simulation's first plan equals LaneChangePlanner.plan on the scenario's
    initial situation (what `cosim plan` computes)."""
    r = paper(name)
    sc = r.scenario
    x0 = float(r.trace["x_m"][0])
    lane = sc.sv.lane
    target = sc.sv.lane_changes[0].target_lane
    state = SVPlanState(x=x0, y=r.road.lane_center(lane), heading=0.0, vx=sc.sv.speed,
                        ax=0.0, vy=0.0, ay=0.0, lane=lane)
    messages = [ScriptedTV(tv, r.road, x0).message(0.0) for tv in sc.tvs]
    plan = LaneChangePlanner(sc.vehicle, r.road, sc.planner).plan(
        0.0, state, target, messages, sc.sv.occupant)
    first = r.plans[0]
    assert first["t_s"] == 0.0
    if plan.tau is None:
        assert first["ok"] == 0 and math.isnan(first["tau_s"])
    else:
        assert first["ok"] == 1 and first["tau_s"] == pytest.approx(plan.tau, abs=1e-12)
        assert r.lane_changes[0].tau == pytest.approx(plan.tau, abs=1e-12)
    assert first["tau_min_stable_s"] == pytest.approx(plan.tau_min, abs=1e-12)


def test_paper_case_1_tau_sits_in_the_collision_free_set() -> None:
    row = paper(PAPER_CASES[0]).plans[0]
    lo, hi = (float(v) for v in row["collision_free_set_s"].split(";")[0].split("-"))
    assert lo <= row["tau_s"] <= hi
    assert row["rejected_collision"] > 0 and row["rejections"].startswith("pvc:")


CUT_IN = """
[scenario]
name = "cut_in"
duration_s = 6.0
on_collision = "continue"
[road]
mu = 0.8
[sv]
lane = 0
position_m = 200.0
speed_kmh = 80.0
[[tv]]
id = "cutter"
lane = 1
gap_m = 0.0
speed_kmh = 80.0
[tv.lane_change]
start_s = 0.5
target_lane = 0
tau_s = 3.0
broadcast = "none"
"""


def test_a_forced_overlap_is_detected_by_our_check(tmp_path: Path) -> None:
    """A scripted TV driven sideways into the SV: our exact check sees the contact."""
    r = simulate(scenario_from(tmp_path, CUT_IN))
    assert r.metrics["collisions"] == 1  # one contact, counted once however long it lasts
    assert r.metrics["collision"] == 1
    # SUMO's cross-check sees it too (one-dimensionally, once the TV's lane index is the SV's)
    assert r.metrics["sumo_collisions"] == 1
    hit = r.trace["collisions"] > 0
    t_first = r.trace["t_s"][np.argmax(hit)]
    # the TV (quintic over 3 s from 0.5 s) reaches the SV's body when its near side,
    # 0.9 m from its centre, crosses the SV's near side: lateral centre gap 1.8 m
    dy = 3.75 * (1 - _quintic((r.trace["t_s"] - 0.5) / 3.0))
    expected = r.trace["t_s"][np.argmax(dy <= 1.8)]
    assert abs(t_first - expected) <= 0.051


def test_a_collision_stops_the_run_at_its_onset(tmp_path: Path) -> None:
    """The default `on_collision = "stop"`: the run ends with the row of the first onset
    (a crash ends the ride: the SV never drives on inside the TV), recorded with
    its time, the TV and the fault; "continue" runs to the end."""
    go_on = simulate(scenario_from(tmp_path, CUT_IN))
    t_hit = float(go_on.trace["t_s"][np.argmax(go_on.trace["collisions"] > 0)])
    r = simulate(scenario_from(tmp_path, CUT_IN.replace('on_collision = "continue"', "")))
    m = r.metrics
    assert r.scenario.on_collision == "stop"
    assert m["stopped_by_collision"] == 1 and go_on.metrics["stopped_by_collision"] == 0
    assert m["collision_t_s"] == pytest.approx(t_hit) == go_on.metrics["collision_t_s"]
    assert m["collision_with"] == "cutter" and m["collisions"] == 1
    assert m["collisions_sv"] == go_on.metrics["collisions_sv"]  # the same fault
    assert r.trace["t_s"][-1] == pytest.approx(t_hit) == m["duration_s"]
    assert r.trace["collisions"][-1] == 1 and np.all(r.trace["collisions"][:-1] == 0)
    assert m["steps"] == round(t_hit / 0.05) and go_on.metrics["duration_s"] == 6.0
    # the rows up to the onset are the same run's
    n = r.trace["t_s"].size
    assert np.array_equal(r.trace["x_m"], go_on.trace["x_m"][:n])


def test_cosim_run_says_on_stderr_that_a_collision_stopped_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "cut_in.toml"
    path.write_text(CUT_IN.replace('on_collision = "continue"', ""), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-figures"]) == 0
    err = capsys.readouterr().err
    assert "collision with cutter at t = " in err and "the run stopped there" in err
    metrics = (out / "metrics.csv").read_text(encoding="utf-8")
    assert "stopped_by_collision" in metrics


def _quintic(s: np.ndarray) -> np.ndarray:
    s = np.clip(s, 0.0, 1.0)
    return 6 * s**5 - 15 * s**4 + 10 * s**3


BLOCKED = """
[scenario]
name = "blocked"
duration_s = 14.0
[road]
mu = 0.8
[sv]
lane = 0
position_m = 200.0
speed_kmh = 80.0
occupant = 0.5
lane_changes = [{at_s = 0.0, target_lane = 1}]
[[tv]]
id = "beside"
lane = 1
gap_m = 0.0
speed_kmh = 80.0
accel_mps2 = 0.5
"""


def test_no_collision_free_tau_keeps_the_lane_and_asks_again(tmp_path: Path) -> None:
    r = simulate(scenario_from(tmp_path, BLOCKED))
    plans = r.plans
    assert plans[0]["ok"] == 0 and plans[0]["rejections"].startswith("beside:")
    assert plans[1]["trigger"] == "retry" and plans[1]["t_s"] == pytest.approx(1.0)
    ok = [p for p in plans if p["ok"] == 1]
    assert len(ok) == 1 and all(p["trigger"] == "retry" for p in plans[1:])
    t, y = r.trace["t_s"], r.trace["y_m"]
    before = t <= ok[0]["t_s"]
    assert np.max(np.abs(y[before] - r.road.lane_center(0))) < 0.01  # kept its lane
    assert r.metrics["lane_changes"] == 1 and r.metrics["collisions"] == 0


SLOW_LEADER = """
[scenario]
name = "slow_leader"
duration_s = 14.0
[road]
mu = 0.8
[sv]
lane = 0
position_m = 200.0
speed_kmh = 85.0
occupant = 0.5
decision = true
desired_speed_kmh = 90.0
[[tv]]
id = "slow"
lane = 0
gap_m = 60.0
speed_kmh = 65.0
"""


def test_decision_rule_overtakes_a_slow_leader(tmp_path: Path) -> None:
    r = simulate(scenario_from(tmp_path, SLOW_LEADER))
    assert r.plans and r.plans[0]["trigger"] == "decision"
    assert r.plans[0]["target_lane"] == 1 and r.plans[0]["ok"] == 1
    assert r.metrics["lane_changes"] == 1 and r.metrics["collisions"] == 0
    # it asked as soon as the leader came within the look-ahead (100 m), not before:
    # row k holds the gap the rule saw at step k - 1
    k = int(np.searchsorted(r.trace["t_s"], r.plans[0]["t_s"]))
    gaps = r.trace["leader_gap_m"]
    assert gaps[k] > 100.0 >= gaps[k + 1]


def test_dense_traffic_run_writes_its_outputs(tmp_path: Path) -> None:
    sc = with_overrides(load_scenario(SCENARIOS / "traffic_high.toml"), duration=20.0)
    out = tmp_path / "dense"
    metrics = run_scenario(sc, out, write_figures=True)
    for name in ("trace.csv", "plans.csv", "metrics.csv", "timing.csv", "trajectories.png"):
        assert (out / name).is_file(), name
    row = pd.read_csv(out / "metrics.csv")
    assert list(row.columns) == list(METRIC_DOCS)
    for col in ("lane_changes", "collisions", "sumo_collisions", "min_gap_m", "min_ttc_s"):
        assert col in row.columns
    trace = pd.read_csv(out / "trace.csv")
    assert list(trace.columns) == list(TRACE_COLUMNS)
    assert len(trace) == sc.n_steps + 1
    assert trace["n_tvs"].min() > 5  # dense: many TVs around the SV all along
    assert list(pd.read_csv(out / "plans.csv").columns) == list(PLAN_COLUMNS)
    assert metrics["collisions"] == 0
    assert "wall_time_s" in metrics and "wall_time_s" not in row.columns


def test_the_entry_as_its_new_follower_sees_it() -> None:
    """The scripted `lag` TV (lane 2, 30 m behind at 115 km/h) becomes the SV's follower
    when the SV enters lane 2: the entry columns are its gap, time gap and needed
    deceleration at that instant, recomputed here from the trace and its track."""
    from cosim.run.metrics import ENTRY_WINDOW, follower_needed_decel

    r = simulate(load_scenario(Path(__file__).resolve().parents[1] / "bad_inputs" / "base.toml"))
    m, tr = r.metrics, r.trace
    k = int(np.flatnonzero(tr["lane"] == 2)[0])  # the SV's centre enters lane 2
    t_in = float(tr["t_s"][k])
    tt, xx, _ = r.tv_tracks["lag"]
    j = int(np.searchsorted(tt, t_in - 1e-9))
    assert tt[j] == pytest.approx(t_in, abs=1e-9)
    gap = float(tr["s_m"][k] - xx[j]) - 0.5 * (r.scenario.vehicle.length + 4.32)
    v_lag = float((xx[j + 1] - xx[j]) / (tt[j + 1] - tt[j]))
    assert m["entry_follower_gap_m"] == pytest.approx(gap, abs=1e-9)
    assert m["entry_follower_time_gap_s"] == pytest.approx(gap / v_lag, abs=1e-9)
    assert m["entry_follower_needed_decel_mps2"] == pytest.approx(
        follower_needed_decel(gap, v_lag, float(tr["vx_mps"][k])), abs=1e-9)
    after = (tr["t_s"] >= t_in) & (tr["t_s"] <= t_in + ENTRY_WINDOW + 1e-9)
    assert m["entry_min_ttc_s"] == pytest.approx(float(tr["ttc_min_s"][after].min()))


def test_sumo_baseline_runs_the_same_case(tmp_path: Path) -> None:
    sc = with_overrides(load_scenario(SCENARIOS / f"{PAPER_CASES[0]}.toml"), controller="sumo")
    r = simulate(sc)
    m = r.metrics
    assert m["controller"] == "sumo" and m["plant"] == "none"
    assert m["lane_changes"] == 1 and m["final_lane"] == 1
    assert abs(m["final_offset_m"]) < 0.1
    assert math.isnan(m["iae_ye_m_s"])  # SUMO has no reference to track
    assert r.plans[0]["trigger"] == "scripted"
    assert np.isfinite(m["min_gap_m"]) and m["collisions"] == 0


def test_cli_bad_scenario_exits_2_and_writes_nothing(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[scenario]\nname = 'x'\nduration_s = -1\n[sv]\nlane = 0\n", encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(bad), "--out", str(out)]) == 2
    assert not out.exists()


def test_docs_describe_every_output_column() -> None:
    from cosim.run.fleet import FLEET_COLUMNS, FLEET_METRIC_DOCS
    from cosim.run.result import TIMING_DOCS
    from cosim.traffic.detectors import COLUMNS as DETECTOR_COLUMNS
    from cosim.traffic.ssm import COLUMNS as CONFLICT_COLUMNS
    from cosim.traffic.ssm import COUNT_DOCS
    from cosim.traffic.traffic_measures import TRAFFIC_DOCS

    text = (project_root() / "docs" / "outputs.md").read_text(encoding="utf-8")
    for columns in (TRACE_COLUMNS, PLAN_COLUMNS, METRIC_DOCS, TIMING_DOCS, DETECTOR_COLUMNS,
                    TRAFFIC_DOCS, FLEET_COLUMNS, FLEET_METRIC_DOCS, ("vehicle_id",),
                    CONFLICT_COLUMNS, COUNT_DOCS):
        for name in columns:
            assert f"| `{name}` |" in text, name


def test_sumo_baseline_sv_starts_where_ours_does_in_dense_traffic() -> None:
    """SUMO's own insertion would refuse a car at 100 km/h in this traffic: the
    baseline SV is placed like ours and then driven by SUMO."""
    sc = with_overrides(load_scenario(SCENARIOS / "traffic_high.toml"), controller="sumo",
                        duration=5.0)
    r = simulate(sc)
    x_ours = simulate(with_overrides(sc, controller="mimo", duration=0.1)).trace["x_m"][0]
    assert r.trace["x_m"][0] == pytest.approx(x_ours, abs=1e-6)
    assert r.trace["y_m"][0] == pytest.approx(r.road.lane_center(sc.sv.lane))
    assert r.trace["vx_mps"][0] == pytest.approx(sc.sv.speed)
    assert not r.events and r.metrics["collisions"] == 0
    # SUMO drives it: its speed follows SUMO's car-following model, not a script
    assert np.all(np.isfinite(r.trace["vx_mps"])) and r.trace["sumo_lane"].min() >= 0


THERE_AND_BACK = """
[scenario]
name = "there_and_back"
duration_s = 10.0
[road]
mu = 0.8
[sv]
lane = 0
position_m = 200.0
speed_kmh = 85.0
occupant = 1.0
lane_changes = [{at_s = 0.0, target_lane = 1}, {at_s = 4.0, target_lane = 0}]
"""


def test_scripted_requests_come_when_the_scenario_says(tmp_path: Path) -> None:
    """Two scripted changes, the second 4 s after the first began: it starts at 4 s
    (the decision rule's cooldown does not hold scripted requests back), and the SV
    ends back in the centre of lane 0."""
    r = simulate(scenario_from(tmp_path, THERE_AND_BACK))
    assert [p["trigger"] for p in r.plans] == ["scripted", "scripted"]
    assert [p["t_s"] for p in r.plans] == pytest.approx([0.0, 4.0])
    first = r.lane_changes[0]
    assert first.t0 + first.tau < 4.0  # the first was over by then
    assert r.metrics["lane_changes"] == 2 and r.metrics["final_lane"] == 0
    assert abs(r.metrics["final_offset_m"]) < 0.1


@pytest.mark.parametrize("controller", ["mimo", "sumo"])
def test_comfort_metrics_are_the_traces_for_both_drivers(controller: str) -> None:
    """The comfort columns, for our driver and SUMO's alike (paper case 5.1)."""
    from cosim.run.metrics import COMFORT_COLUMNS

    sc = with_overrides(load_scenario(SCENARIOS / "paper_case1_overtaking.toml"),
                        controller=controller)
    r = simulate(sc)
    m, t, ax = r.metrics, r.trace["t_s"], r.trace["ax_mps2"]
    assert all(k in m for k in COMFORT_COLUMNS)
    ok = np.isfinite(ax)
    assert m["rms_long_accel_mps2"] == pytest.approx(np.sqrt(np.mean(ax[ok] ** 2)))
    jerk = np.abs(np.diff(ax) / np.diff(t))
    assert m["max_long_jerk_mps3"] == pytest.approx(np.nanmax(jerk))
    assert m["long_accel_jump_share"] < 0.01
    # requested at 0 s (scripted), in lane 1 within the lane change's time
    entered = t[np.argmax(r.trace["lane"] == 1)]
    assert m["request_to_lane_s"] == pytest.approx(entered - sc.sv.lane_changes[0].at)
    assert 0.5 < m["request_to_lane_s"] < 6.4
    assert m["merge_time_gap_s"] == math.inf  # case 5.1: nobody ahead in lane 1
    assert 0.0 <= m["post_change_max_decel_mps2"] < 3.0
