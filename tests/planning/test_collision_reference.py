"""The planner's collision-free sets against an independent reference.

The reference knows nothing of the compiled check: every rectangle is a shapely
polygon (its corners computed here), time runs on a 1 ms grid, and a C2 TV takes
every duration of its stable cluster on a 1 ms grid from its tau_min, which comes
from a bisection of the envelope at the TV's own speed with 2048 samples (the
converged value, not the planner's map). Only the prediction model (C1 constant
acceleration, C3 broadcasts, the C2 cluster's start and target) and the horizons
are shared: they define what "collision-free" means.

Checked: no tau the planner accepts overlaps anything (sound), and each bound of
its collision-free set lies within one tau step of the reference's (tight): the
candidate two steps outside a bound is rejected by the reference too.

The random dense situations: 4 by default; the full 200 with COSIM_REFERENCE_FULL=1
(about 8 minutes), which also judges every accepted tau of the dense scenes (by
default every 4th and the ends of each interval).
"""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np
import pytest

shapely = pytest.importorskip("shapely")

from cosim.bench.planner import dense_situation, paper_situation  # noqa: E402
from cosim.params import PlannerConfig, RoadParams, VehicleParams, kmh  # noqa: E402
from cosim.planning.envelope import envelope_margin  # noqa: E402
from cosim.planning.planner import LaneChangePlanner, SVPlanState  # noqa: E402
from cosim.planning.prediction import (  # noqa: E402
    C2Options,
    c2_lanes,
    category,
    constant_acceleration,
    predict,
)
from cosim.planning.trajectory import BoundaryConditions, cluster_derivatives  # noqa: E402
from cosim.traffic.v2v import LateralMotion, V2VMessage  # noqa: E402

DT = 0.001  # s, the reference's time step
COARSE = 10  # steps of DT per sample of the first, pruning pass
TAU_STEP = 0.001  # s, the reference's step over a C2 TV's durations
STRIDE = 20  # steps of TAU_STEP per duration of the pruning pass
MID_STEPS, MID_STRIDE = 2, 4  # the second pass: every 2 ms and 4 ms of duration
CHUNK = 20000  # points of the first pass refined at once
FULL = bool(os.environ.get("COSIM_REFERENCE_FULL"))
# seed 98: an overlap in the last half step before a pair's horizon, when the next sample
# lies past it (found by the full run; the last sample's cell now reaches the horizon)
SEEDS = range(200) if FULL else (0, 1, 2, 98)
# the dense scenes' accepted taus judged: all (full), else every 4th and both ends of
# every interval
EVERY = 1 if FULL else 4


def _polygons(x: np.ndarray, y: np.ndarray, h: np.ndarray, length: float,
              width: float) -> np.ndarray:
    """shapely polygons of rectangles centred at (x, y), turned by h."""
    c, s = np.cos(h), np.sin(h)
    pts = []
    for u, v in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        lx, ly = 0.5 * u * length, 0.5 * v * width
        pts.append(np.stack([x + c * lx - s * ly, y + s * lx + c * ly], axis=-1))
    return shapely.polygons(np.stack(pts, axis=-2))


def _touch(sx, sy, sh, sl, sw, tx, ty, th, tl, tw) -> bool:  # noqa: ANN001
    """Any of the paired rectangles overlap (touching counts), by shapely."""
    if np.size(sx) == 0:
        return False
    return bool(shapely.intersects(_polygons(sx, sy, sh, sl, sw),
                                   _polygons(tx, ty, th, tl, tw)).any())


def _converged_tau_min(v0: np.ndarray, vxf: np.ndarray, width: np.ndarray, mu: float,
                       vehicle: VehicleParams, tau_max: float) -> np.ndarray:
    """s, tau_min of each C2 TV, bisection of the envelope sampled at 1024 instants (within
    0.05 ms of the converged value), to 1e-5 s (nan: none up to tau_max)."""
    lo, hi = np.full(v0.size, 1.0), np.full(v0.size, tau_max)

    def stable(tau: np.ndarray) -> np.ndarray:
        return envelope_margin(BoundaryConditions(v0, vxf, width), tau, mu, vehicle,
                               n_s=1024) <= 1.0

    ok_hi = stable(hi)
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        ok = stable(mid)
        hi, lo = np.where(ok, mid, hi), np.where(ok, lo, mid)
    return np.where(ok_hi, lo, np.nan)


class Reference:
    """The TVs of one planning situation as the reference sees them."""

    def __init__(self, planner: LaneChangePlanner, t: float, sv: SVPlanState, target: int,
                 messages: list[V2VMessage]) -> None:
        cfg, road, veh = planner.config, planner.road, planner.vehicle
        self.planner, self.sv, self.cfg, self.veh = planner, sv, cfg, veh
        self.vxf = road.target_speed(sv.lane, target)
        self.width = road.lane_center(target) - sv.y
        grid, follow = planner._horizon(t, 0.0, sv.x, sv.vx, self.vxf, target, messages)
        self.t = np.arange(0.0, grid[-1] + 0.5 * DT, DT)
        self.rows: list[tuple] = []  # (x, y, h, length, width, horizon)
        self.clusters: list[tuple] = []  # (v0, vxf, W, x0, y0, taus, length, width, follow)
        c2 = []
        for j, m in enumerate(messages):
            lanes = c2_lanes(m, road) if category(m) == "C2" else None
            if lanes is not None and abs(m.lateral_speed) < 1e-12:
                x0, v0 = (a[0] for a in constant_acceleration([m], t))
                c2.append((j, m, v0, road.target_speed(*lanes),
                           road.lane_center(lanes[1]) - m.y, x0))
                continue
            f = predict([m], t, self.t, road, veh, planner.grid,
                        C2Options(cfg.envelope, cfg.safety_factor))
            for h in range(f.n_hypotheses):
                end = f.t_end[h] - t if np.isfinite(f.t_end[h]) else -np.inf
                self.rows.append((f.x[h], f.y[h], f.heading[h], f.length[h], f.width[h],
                                  max(end + cfg.horizon_extra, follow[j])))
        if c2:
            v0, vxf, w = (np.array([c[k] for c in c2]) for k in (2, 3, 4))
            tmin = _converged_tau_min(v0, vxf, w, road.mu, veh, cfg.tau_max)
            for (j, m, v0_, vxf_, w_, x0), tau_min in zip(c2, tmin, strict=True):
                if not np.isfinite(tau_min):  # no stable lane change: it keeps its lane
                    f = predict([replace(m, intention=0)], t, self.t, road, veh, planner.grid)
                    self.rows.append((f.x[0], f.y[0], f.heading[0], m.length, m.width,
                                      follow[j]))
                    continue
                taus = np.append(np.arange(tau_min, cfg.tau_max - 0.5 * TAU_STEP, TAU_STEP),
                                 cfg.tau_max)
                self.clusters.append((v0_, vxf_, w_, x0, m.y, taus, m.length, m.width,
                                      follow[j], self._coarse(v0_, vxf_, w_, x0, m.y, taus)))

    def collides(self, tau: float) -> bool:
        """The candidate of duration tau overlaps some TV trajectory (grown by the
        planner's safety margin) within the horizons."""
        sv, cfg, m = self.sv, self.cfg, self.cfg.safety_margin
        d = cluster_derivatives(BoundaryConditions(sv.vx, self.vxf, self.width, ax0=sv.ax,
                                                   vy0=sv.vy, ay0=sv.ay), [tau], self.t, (0, 1))
        sx, sy = d[0][0][0] + sv.x, d[0][1][0] + sv.y
        sh = np.arctan2(d[1][1][0], d[1][0][0])
        sl, sw = self.veh.length + 2 * m, self.veh.width + 2 * m
        for x, y, h, tl, tw, hor in self.rows:
            k = self.t <= max(tau + cfg.horizon_extra, hor) + 1e-9  # (the grid's rounding)
            near = k & _boxes_meet(sx, sy, sh, sl, sw, x, y, h, tl + 2 * m, tw + 2 * m, 0.0)
            if _touch(sx[near], sy[near], sh[near], sl, sw, x[near], y[near], h[near],
                      tl + 2 * m, tw + 2 * m):
                return True
        for v0, vxf, w, x0, y0, taus, tl, tw, follow, coarse in self.clusters:
            if self._cluster_collides(tau, sx, sy, sh, sl, sw, v0, vxf, w, x0, y0, taus,
                                      tl + 2 * m, tw + 2 * m, follow, coarse):
                return True
        return False

    def _coarse(self, v0, vxf, w, x0, y0, taus):  # noqa: ANN001, ANN202
        """A cluster on the 10 ms x 20 ms grid: centres, |cos|, |sin| of the heading."""
        d = cluster_derivatives(BoundaryConditions(v0, vxf, w), taus[_coarse_index(taus.size)],
                                self.t[::COARSE], (0, 1))
        h = np.arctan2(d[1][1], d[1][0])
        return d[0][0] + x0, d[0][1] + y0, np.abs(np.cos(h)), np.abs(np.sin(h))

    def _cluster_collides(self, tau, sx, sy, sh, sl, sw, v0, vxf, w, x0, y0, taus, tl, tw,  # noqa: ANN001, PLR0913
                          follow, coarse) -> bool:
        """Any of the cluster's durations: first on a 10 ms x 20 ms grid, then on a 2 ms x
        4 ms grid around every point that came near, axis-aligned boxes widened by how far
        a corner can move between the points of each grid; then exactly at 1 ms x 1 ms
        around every point still near (in pieces)."""
        extra = self.cfg.horizon_extra
        kc = np.arange(0, self.t.size, COARSE)
        tc = self.t[kc]
        ci = _coarse_index(taus.size)
        tau_c = taus[ci]
        cx, cy, cc, cs = coarse

        def slack(steps: int, stride: int) -> float:
            """m, a corner's motion within half a cell of `steps` x DT and `stride` x
            TAU_STEP: relative motion (< 20 m/s) and with the duration (< 1.1 W / tau),
            turning (< 0.5 rad/s, 0.2 rad/s per s of duration) at 3 m from the centre."""
            ht, hd = steps * DT / 2, stride * TAU_STEP / 2
            return 20.0 * ht + 1.1 * abs(w) / taus[0] * hd + 3.0 * (0.5 * ht + 0.2 * hd) + 0.02

        # (a cell reaches half a step past its point, in time and in duration)
        hor = np.maximum(np.maximum(tau, tau_c) + extra, follow) + (
            COARSE * DT / 2 + STRIDE * TAU_STEP / 2 + 1e-9)
        ac, as_ = np.abs(np.cos(sh[kc])), np.abs(np.sin(sh[kc]))
        ahx, ahy = 0.5 * (sl * ac + sw * as_), 0.5 * (sl * as_ + sw * ac)
        wide = 2 * slack(COARSE, STRIDE)
        near = ((np.abs(cx - sx[kc]) <= ahx + 0.5 * (tl * cc + tw * cs) + wide)
                & (np.abs(cy - sy[kc]) <= ahy + 0.5 * (tl * cs + tw * cc) + wide)
                & (tc[None, :] <= hor[:, None]))
        ii, kk = np.nonzero(near)
        ti0, ui0 = kc[kk], ci[ii]
        mid = 2 * slack(MID_STEPS, MID_STRIDE)
        keep_t, keep_u, keep_d = [np.zeros(0, int)], [np.zeros(0, int)], [np.zeros(0)]
        for lo in range(0, ti0.size, CHUNK):  # (in pieces: a long horizon holds millions)
            ti, ui = self._around(ti0[lo:lo + CHUNK], ui0[lo:lo + CHUNK], COARSE, STRIDE,
                                  MID_STEPS, MID_STRIDE, taus.size)
            tx, ty, th = _cluster_poses(v0, vxf, w, x0, y0, taus[ui], self.t[ti])
            depth = _box_depth(sx[ti], sy[ti], sh[ti], sl, sw, tx, ty, th, tl, tw) + mid
            near = depth >= 0.0
            keep_t.append(ti[near])
            keep_u.append(ui[near])
            keep_d.append(depth[near])
        order = np.argsort(-np.concatenate(keep_d), kind="stable")  # the deepest first
        ti1, ui1 = np.concatenate(keep_t)[order], np.concatenate(keep_u)[order]
        for lo in range(0, ti1.size, CHUNK // 10):
            ti, ui = self._around(ti1[lo:lo + CHUNK // 10], ui1[lo:lo + CHUNK // 10],
                                  MID_STEPS, MID_STRIDE, 1, 1, taus.size)
            tt, fine = self.t[ti], taus[ui]
            ok = tt <= np.maximum(np.maximum(tau, fine) + extra, follow) + 1e-9
            ti, tt, fine = ti[ok], tt[ok], fine[ok]
            tx, ty, th = _cluster_poses(v0, vxf, w, x0, y0, fine, tt)
            meet = _box_depth(sx[ti], sy[ti], sh[ti], sl, sw, tx, ty, th, tl, tw) >= 0.0
            ti, tx, ty, th = ti[meet], tx[meet], ty[meet], th[meet]
            if _touch(sx[ti], sy[ti], sh[ti], sl, sw, tx, ty, th, tl, tw):
                return True
        return False

    def _around(self, ti, ui, steps, stride, sub_steps, sub_stride, n_tau):  # noqa: ANN001, ANN202, PLR0913
        """(time, duration) indices of the points of a finer grid (every sub_steps x DT,
        sub_stride x TAU_STEP) covering the cells of the given points (half of steps x DT
        and stride x TAU_STEP on each side), each finer point covering half its own."""
        ht, hd = steps // 2, stride // 2
        dk = np.arange(-ht + sub_steps // 2, ht + 1, sub_steps) if sub_steps > 1 else np.arange(
            -ht, ht + 1)
        di = np.arange(-hd + sub_stride // 2, hd + 1, sub_stride) if sub_stride > 1 else np.arange(
            -hd, hd + 1)
        t_i = np.clip(ti[:, None, None] + dk[None, None, :], 0, self.t.size - 1)
        u_i = np.clip(ui[:, None, None] + di[None, :, None], 0, n_tau - 1)
        t_i, u_i = np.broadcast_arrays(t_i, u_i)
        return t_i.ravel(), u_i.ravel()


def _cluster_poses(v0, vxf, w, x0, y0, taus, tt):  # noqa: ANN001, ANN202
    """(x, y, heading) of the cluster's lane change of duration taus[i] at time tt[i]."""
    dd = cluster_derivatives(BoundaryConditions(v0, vxf, w), taus[:, None], tt[:, None], (0, 1))
    return (dd[0][0][:, 0] + x0, dd[0][1][:, 0] + y0,
            np.arctan2(dd[1][1][:, 0], dd[1][0][:, 0]))


def _coarse_index(n: int) -> np.ndarray:
    """Every STRIDE-th duration, and the last (tau_max)."""
    return np.unique(np.append(np.arange(0, n, STRIDE), n - 1))


def _box_depth(ax, ay, ah, al, aw, bx, by, bh, bl, bw):  # noqa: ANN001, ANN202
    """m, how far the axis-aligned boxes of the rectangles overlap (the lesser of the two
    axes; negative: the gap between them)."""
    def half(h, length, width):  # noqa: ANN001, ANN202
        c, s = np.abs(np.cos(h)), np.abs(np.sin(h))
        return 0.5 * (length * c + width * s), 0.5 * (length * s + width * c)

    (ahx, ahy), (bhx, bhy) = half(ah, al, aw), half(bh, bl, bw)
    return np.minimum(ahx + bhx - np.abs(bx - ax), ahy + bhy - np.abs(by - ay))


def _boxes_meet(ax, ay, ah, al, aw, bx, by, bh, bl, bw, slack):  # noqa: ANN001, ANN202
    """The axis-aligned boxes of the rectangles, each widened by slack, overlap."""
    return _box_depth(ax, ay, ah, al, aw, bx, by, bh, bl, bw) + 2 * slack >= 0.0


def _check(planner: LaneChangePlanner, t: float, sv: SVPlanState, target: int,
           messages: list[V2VMessage], occupant: float, every: int = 1) -> tuple[list, int]:
    """Sound and tight: asserts; returns the planner's intervals and the number of
    taus the reference judged."""
    plan = planner.plan(t, sv, target, messages, occupant)
    ref = Reference(planner, t, sv, target, messages)
    taus, free, stable = plan.taus, plan.collision_free, plan.stable
    judged, seen = 0, 0
    ends = {round(float(v), 9) for span in plan.collision_free_intervals for v in span}
    for tau in taus[free]:
        seen += 1
        if every > 1 and seen % every and round(float(tau), 9) not in ends:
            continue
        assert not ref.collides(float(tau)), f"accepted tau {tau:.3f} s overlaps a TV"
        judged += 1
    step = planner.config.tau_step
    for lo, hi in plan.collision_free_intervals:
        for out in (lo - 2 * step, hi + 2 * step):
            i = int(np.argmin(np.abs(taus - out)))
            if abs(taus[i] - out) < 1e-6 and stable[i] and not free[i]:
                assert ref.collides(float(taus[i])), (
                    f"bound {lo:.3f}-{hi:.3f} s: the reference accepts {taus[i]:.3f} s")
                judged += 1
    return plan.collision_free_intervals, judged


@pytest.mark.parametrize("step", [0.05, 0.1, 0.25])
@pytest.mark.parametrize("case", ["paper_case1_overtaking", "paper_case2_tv_lane_change",
                                  "paper_case3_lane_exchange"])
def test_paper_cases_against_the_reference(case: str, step: float) -> None:
    planner, t, sv, target, messages, occupant = paper_situation(case)
    planner = LaneChangePlanner(planner.vehicle, planner.road,
                                replace(planner.config, tau_step=step))
    intervals, judged = _check(planner, t, sv, target, messages, occupant)
    assert intervals and judged > 0


def test_dense_bench_situation_against_the_reference() -> None:
    intervals, judged = _check(*dense_situation(), every=EVERY)
    assert judged > 0


def random_situation(seed: int) -> tuple:
    """A dense scene: 12-18 TVs on three lanes within -100..+120 m of the SV, about a
    third announcing a lane change (C2), some broadcasting one under way (C3)."""
    road = RoadParams(mu=float(np.random.default_rng(seed).choice([0.5, 0.8, 1.0])))
    rng = np.random.default_rng(1000 + seed)
    sv_lane = int(rng.integers(0, 3))
    target = sv_lane + 1 if sv_lane == 0 else sv_lane - 1 if sv_lane == 2 else int(
        rng.choice([0, 2]))
    sv = SVPlanState(500.0, road.lane_center(sv_lane), 0.0, kmh(float(rng.uniform(70, 120))),
                     0.0, 0.0, 0.0, sv_lane)
    messages = []
    for lane in range(3):
        slots = np.sort(rng.choice(np.arange(-100.0, 120.0, 16.0), size=int(rng.integers(4, 7)),
                                   replace=False))
        if lane == sv_lane:
            slots = slots[np.abs(slots) > 10.0]
        lo, hi = road.speed_bands[lane]
        for gap in slots:
            # (the first TV broadcasts its lane change, the second announces one: every
            # scene has all three categories)
            kind = ("C3", "C2")[len(messages)] if len(messages) < 2 else rng.choice(
                ["C1", "C2", "C3"], p=[0.55, 0.3, 0.15])
            y, speed = road.lane_center(lane), float(rng.uniform(lo, hi))
            intention = int(rng.choice([d for d in (-1, 1) if 0 <= lane + d <= 2]))
            motion = None
            if kind == "C3":
                started = float(rng.uniform(0.0, 2.0))
                motion = LateralMotion(-started, float(rng.uniform(3.0, 7.0)),
                                       sv.x + float(gap) - speed * started, y, speed, speed,
                                       intention * road.lane_width)
            messages.append(V2VMessage(
                f"tv{len(messages)}", 0.0, sv.x + float(gap), y, 0.0, speed,
                float(rng.uniform(-0.5, 0.3)), lane, 0.0, 4.32, 1.8,
                intention if kind != "C1" else 0, motion))
    planner = LaneChangePlanner(VehicleParams(), road, PlannerConfig(tau_step=0.05))
    return planner, 0.0, sv, target, messages, float(rng.uniform(0, 1))


@pytest.mark.parametrize("seed", SEEDS)
def test_random_dense_situations_against_the_reference(seed: int) -> None:
    planner, t, sv, target, messages, occupant = random_situation(seed)
    assert {category(m) for m in messages} == {"C1", "C2", "C3"}
    _check(planner, t, sv, target, messages, occupant, every=EVERY)
