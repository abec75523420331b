"""Choosing tau from the collision-free set (Section 3.3, eq. 12, 13, 35).

The collision-free set need not be one interval (beyond the paper): tau_opt of
eq. 13 is placed between the set's smallest and largest tau, and the plan takes
the collision-free tau nearest to it. None collision-free: keep the lane.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.planning.trajectory import jerk_costs

Array = NDArray[np.float64]


def omega(p: float, mu: float) -> float:
    """-, eq. 35 weight omega(p, mu) = 1.60 - 0.18 p - 1.69 mu, clipped to [0, 1]
    (p occupant type, 0 conservative .. 1 aggressive; mu road friction)."""
    return float(np.clip(1.60 - 0.18 * p - 1.69 * mu, 0.0, 1.0))


def tau_opt(w: float, tau_lo: float, tau_hi: float) -> float:
    """s, eq. 13: w (tau_max - tau_min) + tau_min over the collision-free set."""
    return w * (tau_hi - tau_lo) + tau_lo


def j_xy(vx0: float, vxf: float, width: float, taus: ArrayLike) -> Array:
    """Comprehensive jerk of eq. 12 as printed, Jx^2 + Jy^2 (closed forms of eq. 1, 3)."""
    jx, jy = jerk_costs(vx0, vxf, width, taus)
    return jx**2 + jy**2


def intervals(taus: Array, mask: NDArray[np.bool_]) -> list[tuple[float, float]]:
    """The runs of True in `mask` over the sorted grid `taus`, as [(lo, hi), ...]."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return []
    edges = np.diff(np.concatenate(([0], m.view(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    return [(float(taus[a]), float(taus[b])) for a, b in zip(starts, ends, strict=True)]


def choose(taus: Array, free: NDArray[np.bool_], w: float,
           max_tau: float = np.inf) -> tuple[float | None, float]:
    """(chosen tau or None, tau_opt): the free grid tau nearest eq. 13's tau_opt, or
    nearest `max_tau` (s) when tau_opt is longer (beyond the paper: a policy that bounds
    its manoeuvre's duration; the paper's: inf) (ties to the longer, gentler one).
    tau_opt is nan when nothing is free."""
    ok = taus[np.asarray(free, dtype=bool)]
    if ok.size == 0:
        return None, float("nan")
    target = tau_opt(w, float(ok.min()), float(ok.max()))
    dist = np.abs(ok - min(target, max_tau))
    best = np.flatnonzero(dist <= dist.min() + 1e-12)[-1]
    return float(ok[best]), target
