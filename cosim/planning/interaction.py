"""How the SV's new follower in the target lane reacts to the SV (beyond the paper).

The paper's prediction (S1-S3) lets every TV keep its motion. SUMO's vehicles do
not: a vehicle does not see the SV until the SV's centre crosses into its lane
(SUMO_NOTES.md), then treats it as its leader and brakes for it with its
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
  follower further, which opens the gap). SUMO's Euler update takes v_safe at once,
  so a gap that is not Krauss-safe at entry costs the follower (v - v_safe) / dt in
  one step, up to its emergency decel.
- IDM (Treiber, Hennecke, Helbing 2000), the model MOBIL's safety criterion is
  written in: a = a_max (1 - (v / v0)^delta - (s* / g)^2),
  s* = s0 + v T + v dv / (2 sqrt(a_max b)).

Safety bound (MOBIL, Kesting, Treiber, Helbing 2007, "General lane-changing model
MOBIL for car-following models", TRR 1999, eq. 2): after the SV is in its lane the
new follower's deceleration must not exceed b_safe. Default 4.0 m/s^2, MOBIL's own
value ("well below the maximum possible deceleration of about 9 m/s^2"); SUMO's
LC2013 asks a blocking follower for at most its maxDecel x HELP_DECEL_FACTOR
(4.5 m/s^2 x 1.0 for a passenger car, `MSLCM_LC2013::informFollower`).
The defaults of `FollowerModel` are SUMO's passenger-car type (accel 2.6, decel 4.5,
emergencyDecel 9.0 m/s^2, tau 1.0 s, minGap 2.5 m).

`predict_follower` runs the follower's recursion over a time grid, compiled (numba):
before the SV enters the lane the follower keeps its speed (it cannot see the SV),
afterwards it follows the SV's rear by the model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.compiled import njit
from cosim.errors import InputError

Array = NDArray[np.float64]

MODELS = ("krauss", "idm")
B_SAFE = 4.0  # m/s^2, MOBIL's safe braking limit for the new follower (Kesting et al. 2007)


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

    def check(self, source: str = "follower model") -> None:
        """Raise InputError naming the first bad field."""
        if self.model not in MODELS:
            raise InputError(source, "model", self.model, f"one of {', '.join(MODELS)}")
        for name in ("accel", "decel", "emergency_decel", "tau", "max_speed", "delta",
                     "leader_decel", "b_safe"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InputError(source, name, value, "a finite number > 0")
        if not (math.isfinite(self.min_gap) and self.min_gap >= 0.0):
            raise InputError(source, "min_gap", self.min_gap, "a finite number >= 0 m")
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
    `gap` (bumper to bumper, m; inf: none) by its model, within
    [-emergency_decel, accel]."""
    g = np.asarray(gap, dtype=float)
    v = np.maximum(np.asarray(speed, dtype=float), 0.0)
    vl = np.asarray(leader_speed, dtype=float)
    if m.model == "krauss":
        vsafe = np.where(np.isfinite(g), krauss_safe_speed(np.where(np.isfinite(g), g, 0.0),
                                                           np.nan_to_num(vl), m), np.inf)
        v_next = np.minimum(np.minimum(vsafe, v + m.accel * dt), m.max_speed)
        a = (np.maximum(v_next, 0.0) - v) / dt
    else:
        a = idm_accel(g, v, vl, m)
    return np.clip(a, -m.emergency_decel, m.accel)


def idm_accel(gap: ArrayLike, speed: ArrayLike, leader_speed: ArrayLike,
              m: FollowerModel) -> Array:
    """m/s^2, IDM acceleration (module docstring); gap inf: free road."""
    g = np.asarray(gap, dtype=float)
    v = np.maximum(np.asarray(speed, dtype=float), 0.0)
    dv = v - np.nan_to_num(np.asarray(leader_speed, dtype=float))
    free = 1.0 - (v / m.max_speed) ** m.delta
    s_star = m.min_gap + np.maximum(v * m.tau + v * dv / (2.0 * math.sqrt(m.accel * m.decel)),
                                    0.0)
    inter = np.where(np.isfinite(g), (s_star / np.maximum(np.where(np.isfinite(g), g, 1.0),
                                                          0.1)) ** 2, 0.0)
    return m.accel * (free - inter)


def entry_decel(gap: ArrayLike, follower_speed: ArrayLike, sv_speed: ArrayLike,
                m: FollowerModel, dt: float) -> Array:
    """m/s^2 (>= 0), what the SV's entry asks of the new follower at once: minus its
    acceleration behind the SV at `gap` (the MOBIL safety test is entry_decel <=
    b_safe). Vectorised over candidate gaps / times of entry."""
    return np.maximum(-follower_accel(gap, follower_speed, sv_speed, m, dt), 0.0)


@njit
def _follow_core(kind: int, p: Array, t: Array, sv_rear: Array, sv_speed: Array,
                 t_enter: float, x0: float, v0: float, x: Array, v: Array, a: Array) -> None:
    """The follower's Euler recursion on the grid t (SUMO's update: v then x), into
    x (front bumper, m), v (m/s), a (m/s^2, applied over the step that follows)."""
    accel, decel, emerg, tau, s0, vmax, delta, bl = p[0], p[1], p[2], p[3], p[4], p[5], \
        p[6], p[7]
    x[0], v[0] = x0, v0
    n = t.size
    for k in range(n - 1):
        dt = t[k + 1] - t[k]
        vk = v[k]
        if t[k] >= t_enter - 1e-9:
            g = sv_rear[k] - x[k]
            vl = max(sv_speed[k], 0.0)
            if kind == 0:  # Krauss
                gg = max(g - s0, 0.0)
                bt = decel * tau
                vsafe = -bt + math.sqrt(bt * bt + 2.0 * decel * (gg + vl * vl / (2.0 * bl)))
                vn = min(vsafe, vk + accel * dt, vmax)
                ak = (max(vn, 0.0) - vk) / dt
            else:  # IDM
                s_star = s0 + max(vk * tau + vk * (vk - vl) / (2.0 * math.sqrt(accel * decel)),
                                  0.0)
                ak = accel * (1.0 - (vk / vmax) ** delta - (s_star / max(g, 0.1)) ** 2)
            ak = min(max(ak, -emerg), accel)
        else:
            ak = 0.0  # it cannot see the SV yet: keeps its speed
        a[k] = ak
        vn = max(vk + ak * dt, 0.0)
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

    def safe(self, m: FollowerModel) -> bool:
        """The MOBIL criterion over the whole prediction: max_decel <= b_safe and the
        follower never reaches the SV."""
        return bool(self.max_decel <= m.b_safe + 1e-9 and self.min_gap > 0.0)


def predict_follower(t: ArrayLike, sv_rear_x: ArrayLike, sv_speed: ArrayLike,
                     t_enter: float, follower_front_x: float, follower_speed: float,
                     m: FollowerModel) -> FollowerPrediction:
    """Predict the new follower: it keeps its speed until the SV enters its lane at
    `t_enter` (s; the SV's centre crosses the lane line), then follows the SV's rear
    (x of the rear bumper and speed on the grid t) by its model."""
    tt = np.ascontiguousarray(t, dtype=float)
    rear = np.ascontiguousarray(sv_rear_x, dtype=float)
    vs = np.ascontiguousarray(sv_speed, dtype=float)
    if tt.ndim != 1 or tt.size < 2 or rear.shape != tt.shape or vs.shape != tt.shape:
        raise ValueError("t, sv_rear_x and sv_speed must be 1-D arrays of the same length >= 2")
    p = np.array([m.accel, m.decel, m.emergency_decel, m.tau, m.min_gap, m.max_speed,
                  m.delta, m.leader_decel])
    x, v, a = np.empty_like(tt), np.empty_like(tt), np.empty_like(tt)
    _follow_core(MODELS.index(m.model), p, tt, rear, vs, float(t_enter),
                 float(follower_front_x), float(follower_speed), x, v, a)
    after = tt >= t_enter - 1e-9
    max_decel = float(max(np.max(-a[after], initial=0.0), 0.0))
    gaps = (rear - x)[after]
    return FollowerPrediction(t=tt, x=x, speed=v, accel=a, max_decel=max_decel,
                              min_gap=float(gaps.min()) if gaps.size else math.inf)


def warm_up() -> None:
    """Compile (or load) the follower recursion for both models."""
    t = np.linspace(0.0, 1.0, 5)
    for model in MODELS:
        predict_follower(t, 50.0 + 20.0 * t, np.full(5, 20.0), 0.0, 0.0, 20.0,
                         FollowerModel(model=model))
