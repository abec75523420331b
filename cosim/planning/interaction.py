"""How the SV's new follower in the target lane reacts to the SV (beyond the paper).

The paper's prediction (S1-S3) lets every TV keep its motion. SUMO's vehicles do
not: a vehicle does not see the SV until the SV is in its lane (its centre across the
line, SUMO_NOTES.md; with SUMO's continuous lane change its side already, the shadow
lane: `check_follower`), then treats it as its leader and brakes for it with its
car-following model. This module predicts that follower and bounds what the
manoeuvre may ask of it.

Car-following models (SI units, arrays broadcast; no Python loop over vehicles):

- Krauss (SUMO's default, `MSCFModel_Krauss` / `MSCFModel::maximumSafeFollowSpeed`,
  Krauss 1998): the safe speed v_safe is the largest speed from which the follower,
  reacting after its headway tau and braking at its `decel` b, stops within the gap
  plus the leader's own braking distance at the leader's decel b_l:
  v tau + v^2 / (2 b) = g + v_l^2 / (2 b_l), so
  v_safe = -b tau + sqrt((b tau)^2 + 2 b (g + v_l^2 / (2 b_l))).
  Next speed: min(v_safe, v + a dt, v_max) (no dawdling: sigma only slows the
  follower further, which opens the gap). Where v_safe asks more than b, SUMO
  (`MSCFModel::maximumSafeFollowSpeed`) brakes instead at what avoiding the collision
  needs, times 1.2 (EMERGENCY_DECEL_AMPLIFIER), but at least b and at most what v_safe
  asked: the needed deceleration is v^2 / (2 (g + v_l^2 / (2 b_l))) if that is at most
  b_l (it stops behind the braking leader), else (v^2 - v_l^2) / (2 g) (it matches the
  leader's speed within the gap); all within the emergency decel. A cut-in inside the
  secure gap therefore costs the follower at least b at once, often more.
- IDM (Treiber, Hennecke, Helbing 2000), the model MOBIL's safety criterion is
  written in: a = a_max (1 - (v / v0)^delta - (s* / g)^2),
  s* = s0 + v T + v dv / (2 sqrt(a_max b)).

Safety bound (MOBIL, Kesting, Treiber, Helbing 2007, "General lane-changing model
MOBIL for car-following models", TRR 1999, eq. 2): after the SV is in its lane the
new follower's deceleration must not exceed b_safe. Default 4.5 m/s^2: what SUMO's
own lane-change model LC2013 asks of a blocking follower at most, its maxDecel x
HELP_DECEL_FACTOR (4.5 m/s^2 x 1.0 for a passenger car,
`MSLCM_LC2013::informFollower`), so that our SV asks no more of SUMO's traffic than
SUMO's own driver does. MOBIL's paper uses 4 m/s^2 ("well below the maximum possible
deceleration of about 9 m/s^2"); below SUMO's decel (4.5) that would forbid any
entry inside the follower's Krauss secure gap (module docstring: Krauss then brakes
at decel at least).
The defaults of `FollowerModel` are SUMO's passenger-car type (accel 2.6, decel 4.5,
emergencyDecel 9.0 m/s^2, tau 1.0 s, minGap 2.5 m).

`predict_follower` runs the follower's recursion over a time grid, compiled (numba):
before the SV enters the lane the follower keeps its speed (it cannot see the SV),
afterwards it follows the SV's rear by the model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.compiled import njit, register_warm_up
from cosim.errors import InputError
from cosim.planning.trajectory import LaneChangeTrajectory

Array = NDArray[np.float64]

MODELS = ("krauss", "idm")
B_SAFE = 4.5  # m/s^2, safe braking limit for the new follower (SUMO LC2013's help decel)


@dataclass(frozen=True)
class FollowerModel:
    """A TV's car-following model as the SV predicts it (defaults: SUMO's passenger car)."""

    model: str = "krauss"  # "krauss" (SUMO's default) or "idm"
    accel: float = 2.6  # m/s^2, maximum acceleration a
    decel: float = 4.5  # m/s^2, Krauss decel b / IDM comfortable deceleration b
    emergency_decel: float = 9.0  # m/s^2, the hardest the follower can brake
    tau: float = 1.0  # s, Krauss reaction time / IDM desired time headway T
    min_gap: float = 2.5  # m, standstill gap s0 (SUMO minGap)
    max_speed: float = 70.0  # m/s, desired speed v0 (IDM free term) / speed cap
    delta: float = 4.0  # -, IDM acceleration exponent
    leader_decel: float = 4.5  # m/s^2, the decel the follower assumes of its leader (Krauss)
    b_safe: float = B_SAFE  # m/s^2, MOBIL safe-braking limit the manoeuvre may ask
    reaction: float = 0.0  # s, after the SV enters its lane the follower goes on as before
    # this long (SUMO's follower sees the SV at its next step and acts on it the step after)

    def limited(self, decel: float) -> FollowerModel:
        """The same follower, with the manoeuvre asking it no more than `decel` (m/s^2)
        within b_safe."""
        return replace(self, b_safe=min(self.b_safe, decel))

    def wary(self, share: float, gap: float) -> FollowerModel:
        """The same follower asked for `share` of what it may be asked and kept `gap`
        (m) farther from the SV: the entry rule with a margin (a follower just refused)."""
        return replace(self, b_safe=share * self.b_safe, min_gap=self.min_gap + gap)

    def check(self, source: str = "follower model") -> None:
        """Raise InputError naming the first bad field."""
        if self.model not in MODELS:
            raise InputError(source, "model", self.model, f"one of {', '.join(MODELS)}")
        for name in ("accel", "decel", "emergency_decel", "tau", "max_speed", "delta",
                     "leader_decel", "b_safe"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InputError(source, name, value, "a finite number > 0")
        for name in ("min_gap", "reaction"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise InputError(source, name, value, "a finite number >= 0")
        if self.emergency_decel < self.decel:
            raise InputError(source, "emergency_decel", self.emergency_decel,
                             f">= decel = {self.decel:g} m/s^2")


def krauss_safe_speed(gap: ArrayLike, leader_speed: ArrayLike, m: FollowerModel) -> Array:
    """m/s, Krauss's v_safe (module docstring) for a bumper-to-bumper gap (m) beyond the
    follower's min_gap; 0 where that gap is used up."""
    g = np.maximum(np.asarray(gap, dtype=float) - m.min_gap, 0.0)
    vl = np.maximum(np.asarray(leader_speed, dtype=float), 0.0)
    bt = m.decel * m.tau
    return -bt + np.sqrt(bt * bt + 2.0 * m.decel * (g + vl * vl / (2.0 * m.leader_decel)))


def secure_gap(follower_speed: ArrayLike, leader_speed: ArrayLike, m: FollowerModel) -> Array:
    """m, the smallest bumper-to-bumper gap at which a follower at `follower_speed` is
    Krauss-safe behind a leader at `leader_speed` (v_safe >= v): min_gap +
    v tau + v^2 / (2 b) - v_l^2 / (2 b_l), at least min_gap (SUMO's getSecureGap)."""
    v = np.maximum(np.asarray(follower_speed, dtype=float), 0.0)
    vl = np.maximum(np.asarray(leader_speed, dtype=float), 0.0)
    need = v * m.tau + v * v / (2.0 * m.decel) - vl * vl / (2.0 * m.leader_decel)
    return m.min_gap + np.maximum(need, 0.0)


def follower_accel(gap: ArrayLike, speed: ArrayLike, leader_speed: ArrayLike,
                   m: FollowerModel, dt: float) -> Array:
    """m/s^2, the follower's acceleration over the next step dt (s) behind a leader at
    `gap` (bumper to bumper, m; inf: none) by its model (module docstring), within
    [-emergency_decel, accel]."""
    g, v, vl = np.broadcast_arrays(np.asarray(gap, dtype=float),
                                   np.asarray(speed, dtype=float),
                                   np.asarray(leader_speed, dtype=float))
    out = np.empty(g.shape)
    _accel_array(MODELS.index(m.model), _params(m), np.ravel(g), np.ravel(v),
                 np.ravel(np.nan_to_num(vl)), float(dt), out.reshape(-1))
    return out


def accepted_gap(follower_speed: ArrayLike, sv_speed: ArrayLike, m: FollowerModel,
                 dt: float = 0.05, longest: float = 400.0) -> Array:
    """m, the shortest bumper gap behind the SV at which the follower's entry
    deceleration (`entry_decel`) is at most b_safe (bisection on the model itself, to
    1 cm; entry_decel does not grow with the gap). Compiled: the gap policy asks this
    every step."""
    v, vs = np.broadcast_arrays(np.asarray(follower_speed, dtype=float),
                                np.asarray(sv_speed, dtype=float))
    out = np.empty(v.shape)
    _accepted_gap_array(MODELS.index(m.model), _params(m), np.ravel(v),
                        np.ravel(np.nan_to_num(vs)), float(dt), m.b_safe + 1e-9,
                        float(longest), out.reshape(-1))
    return out


def entry_decel(gap: ArrayLike, follower_speed: ArrayLike, sv_speed: ArrayLike,
                m: FollowerModel, dt: float) -> Array:
    """m/s^2 (>= 0), what the SV's entry asks of the new follower at once: minus its
    acceleration behind the SV at `gap` (the MOBIL safety test is entry_decel <=
    b_safe). Vectorised over candidate gaps / times of entry."""
    return np.maximum(-follower_accel(gap, follower_speed, sv_speed, m, dt), 0.0)


def _params(m: FollowerModel) -> Array:
    """The model's constants for the compiled functions (order of `_accel_core`)."""
    return np.array([m.accel, m.decel, m.emergency_decel, m.tau, m.min_gap, m.max_speed,
                     m.delta, m.leader_decel])


EMERGENCY_DECEL_AMPLIFIER = 1.2  # -, SUMO's factor on the deceleration a collision needs


@njit
def _accel_core(kind: int, p: Array, g: float, v: float, vl: float, dt: float) -> float:
    """m/s^2, the follower's acceleration (kind 0 Krauss as SUMO applies it, 1 IDM) at
    speed v behind a leader at bumper gap g (inf: none) driving vl (module docstring)."""
    accel, decel, emerg, tau, s0 = p[0], p[1], p[2], p[3], p[4]
    vmax, delta, bl = p[5], p[6], p[7]
    v = max(v, 0.0)
    vl = max(vl, 0.0)
    if kind == 0:
        vn = min(v + accel * dt, vmax)
        if math.isfinite(g):
            gg = max(g - s0, 0.0)
            bt = decel * tau
            vsafe = -bt + math.sqrt(bt * bt + 2.0 * decel * (gg + vl * vl / (2.0 * bl)))
            asked = (v - vsafe) / dt
            if asked > decel:  # SUMO's emergency branch: what avoiding the collision needs
                room = gg + 0.5 * vl * vl / bl
                b1 = 0.5 * v * v / room if room > 0.0 else emerg
                if b1 <= bl:
                    need = b1
                elif gg > 0.0:
                    need = 0.5 * (v * v - vl * vl) / gg
                else:
                    need = emerg
                vsafe = v - min(max(EMERGENCY_DECEL_AMPLIFIER * need, decel), asked) * dt
            vn = min(vn, vsafe)
        a = (max(vn, 0.0) - v) / dt
    else:
        a = accel * (1.0 - (v / vmax) ** delta)
        if math.isfinite(g):
            s_star = s0 + max(v * tau + v * (v - vl) / (2.0 * math.sqrt(accel * decel)), 0.0)
            a -= accel * (s_star / max(g, 0.1)) ** 2
    return min(max(a, -emerg), accel)


@njit
def _accel_array(kind: int, p: Array, g: Array, v: Array, vl: Array, dt: float,
                 out: Array) -> None:
    """`_accel_core` elementwise into out."""
    for i in range(g.size):
        out[i] = _accel_core(kind, p, g[i], v[i], vl[i], dt)


@njit
def _accepted_gap_array(kind: int, p: Array, v: Array, vs: Array, dt: float,
                        threshold: float, longest: float, out: Array) -> None:
    """`accepted_gap` elementwise into out: 16 bisection steps on [0, longest]
    (400 m / 2^16 < 1 cm), a gap accepted when -accel <= threshold (NaN: not)."""
    for i in range(v.size):
        lo = 0.0
        hi = longest
        for _ in range(16):
            mid = 0.5 * (lo + hi)
            if -_accel_core(kind, p, mid, v[i], vs[i], dt) <= threshold:
                hi = mid
            else:
                lo = mid
        out[i] = hi


@njit
def _follow_core(kind: int, p: Array, t: Array, sv_rear: Array, sv_speed: Array,
                 t_enter: float, x0: float, v0: float, x: Array, v: Array, a: Array,
                 a_before: float, reaction: float) -> None:
    """The follower's Euler recursion on the grid t (SUMO's update: v then x), into
    x (front bumper, m), v (m/s), a (m/s^2, applied over the step that follows);
    before t_enter + reaction it drives at a_before (down to a standstill)."""
    x[0], v[0] = x0, v0
    n = t.size
    for k in range(n - 1):
        dt = t[k + 1] - t[k]
        if t[k] >= t_enter + reaction - 1e-9:
            ak = _accel_core(kind, p, sv_rear[k] - x[k], v[k], sv_speed[k], dt)
        else:
            ak = a_before  # it cannot see the SV yet
        a[k] = ak
        vn = max(v[k] + ak * dt, 0.0)
        v[k + 1] = vn
        x[k + 1] = x[k] + vn * dt
    a[n - 1] = a[n - 2] if n > 1 else 0.0


@dataclass(frozen=True)
class FollowerPrediction:
    """The new follower on the time grid `t` (s) under its model."""

    t: Array  # s
    x: Array  # m, front bumper global x
    speed: Array  # m/s
    accel: Array  # m/s^2, over the step that follows each time
    max_decel: float  # m/s^2 (>= 0), the largest deceleration from entry on
    min_gap: float  # m, smallest gap follower front -> SV rear from entry on (inf: none)
    entry_gap: float = math.inf  # m, that gap as the SV enters the lane
    needed_decel: float = 0.0  # m/s^2 (>= 0), the largest constant deceleration the
    # follower needs from entry on to stay its min_gap behind the SV at the SV's speed,
    # (v_f - v_sv)^2 / (2 (gap - min_gap)) while closing (inf: closing within min_gap)

    def safe(self, m: FollowerModel) -> bool:
        """The entry rule over the whole prediction: MOBIL's max_decel <= b_safe, the
        needed deceleration within b_safe too, and the follower never closer to the SV
        than its min_gap (SUMO's minGap) from the entry on."""
        return bool(self.max_decel <= m.b_safe + 1e-9
                    and self.needed_decel <= m.b_safe + 1e-9
                    and self.min_gap >= m.min_gap - 1e-6)


def predict_follower(t: ArrayLike, sv_rear_x: ArrayLike, sv_speed: ArrayLike,
                     t_enter: float, follower_front_x: float, follower_speed: float,
                     m: FollowerModel, accel_before: float = 0.0) -> FollowerPrediction:
    """Predict the new follower: it keeps its speed (or its acceleration
    `accel_before`, m/s^2: a TV yielding to the SV, `check_follower`) until the SV
    enters its lane at `t_enter` (s; `check_follower`), then, after its `m.reaction`,
    follows the SV's rear (x of the rear bumper and speed on the grid t) by its model."""
    tt = np.ascontiguousarray(t, dtype=float)
    rear = np.ascontiguousarray(sv_rear_x, dtype=float)
    vs = np.ascontiguousarray(sv_speed, dtype=float)
    if tt.ndim != 1 or tt.size < 2 or rear.shape != tt.shape or vs.shape != tt.shape:
        raise ValueError("t, sv_rear_x and sv_speed must be 1-D arrays of the same length >= 2")
    x, v, a = np.empty_like(tt), np.empty_like(tt), np.empty_like(tt)
    _follow_core(MODELS.index(m.model), _params(m), tt, rear, vs, float(t_enter),
                 float(follower_front_x), float(follower_speed), x, v, a,
                 float(accel_before), float(m.reaction))
    after = tt >= t_enter - 1e-9
    max_decel = float(max(np.max(-a[after], initial=0.0), 0.0))
    gaps = (rear - x)[after]
    if not gaps.size:
        return FollowerPrediction(t=tt, x=x, speed=v, accel=a, max_decel=max_decel,
                                  min_gap=math.inf)
    closing = np.maximum(v[after] - vs[after], 0.0)
    room = gaps - m.min_gap
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(closing > 0.0,
                        np.where(room > 0.0, closing * closing / (2.0 * room), np.inf), 0.0)
    return FollowerPrediction(t=tt, x=x, speed=v, accel=a, max_decel=max_decel,
                              min_gap=float(gaps.min()), entry_gap=float(gaps[0]),
                              needed_decel=float(need.max()))


FOLLOW_AFTER = 3.0  # s, the follower is predicted this long after the manoeuvre ends


@dataclass(frozen=True)
class FollowerCheck:
    """What a planned lane change asks of the new follower in the target lane."""

    follower: int  # index into the TV arrays, -1: none (nothing asked)
    t_enter: float  # s, when the SV enters the target lane (`check_follower`; nan: never)
    prediction: FollowerPrediction | None  # None: no follower
    safe: bool  # MOBIL: max_decel <= b_safe and no contact

    @property
    def max_decel(self) -> float:
        """m/s^2, the follower's largest predicted deceleration (0: none)."""
        return 0.0 if self.prediction is None else self.prediction.max_decel


@dataclass(frozen=True)
class LaneTraffic:
    """The TVs a planned change's new follower is sought among (arrays over TVs)."""

    x: Array  # m, centres at the manoeuvre's start
    speed: Array  # m/s, kept until the SV enters the lane (or braking at `braking`)
    length: Array  # m
    in_target: NDArray[np.bool_]  # the TVs in the target lane
    braking: Array | None = None  # m/s^2 >= 0 per TV: the TVs that yield to the SV go on
    # braking at this rate (down to a standstill) until it is in their lane; None: none

    @classmethod
    def of(cls, x: ArrayLike, speed: ArrayLike, length: ArrayLike, in_target: ArrayLike,
           braking: ArrayLike | None = None) -> LaneTraffic:
        """From lists or arrays."""
        return cls(np.asarray(x, dtype=float), np.asarray(speed, dtype=float),
                   np.asarray(length, dtype=float), np.asarray(in_target, dtype=bool),
                   None if braking is None else np.asarray(braking, dtype=float))


def check_follower(trajectory: LaneChangeTrajectory, sv_length: float, tvs: LaneTraffic,
                   m: FollowerModel, dt: float = 0.05, sv_width: float = 0.0
                   ) -> FollowerCheck:
    """Predict the new follower of a planned lane change (`trajectory`, from its t0):
    among the TVs in the target lane (`tvs`: constant speeds until the SV enters, or
    braking at `tvs.braking` down to a standstill), the nearest one behind the SV when
    it enters that lane: when the side of its body (`sv_width`, m; 0: its centre)
    crosses the lane line, where SUMO's continuous lane change puts a vehicle into the
    lane it moves into as well (its shadow lane) and that lane's follower starts to
    brake for it; it then follows the SV's rear by its model (after its reaction)
    until FOLLOW_AFTER after the manoeuvre ends (`predict_follower`). What it is asked
    is its braking from then on, and the gap it keeps (`FollowerPrediction.safe`)."""
    tr = trajectory
    t = tr.t0 + np.arange(0.0, tr.tau + FOLLOW_AFTER + 0.5 * dt, dt)
    xs, ys = tr.position(t)
    vx, vy = tr.derivative(t, 1)
    edge = max(0.5 * abs(tr.width) - 0.5 * sv_width, 0.0)
    crossed = np.abs(ys - tr.y0) >= edge
    if tr.width == 0.0 or not crossed.any():
        return FollowerCheck(-1, math.nan, None, True)
    k_in = int(np.argmax(crossed))
    t_in = float(t[k_in])
    x = np.asarray(tvs.x, dtype=float)
    v = np.asarray(tvs.speed, dtype=float)
    half = 0.5 * np.asarray(tvs.length, dtype=float)
    b = np.zeros_like(x) if tvs.braking is None else np.asarray(tvs.braking, dtype=float)
    # each TV's travel until the SV enters (a braking one no farther than its stop)
    dt_in = np.where(b > 0.0, np.minimum(t_in - tr.t0, v / np.maximum(b, 1e-9)), t_in - tr.t0)
    moved = (v - 0.5 * b * dt_in) * dt_in
    front_in = x + half + moved  # each TV's front when the SV enters
    rear_in = float(xs[k_in]) - 0.5 * sv_length
    behind = np.asarray(tvs.in_target, dtype=bool) & (x + moved < float(xs[k_in]))
    if not behind.any():
        return FollowerCheck(-1, t_in, None, True)
    gap_in = np.where(behind, rear_in - front_in, np.inf)
    j = int(np.argmin(gap_in))
    speed = np.hypot(vx, vy)
    # its desired speed is what it drives now (SUMO's TVs cruise at their band's speed
    # when free), not the model's cap: a free follower predicted to speed up to the cap
    # would then be predicted to brake for an SV far ahead of it
    m = replace(m, max_speed=min(m.max_speed, max(float(v[j]), 0.1)))
    pred = predict_follower(t, xs - 0.5 * sv_length, speed, t_in, float(x[j] + half[j]),
                            float(v[j]), m, -float(b[j]))
    return FollowerCheck(j, t_in, pred, pred.safe(m))


@register_warm_up
def warm_up() -> None:
    """Compile (or load) the follower recursion for both models."""
    t = np.linspace(0.0, 1.0, 5)
    for model in MODELS:
        m = FollowerModel(model=model)
        predict_follower(t, 50.0 + 20.0 * t, np.full(5, 20.0), 0.0, 0.0, 20.0, m)
        follower_accel(t, t, t, m, 0.05)
        accepted_gap(t, t, m)
