"""`cosim bench planner`: planning time, the planner against a loop transcription.

Side by side in one run, medians over repeats:

- the paper's three cases (their scenario files, tau step 0.05 s);
- a dense case: 20 TVs around the SV on three lanes, 5 of them C2 (the SV must be
  safe against each one's whole stable cluster), tau step 0.05 s;

each planned by `LaneChangePlanner.plan` (its collision check is one compiled kernel
over candidates x samples x TV hypotheses) and by `loop_plan`, a direct transcription
of the paper's collision procedure with one Python loop per candidate tau of the
stable set and, inside it, one per TV trajectory (hypothesis): the exact test of
that pair over the time grid in one numpy call, stopping at the first overlap; for
the paper cases also by `step_loop_plan`, with no vectorisation at all: for each
candidate, for each time sample (eq. 10's integral as a sum), for each TV
trajectory, one scalar test. All share the planner's stable set (so the loops time
the collision procedure, not the envelope: the planner's tau_min maps are built
once per planner), the prediction, the time grid and the horizons; for the look
between samples and between a C2 TV's durations the loops call the planner's
compiled routine once per candidate and TV (when no sample overlaps). The bench
checks that their collision-free sets agree.

Targets: paper cases < 1 ms, dense case < 3 ms, loop / plan() >= 100x.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cosim.bench import median_time
from cosim.commands import count
from cosim.params import PlannerConfig, RoadParams, VehicleParams, kmh
from cosim.planning.collision import (
    Box,
    CollisionTest,
    SVCandidates,
    TVHypotheses,
    check_candidates,
    overlap_sat,
)
from cosim.planning.envelope import MODES
from cosim.planning.planner import LaneChangePlanner, SVPlanState
from cosim.planning.prediction import C2Options, predict_lazy
from cosim.planning.trajectory import cluster_derivatives
from cosim.traffic.v2v import V2VMessage

PAPER_CASES = (
    ("paper 5.1", "paper_case1_overtaking"),
    ("paper 5.2", "paper_case2_tv_lane_change"),
    ("paper 5.3", "paper_case3_lane_exchange"),
)
Array = NDArray[np.float64]
TARGETS = {"paper_ms": 1.0, "dense_ms": 3.0, "ratio": 100.0}
Situation = tuple[LaneChangePlanner, float, SVPlanState, int, list[V2VMessage], float]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--repeats", type=count("--repeats"), default=15,
                        help="repeats of plan() (median; default 15)")
    parser.add_argument("--loop-repeats", type=count("--loop-repeats"), default=3,
                        help="repeats of the loop transcription (median; default 3: "
                             "one run can catch a burst of load)")
    parser.add_argument("--no-step-loop", action="store_true",
                        help="skip the per-time-step loop (paper cases only; slow)")


def dense_situation(seed: int = 3) -> Situation:
    """The SV at 100 km/h in lane 1 changing to lane 2 among 20 TVs within -120..+150 m,
    5 of them announcing a lane change (C2), the others keeping their lane (C1)."""
    road = RoadParams(mu=0.8)
    rng = np.random.default_rng(seed)
    sv = SVPlanState(500.0, road.lane_center(1), 0.0, kmh(100), 0.0, 0.0, 0.0, 1)
    messages: list[V2VMessage] = []
    per_lane = {0: 7, 1: 6, 2: 7}
    c2_left = 5
    for lane, n in per_lane.items():
        # spaced at least 18 m apart (centre to centre) and clear of the SV
        slots = np.sort(rng.choice(np.arange(-120.0, 150.0, 18.0), size=n, replace=False))
        slots = slots[np.abs(slots) > 12.0] if lane == 1 else slots
        lo, hi = road.speed_bands[lane]
        for gap in slots:
            intention = 0
            if c2_left and abs(gap) < 80.0 and lane != 1:
                intention = 1 if lane == 0 else -1  # towards the middle lane
                c2_left -= 1
            elif c2_left and lane == 1 and abs(gap) < 80.0:
                intention = 1
                c2_left -= 1
            messages.append(V2VMessage(
                f"tv{len(messages)}", 0.0, sv.x + float(gap), road.lane_center(lane), 0.0,
                float(rng.uniform(lo, hi)), float(rng.uniform(-0.3, 0.3)), lane, 0.0,
                4.32, 1.8, intention, None))
    planner = LaneChangePlanner(VehicleParams(), road, PlannerConfig(tau_step=0.05))
    return planner, 0.0, sv, 2, messages, 0.5


def paper_situation(name: str) -> Situation:
    from cosim.planning.situation import situation
    from cosim.scenario import load_scenario, project_root

    sc = load_scenario(project_root() / "scenarios" / f"{name}.toml")
    si = situation(sc)
    planner = LaneChangePlanner(sc.vehicle, si.road, sc.planner)
    return planner, si.t, si.sv, si.target_lane, list(si.messages), si.occupant


def _loop_setup(planner: LaneChangePlanner, t: float, sv: SVPlanState, target: int,
                messages: list[V2VMessage]) -> dict[str, Any]:
    """What the loops share with the planner: the stable set (the planner's own, so the
    loops time the collision procedure over the same candidates), the prediction, the
    time grid and the horizons."""
    cfg, road, veh = planner.config, planner.road, planner.vehicle
    vxf = road.target_speed(sv.lane, target)
    width = road.lane_center(target) - sv.y
    st = planner._stable_set(sv.boundary(vxf, width), MODES.get((sv.lane, target)))
    taus, stable = planner.grid, st.stable
    t_rel, follow = planner._horizon(t, 0.0, sv.x, sv.vx, vxf, target, messages)
    c2 = C2Options(cfg.envelope, cfg.safety_factor,
                   planner._tv_stable if planner.use_maps else None,
                   cfg.collision_test == CollisionTest.EXACT)
    lazy = predict_lazy(messages, t, t_rel, road, veh, taus, c2)
    futures = lazy.materialise()
    tv_end = np.where(np.isfinite(futures.t_end), futures.t_end - t, -np.inf)
    tv_hor = np.maximum(tv_end + cfg.horizon_extra, follow[futures.owner])
    tvs = TVHypotheses.from_futures(lazy)
    vehicles = [np.flatnonzero(lazy.owner == i) for i in range(len(lazy.vehicle_ids))]
    return {"vxf": vxf, "width": width, "taus": taus, "stable": stable, "t_rel": t_rel,
            "futures": futures, "tv_hor": tv_hor, "tvs": tvs, "vehicles": vehicles,
            "kw": {"ax0": sv.ax, "vy0": sv.vy, "ay0": sv.ay}}


def _cells_hit(planner: LaneChangePlanner, sv: SVPlanState, s: dict[str, Any], tau: float,
               hyps: Array) -> bool:
    """The look between samples and durations for one candidate and one TV: the
    planner's compiled routine on that pair alone (the loops transcribe the
    procedure around it; the cells are looked at the same way)."""
    tvs: TVHypotheses = s["tvs"]
    one = TVHypotheses(tvs.rows_x, tvs.rows_y, tvs.rows_h, tvs.row_of[hyps], tvs.lc[hyps],
                       tvs.cell[hyps], tvs.length[hyps], tvs.width[hyps],
                       np.array([0, hyps.size]))
    cand = SVCandidates(np.array([tau]), sv.vx, s["vxf"], s["width"], sv.x, sv.y, **s["kw"])
    cfg, veh = planner.config, planner.vehicle
    hits = check_candidates(s["t_rel"], cand, veh,
                            np.array([tau + cfg.horizon_extra]), one, s["tv_hor"][hyps],
                            margin=cfg.safety_margin, test=cfg.collision_test)
    return bool(hits.collides[0])


def loop_plan(planner: LaneChangePlanner, t: float, sv: SVPlanState, target: int,
              messages: list[V2VMessage]) -> NDArray[np.bool_]:
    """The collision-free mask on the planner's grid, one candidate and one TV
    trajectory at a time (the paper's procedure, transcribed directly; each pair's
    test over the time samples in one numpy call; then, when no sample overlaps, the
    look between samples and durations of each TV)."""
    cfg, veh = planner.config, planner.vehicle
    s = _loop_setup(planner, t, sv, target, messages)
    vxf, width, taus, t_rel, futures = (
        s[k] for k in ("vxf", "width", "taus", "t_rel", "futures"))
    free = np.zeros(taus.size, dtype=bool)
    for i, tau in enumerate(taus):  # one candidate of the stable set at a time
        if not s["stable"][i]:
            continue
        d = cluster_derivatives(sv.boundary(vxf, width), [tau], t_rel, (0, 1))
        x, y = d[0][0][0] + sv.x, d[0][1][0] + sv.y
        h = np.arctan2(d[1][1][0], d[1][0][0])
        collides = False
        for j in range(futures.n_hypotheses):  # one TV trajectory at a time
            k = t_rel <= max(tau + cfg.horizon_extra, s["tv_hor"][j])
            tv = Box(futures.x[j, k], futures.y[j, k], futures.heading[j, k], futures.length[j],
                     futures.width[j])
            if overlap_sat(Box(x[k], y[k], h[k], veh.length, veh.width), tv,
                           margin=cfg.safety_margin).any():
                collides = True
                break
        if not collides:
            collides = any(_cells_hit(planner, sv, s, float(tau), hyps)
                           for hyps in s["vehicles"])
        free[i] = not collides
    return free


Pose = tuple[float, float, float, float, float]  # m, m, rad, m, m: x, y, heading, length, width


def _overlap_scalar(a: Pose, b: Pose, m: float) -> bool:
    """The separating-axes test on plain floats (one pair, one instant), both grown by m."""
    ax, ay, ah, al, aw = a
    bx, by, bh, bl, bw = b
    ca, sa, cb, sb = math.cos(ah), math.sin(ah), math.cos(bh), math.sin(bh)
    c, s = abs(ca * cb + sa * sb), abs(sa * cb - ca * sb)
    hla, hwa, hlb, hwb = 0.5 * al + m, 0.5 * aw + m, 0.5 * bl + m, 0.5 * bw + m
    dx, dy = bx - ax, by - ay
    return not (
        abs(dx * ca + dy * sa) > hla + c * hlb + s * hwb
        or abs(-dx * sa + dy * ca) > hwa + s * hlb + c * hwb
        or abs(dx * cb + dy * sb) > hlb + c * hla + s * hwa
        or abs(-dx * sb + dy * cb) > hwb + s * hla + c * hwa
    )


def step_loop_plan(planner: LaneChangePlanner, t: float, sv: SVPlanState, target: int,
                   messages: list[V2VMessage]) -> NDArray[np.bool_]:
    """The paper's procedure with no vectorisation at all: for each candidate of the
    stable set, for each time sample (eq. 10's integral as a sum), for each TV
    trajectory, one scalar overlap test; a candidate stops at its first overlap; then,
    when no sample overlaps, the look between samples and durations of each TV."""
    cfg, veh = planner.config, planner.vehicle
    s = _loop_setup(planner, t, sv, target, messages)
    vxf, width, taus, t_rel, futures = (
        s[k] for k in ("vxf", "width", "taus", "t_rel", "futures"))
    fx, fy, fh = futures.x.tolist(), futures.y.tolist(), futures.heading.tolist()
    fl, fw = futures.length.tolist(), futures.width.tolist()
    tv_hor = s["tv_hor"].tolist()
    m0 = cfg.safety_margin
    free = np.zeros(taus.size, dtype=bool)
    for i, tau in enumerate(taus.tolist()):
        if not s["stable"][i]:
            continue
        d = cluster_derivatives(sv.boundary(vxf, width), [tau], t_rel, (0, 1))
        x = (d[0][0][0] + sv.x).tolist()
        y = (d[0][1][0] + sv.y).tolist()
        h = np.arctan2(d[1][1][0], d[1][0][0]).tolist()
        horizon = [max(tau + cfg.horizon_extra, e) for e in tv_hor]
        last = max(horizon)
        collides = False
        for k, tk in enumerate(t_rel.tolist()):  # eq. 10: over the horizon, sample by sample
            if tk > last:
                break
            sv_pose = (x[k], y[k], h[k], veh.length, veh.width)
            for j in range(futures.n_hypotheses):  # every TV trajectory at this sample
                if tk > horizon[j]:
                    continue
                if _overlap_scalar(sv_pose, (fx[j][k], fy[j][k], fh[j][k], fl[j], fw[j]), m0):
                    collides = True
                    break
            if collides:
                break
        if not collides:
            collides = any(_cells_hit(planner, sv, s, tau, hyps) for hyps in s["vehicles"])
        free[i] = not collides
    return free


def _case(label: str, sit: Situation, repeats: int, loop_repeats: int,
          step_loop: bool = False) -> dict[str, Any]:
    planner, t, sv, target, messages, occupant = sit
    plan = planner.plan(t, sv, target, messages, occupant)
    vec = median_time(lambda: planner.plan(t, sv, target, messages, occupant), repeats)
    vec_cpu = median_time(
        lambda: planner.plan(t, sv, target, messages, occupant), repeats, clock=time.process_time
    )
    no_maps = LaneChangePlanner(planner.vehicle, planner.road, planner.config, use_maps=False)
    direct = median_time(lambda: no_maps.plan(t, sv, target, messages, occupant), repeats)
    loop_free: list[NDArray[np.bool_]] = []

    def loop() -> None:
        loop_free.append(loop_plan(planner, t, sv, target, messages))

    loop_s = median_time(loop, loop_repeats, warmup=0)
    step_s = math.nan
    if step_loop:
        step_free: list[NDArray[np.bool_]] = []
        step_s = median_time(
            lambda: step_free.append(step_loop_plan(planner, t, sv, target, messages)), 1,
            warmup=0)
        if not np.array_equal(step_free[-1], loop_free[-1]):
            loop_free.append(~loop_free[-1])  # a disagreement shows as sets_agree = 0
    # the plan's grid may hold tau_min itself; compare on the planner's own grid
    on_grid = np.isin(np.round(plan.taus, 9), np.round(planner.grid, 9))
    agree = bool(np.array_equal(plan.collision_free[on_grid], loop_free[-1]))
    n_h = plan.futures.n_hypotheses if plan.futures is not None else 0
    return {
        "case": label,
        "plan_ms": vec * 1e3,
        "cpu_ms": vec_cpu * 1e3,
        "no_maps_ms": direct * 1e3,
        "loop_ms": loop_s * 1e3,
        "ratio": loop_s / vec,
        "step_loop_ms": step_s * 1e3,
        "step_ratio": step_s / vec,
        "candidates": float(plan.stable.sum()),
        "tv_trajectories": float(n_h),
        "sets_agree": 1.0 if agree else 0.0,
    }


def measure(args: argparse.Namespace) -> dict[str, Any]:
    start = time.perf_counter()
    rows = [_case(label, paper_situation(name), args.repeats, args.loop_repeats,
                  step_loop=not args.no_step_loop)
            for label, name in PAPER_CASES]
    rows.append(_case("dense: 20 TVs, 5 C2", dense_situation(), args.repeats,
                      args.loop_repeats))
    paper = rows[:3]
    dense = rows[3]
    paper_ms = float(np.median([r["plan_ms"] for r in paper]))
    paper_loop_ms = float(np.median([r["loop_ms"] for r in paper]))
    ratios = {
        "paper_median_ms": paper_ms,
        "paper_max_ms": float(max(r["plan_ms"] for r in paper)),
        "dense_ms": dense["plan_ms"],
        "paper_loop_over_plan": paper_loop_ms / paper_ms,
        "dense_loop_over_plan": dense["ratio"],
        # each case's loop over the same case's plan, then the median (a median of
        # loops over a median of plans would pair one case's loop with another's plan)
        "paper_step_loop_over_plan": float(np.median([r["step_ratio"] for r in paper])),
    }
    targets = {
        "paper_median_ms": f"< {TARGETS['paper_ms']:g} ms",
        "paper_max_ms": f"< {TARGETS['paper_ms']:g} ms",
        "dense_ms": f"< {TARGETS['dense_ms']:g} ms",
        "paper_loop_over_plan": f">= {TARGETS['ratio']:g}x",
        "dense_loop_over_plan": f">= {TARGETS['ratio']:g}x",
        "paper_step_loop_over_plan": f">= {TARGETS['ratio']:g}x",
    }
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    notes = [
        f"plan: median wall time of {args.repeats} plan() calls after one warm-up; "
        f"cpu_ms: the same as process CPU time; no_maps_ms: tau_min from the envelope in "
        f"every call instead of the per-mode maps (built once, in the warm-up)",
        f"loop: one Python loop per candidate tau of the stable set and per TV trajectory, "
        f"each pair's test over time in one numpy call (median of {args.loop_repeats}); "
        f"step_loop: no vectorisation, for each candidate, each time sample, each TV "
        f"trajectory a scalar test (paper cases only; 1 run); both take the planner's "
        f"stable set, prediction, grid and horizons, and call the planner's compiled look "
        f"between samples and durations once per candidate and TV",
        f"1-minute load average at the end: {load:.2f} on {os.cpu_count()} cores",
        "sets_agree = 1: the loop and the planner found the same collision-free set",
        f"wall time of the whole bench {time.perf_counter() - start:.1f} s",
    ]
    return {"title": "planner: planning time (ms), plan() vs a loop per candidate",
            "rows": rows, "ratios": ratios, "targets": targets, "notes": notes}
