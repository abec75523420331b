"""Handling envelope and the stable set of a trajectory cluster (Section 3.1).

A lane change of duration tau is stable when the yaw rate needed to follow it
stays inside the friction-circle envelope (eq. 5-6) for all t in [0, tau]:

    |Omega_z| <= f sqrt((mu g)^2 - Ax^2) / Vx.

Which yaw rate the paper bounds is not written down. The default here is the
2-DOF model of eq. 17-19 made to follow the planned centre-of-gravity path
exactly (inverse dynamics): the path fixes the lateral acceleration a_n = V^2 kappa
the tyres must deliver, and the model's side-slip and yaw rate respond to it

    dVy/dt     = a_n - V Omega
    dOmega/dt  = (lf M a_n - (lf + lr) Fyr) / Iz,   Fyr = Cr (lr Omega - Vy) / V

(the front force is whatever is left of M a_n; the steering that realises it is
not needed). Ax = dVx*/dt of eq. 14. "kinematic" (Omega = V kappa) is kept as an
option to show that it is not enough. The paper's calibrated maps (eq. 31-34)
are the third option.

Everything is vectorised over tau: each candidate is sampled on its own
normalised time grid s = t / tau in [0, 1], arrays shaped (n_tau, n_s). The one
sequential part is the time stepping of the linear ODE (trapezoidal rule: A-stable,
second order), a compiled loop (`_yaw_rate_steps`) with the numpy version's arithmetic
operation by operation, so its results are the same to the last bit.
"""

from __future__ import annotations

import bisect
import math
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.compiled import njit
from cosim.errors import InputError
from cosim.params import G, VehicleParams
from cosim.planning.trajectory import BoundaryConditions

Array = NDArray[np.float64]

class Envelope(StrEnum):
    """How the planner judges a candidate's stability (Section 3.1)."""

    INVERSE_DYNAMICS = "inverse_dynamics"  # eq. 5-6 with the yaw rate of the 2-DOF model
    KINEMATIC = "kinematic"  # eq. 5-6 with the path's own yaw rate, V KL
    PAPER_MAPS = "paper_maps"  # the paper's fitted tau_min maps (eq. 31-34)


YAW_MODELS = (Envelope.INVERSE_DYNAMICS.value, Envelope.KINEMATIC.value)  # the envelope's
ENVELOPES = tuple(e.value for e in Envelope)

# eq. 31-34, vx0 in km/h: (c0, c_v, c_mu, c_v2, c_vmu, c_mu2) per mode
PAPER_MAPS: dict[int, tuple[float, float, float, float, float, float]] = {
    1: (4.46, -1.11e-2, -3.20, 2.79e-5, 3.23e-3, 1.20),
    2: (3.58, -1.91e-2, -4.31, 1.45e-4, 8.15e-3, 1.58),
    3: (-0.05, -6.53e-2, -2.82, 2.21e-4, 1.49e-2, 2.18),
    4: (5.04, -3.61e-2, -2.11, 2.38e-5, 1.25e-2, 1.65),
}
# Fig. 5's four modes by (origin, target) SUMO lane: 1->2, 2->3, 3->2, 2->1 in the paper's numbering
MODES: dict[tuple[int, int], int] = {(0, 1): 1, (1, 2): 2, (2, 1): 3, (1, 0): 4}


def inverse_dynamics_yaw_rate(
    speed: Array, lateral_accel: Array, dt: Array, vehicle: VehicleParams,
    omega0: ArrayLike = 0.0,
) -> Array:
    """rad/s, yaw rate of the 2-DOF linear model (eq. 17-19) whose CG follows a path
    with normal acceleration `lateral_accel` at `speed`, both (n, n_s) on steps `dt` (n,).

    Starts with no side slip and yaw rate `omega0`; trapezoidal rule along axis 1.
    """
    M, Iz, lf, lr, Cr = vehicle.mass, vehicle.yaw_inertia, vehicle.lf, vehicle.lr, vehicle.cr
    speed = np.ascontiguousarray(speed, dtype=np.float64)
    n = speed.shape[0]
    om = np.broadcast_to(np.asarray(omega0, dtype=float), (n,)).copy()
    return _yaw_rate(speed, np.ascontiguousarray(lateral_accel, dtype=np.float64),
                     np.ascontiguousarray(dt, dtype=np.float64), om,
                     (lf + lr) * Cr, Iz, lr, lf * M / Iz)


@njit
def _yaw_rate(speed: Array, u: Array, dt: Array, omega0: Array, l_cr: float, Iz: float,
              lr: float, b1: float) -> Array:
    """inverse_dynamics_yaw_rate's trapezoidal steps, (n, n_s), with L Cr = `l_cr` and
    b = (1, lf M / Iz) = (1, `b1`). Sequential in time by nature: a compiled loop,
    operation by operation the arithmetic of `inverse_dynamics_yaw_rate` (the same
    results to the last bit); vectorised over rows in numpy it costs ~2 ms a call, and
    the TauMinMap of a C2 TV's new end speed ~0.17 s, paid at every re-check in slow
    dense traffic."""
    n, n_s = speed.shape
    omega = np.empty((n, n_s))
    for i in range(n):
        h = 0.5 * dt[i]
        vy = 0.0
        om = omega0[i]
        omega[i, 0] = om
        # z' = A z + b a_n with z = (Vy, Omega), A = [[0, -V], [k, -k lr]],
        # k = L Cr / (Iz V): the rear axle's stiffness term of the yaw equation
        V = speed[i, 0] if not speed[i, 0] < 0.5 else 0.5  # linear tyres: singular at rest
        a01 = -V
        a10 = l_cr / (Iz * V)
        a11 = -a10 * lr
        for j in range(n_s - 1):
            V1 = speed[i, j + 1] if not speed[i, j + 1] < 0.5 else 0.5
            b01 = -V1
            b10 = l_cr / (Iz * V1)
            b11 = -b10 * lr
            # trapezoid: (I - h A_{k+1}) z_{k+1} = (I + h A_k) z_k + h (b u_k + b u_{k+1})
            g0 = h * (u[i, j] + u[i, j + 1])
            g1 = g0 * b1
            m01 = -h * b01
            m10 = -h * b10
            m11 = 1.0 - h * b11
            det = 1.0 * m11 - m01 * m10
            i00, i01, i10, i11 = m11 / det, -m01 / det, -m10 / det, 1.0 / det
            p01, p10, p11 = h * a01, h * a10, 1.0 + h * a11
            t00 = i00 * 1.0 + i01 * p10
            t01 = i00 * p01 + i01 * p11
            t10 = i10 * 1.0 + i11 * p10
            t11 = i10 * p01 + i11 * p11
            c0 = i00 * g0 + i01 * g1
            c1 = i10 * g0 + i11 * g1
            vy, om = t00 * vy + t01 * om + c0, t10 * vy + t11 * om + c1
            omega[i, j + 1] = om
            a01, a10, a11 = b01, b10, b11
    return omega


@dataclass(frozen=True)
class StableSet:
    """The handling-envelope verdict on a tau grid."""

    taus: Array  # s, (n_tau,) the grid
    margin: Array  # -, (n_tau,) max of |Omega_z| / bound on [0, tau] (<= 1 stable; inf |Ax| > mu g)
    stable: Array  # bool (n_tau,)
    tau_min: float  # s, shortest stable tau (interpolated between grid points; nan: none)


def envelope_margin(
    bc: BoundaryConditions, taus: ArrayLike, mu: float, vehicle: VehicleParams, *,
    safety_factor: float = 0.8, yaw_model: str = "inverse_dynamics", n_s: int = 64,
) -> Array:
    """-, max over t in [0, tau] of |Omega_z(t)| / (f sqrt((mu g)^2 - Ax^2) / Vx) (eq. 5-6)
    for every tau; > 1 means the candidate leaves the envelope. Shape (n_tau,).

    The fields of `bc` may be arrays of the same length as `taus`: one row per
    (vehicle, tau), so the clusters of several vehicles are checked in one call."""
    if yaw_model not in YAW_MODELS:
        raise InputError("planner", "envelope", yaw_model, f"one of {', '.join(ENVELOPES)}")
    tau = np.atleast_1d(np.asarray(taus, dtype=float))

    s = np.linspace(0.0, 1.0, n_s)
    starts = np.empty((6, tau.size))  # vx0, vxf, W, ax0, vy0, ay0 per row
    for k, field in enumerate((bc.vx0, bc.vxf, bc.width, bc.ax0, bc.vy0, bc.ay0)):
        starts[k] = field
    # tau's powers as `trajectory.polynomial_coefficients` takes them (numpy's pow on
    # the same (n, 1) array: a compiled pow need not round as numpy's does)
    col = tau[:, None]
    powers = np.stack([(col**3)[:, 0], (col**4)[:, 0], (col**5)[:, 0]])
    M, Iz, lf, lr, Cr = vehicle.mass, vehicle.yaw_inertia, vehicle.lf, vehicle.lr, vehicle.cr
    return _margin_rows(starts, np.ascontiguousarray(tau), powers, s,
                        yaw_model == Envelope.KINEMATIC, (mu * G) ** 2, float(safety_factor),
                        (lf + lr) * Cr, Iz, lr, lf * M / Iz)


@njit
def _margin_rows(starts: Array, tau: Array, powers: Array, s: Array, kinematic: bool,
                 grip_sq: float, safety_factor: float, l_cr: float, Iz: float, lr: float,
                 b1: float) -> Array:
    """`envelope_margin` of each row i (its start `starts[:, i]`: vx0, vxf, W, ax0, vy0,
    ay0; duration tau[i] with tau^3, tau^4, tau^5 in `powers[:, i]`, sampled at tau[i]
    s) in one compiled pass: the coefficients as `trajectory.polynomial_coefficients`
    computes them, the derivatives as `trajectory._horner_rows`, then operation by
    operation the numpy arithmetic it replaces (Vx* = hypot(x', y'), Ax, a_n, the yaw
    rate of `_yaw_rate`, the ratio to the bound, nan read as outside): the same margins
    to the last bit. In numpy its ~50 calls on small arrays cost ~0.2 ms, and a
    TauMinMap's bisection makes ~40 of them."""
    n, n_s = tau.size, s.size
    V = np.empty((n, n_s))
    a_n = np.empty((n, n_s))
    Ax = np.empty((n, n_s))
    omega0 = np.empty(n)
    dt = np.empty(n)
    for i in range(n):
        T = tau[i]
        vx0, vxf, W, ax0, vy0, ay0 = (starts[0, i], starts[1, i], starts[2, i], starts[3, i],
                                      starts[4, i], starts[5, i])
        T2, T3, T4, T5 = T * T, powers[0, i], powers[1, i], powers[2, i]
        # trajectory.longitudinal_coefficients, lateral_coefficients
        d = vxf - vx0 - ax0 * T
        e = -ax0
        c3x = ((3.0 * d - e * T) / T2) / 3.0
        c4x = ((e * T - 2.0 * d) / T3) / 4.0
        c3y = (20.0 * W - 12.0 * vy0 * T - 3.0 * ay0 * T2) / (2.0 * T3)
        c4y = (-30.0 * W + 16.0 * vy0 * T + 3.0 * ay0 * T2) / (2.0 * T4)
        c5y = (12.0 * W - 6.0 * vy0 * T - ay0 * T2) / (2.0 * T5)
        c1x, c2x, c1y, c2y = 0.0 + vx0, 0.0 + ax0 / 2.0, 0.0 + vy0, 0.0 + ay0 / 2.0
        # factors of x' (k c_k) and x'' (k (k - 1) c_k), y likewise (`_horner_rows`)
        x1 = (1.0 * c1x, 2.0 * c2x, 3.0 * c3x, 4.0 * c4x)
        x2 = (2.0 * c2x, 6.0 * c3x, 12.0 * c4x)
        y1 = (1.0 * c1y, 2.0 * c2y, 3.0 * c3y, 4.0 * c4y, 5.0 * c5y)
        y2 = (2.0 * c2y, 6.0 * c3y, 12.0 * c4y, 20.0 * c5y)
        for j in range(n_s):
            t = T * s[j]
            # ts = minimum(maximum(t, 0), tau), as numpy's (nan kept)
            m = t if (t >= 0.0 or t != t) else 0.0
            ts = m if (m <= T or m != m) else T
            after = t - ts
            xd = x1[3]
            xd = xd * ts + x1[2]
            xd = xd * ts + x1[1]
            xd = xd * ts + x1[0]
            yd = y1[4]
            yd = yd * ts + y1[3]
            yd = yd * ts + y1[2]
            yd = yd * ts + y1[1]
            yd = yd * ts + y1[0]
            xdd = x2[2]
            xdd = xdd * ts + x2[1]
            xdd = xdd * ts + x2[0]
            ydd = y2[3]
            ydd = ydd * ts + y2[2]
            ydd = ydd * ts + y2[1]
            ydd = ydd * ts + y2[0]
            if after > 0:
                xd, yd, xdd, ydd = vxf, 0.0, 0.0, 0.0
            v = np.hypot(xd, yd)
            V[i, j] = v
            Ax[i, j] = (xd * xdd + yd * ydd) / v
            a_n[i, j] = (xd * ydd - yd * xdd) / v
        omega0[i] = a_n[i, 0] / V[i, 0]
        dt[i] = T / (n_s - 1)
    omega = a_n / V if kinematic else _yaw_rate(V, a_n, dt, omega0, l_cr, Iz, lr, b1)
    out = np.empty(n)
    for i in range(n):
        top = -np.inf
        for j in range(n_s):
            ax = Ax[i, j]
            grip2 = grip_sq - ax * ax
            g = grip2 if grip2 > 0 else np.nan
            bound = safety_factor * np.sqrt(g) / V[i, j]
            r = np.abs(omega[i, j]) / bound
            if r != r:
                r = np.inf  # |Ax| >= mu g: outside the envelope
            if j == 0 or r > top:
                top = r
        out[i] = top
    return out


def tau_min_from_margin(taus: Array, margin: Array) -> float:
    """s, the tau where the margin first falls to 1 for good: linear interpolation
    between the last unstable and the first stable grid point of the final stable run."""
    stable = margin <= 1.0
    if not stable.any():
        return float("nan")
    if stable.all():
        return float(taus[0])
    unstable_idx = np.flatnonzero(~stable)
    last_bad = int(unstable_idx[-1])
    if last_bad == len(taus) - 1:
        return float("nan")
    m0, m1 = margin[last_bad], margin[last_bad + 1]
    if not np.isfinite(m0):
        return float(taus[last_bad + 1])
    frac = (m0 - 1.0) / (m0 - m1)
    return float(taus[last_bad] + frac * (taus[last_bad + 1] - taus[last_bad]))


def paper_map_tau_min(mode: int, vx0: float, mu: float) -> float:
    """s, tau_min,i = F_i(vx0, mu) of eq. 31-34 (vx0 in m/s here, km/h in the fit)."""
    if mode not in PAPER_MAPS:
        raise InputError("planner", "mode", mode, "1, 2, 3 or 4 (Fig. 5)")
    c0, cv, cm, cv2, cvm, cm2 = PAPER_MAPS[mode]
    v = vx0 * 3.6
    return c0 + cv * v + cm * mu + cv2 * v**2 + cvm * v * mu + cm2 * mu**2


def stable_set(
    bc: BoundaryConditions, taus: ArrayLike, mu: float, vehicle: VehicleParams, *,
    envelope: str = "inverse_dynamics", safety_factor: float = 0.8, mode: int | None = None,
    tau_floor: float = 1.0,
) -> StableSet:
    """The stable candidates on `taus` (Section 3.1, eq. 5-8).

    `envelope` "inverse_dynamics" (default) or "kinematic": the yaw-rate envelope
    checked on every candidate; "paper_maps": tau >= F_mode(vx0, mu) (eq. 31-34),
    with a warning and `tau_floor` in place of a map value below it (eq. 33 is
    negative over the whole speed range: a misprint).
    """
    tau = np.atleast_1d(np.asarray(taus, dtype=float))
    if envelope == Envelope.PAPER_MAPS:
        if mode is None:
            raise InputError("planner", "envelope", envelope, "paper maps need a lane-change mode")
        vx0 = float(bc.vx0)
        value = paper_map_tau_min(mode, vx0, mu)
        if not np.isfinite(value) or value < tau_floor:
            warnings.warn(
                f"paper map eq. {30 + mode} gives tau_min = {value:.2f} s at "
                f"{vx0 * 3.6:.0f} km/h, mu {mu}: using {tau_floor} s",
                stacklevel=2,
            )
            value = tau_floor
        margin = np.where(tau >= value, 0.0, np.inf)
        return StableSet(tau, margin, tau >= value - 1e-12, float(value))
    if envelope not in YAW_MODELS:
        raise InputError("planner", "envelope", envelope, f"one of {', '.join(ENVELOPES)}")
    margin = envelope_margin(bc, tau, mu, vehicle, safety_factor=safety_factor,
                             yaw_model=envelope)
    return StableSet(tau, margin, margin <= 1.0, tau_min_from_margin(tau, margin))


MAP_V_LO, MAP_V_HI, MAP_V_STEP = 1.0, 50.0, 0.5  # m/s, a TauMinMap's speed grid
MAP_TOL = 1e-4  # s, its bisection's resolution


class TauMinMap:
    """tau_min as a function of the initial speed for one lane-change mode: eq. 7's
    tau_min,i = F_i(vx0, mu), with F computed from the envelope for the vehicle at
    hand instead of the paper's fitted polynomials.

    On a speed grid: a bisection over tau run for the grid's speeds at once (it
    assumes what eq. 7-8 assume, a stable set [tau_min, tau_max]), with the envelope
    sampled at 64 instants. The sampled envelope converges with its step: the
    bisection runs again at 128 and 256 instants and the difference, extrapolated,
    estimates the sampling error.
    Queried by linear interpolation in vx0 (`__call__`, as before), or as bounds of
    the converged envelope's tau_min (`bounds`): the lower one for the durations a C2
    TV may take, the upper one for the SV's own. Covers starts from rest laterally
    (vy0 = ay0 = ax0 = 0) with the given width; other starts need `stable_set`.

    Filled lazily: a query computes only the grid speeds its answer reads (the
    interval around vx0 and the neighbours of the interpolation's error estimate),
    each speed's bisection on its own row of the same vectorised calls, so every
    answer is the one of the whole grid computed at once (`fill`), to the last bit.
    A map is keyed by an exact end speed, and a C2 TV's is new at most re-checks: the
    whole grid cost 0.15-0.6 s, the few speeds a query reads cost ~1/15 of that.
    """

    def __init__(
        self, vxf: float, width: float, mu: float, vehicle: VehicleParams, *,
        tau_lo: float, tau_hi: float, safety_factor: float = 0.8,
        yaw_model: str = "inverse_dynamics",
    ) -> None:
        def stable(speeds: Array, taus: Array, n_s: int) -> Array:
            return envelope_margin(BoundaryConditions(speeds, vxf, width), taus, mu,
                                   vehicle, n_s=n_s, safety_factor=safety_factor,
                                   yaw_model=yaw_model) <= 1.0

        self._stable = stable
        self.tau_lo, self.tau_hi = tau_lo, tau_hi
        # what its envelope calls share with another map's (`fill_maps`), and its own
        self._shared = (mu, vehicle, safety_factor, yaw_model, tau_lo, tau_hi)
        self.vxf, self.width = vxf, width
        self.speeds = np.arange(MAP_V_LO, MAP_V_HI + 1e-9, MAP_V_STEP)
        n = self.speeds.size
        # per grid speed: tau_min (stable side), the bisection's unstable side, the
        # sampling error; nan until computed (`_coarse`, `_refined` say which are)
        self._tau = np.full(n, np.nan)
        self._below = np.full(n, np.nan)
        self._err = np.zeros(n)  # the sampling error, on the same grid
        self._coarse = np.zeros(n, dtype=bool)
        self._refined = np.zeros(n, dtype=bool)
        self._speeds_list: list[float] = self.speeds.tolist()
        self._interp_err = np.full(n - 1, np.nan)
        self._lists: tuple[list[float], ...] = ()
        self._to_lists()

    @property
    def tau_min(self) -> Array:
        """s, tau_min at every grid speed (the whole grid computed)."""
        self.fill()
        return self._tau

    def fill(self) -> None:
        """Every grid speed computed (what a query does for the speeds it reads)."""
        self._ensure(range(self.speeds.size - 1))

    def __call__(self, vx0: ArrayLike) -> Array:
        """s, tau_min at the initial speed(s) vx0 (nan: no stable tau up to tau_hi,
        or outside the map's speed range)."""
        if isinstance(vx0, float | int):
            v = float(vx0)
            speeds = self._lists[0]
            if not speeds[0] <= v <= speeds[-1]:
                return math.nan  # type: ignore[return-value]
            self._ensure((self._interval(v),))
            return _interp_scalar(v, speeds, self._lists[1])  # type: ignore[return-value]
        v = np.asarray(vx0, dtype=float)
        self._ensure_all(v)
        out = np.interp(v, self.speeds, self._tau)
        return np.where((v < self.speeds[0]) | (v > self.speeds[-1]), np.nan, out)

    def bounds(self, vx0: ArrayLike) -> tuple[Array, Array]:
        """s, (lower, upper) bounds of the converged envelope's tau_min at vx0 (nan as
        `__call__`): the map's bisection bracket, the sampling error's estimate and the
        interpolation's error."""
        if isinstance(vx0, float | int):  # the same arithmetic on floats
            v = float(vx0)
            self._ensure((self._interval(v),))
            speeds, _, below, err_, interp_err = self._lists
            hi = self(v)
            lo = _interp_scalar(v, speeds, below)
            err = _interp_scalar(v, speeds, err_)
            e = interp_err[min(max(bisect.bisect_left(speeds, v) - 1, 0), len(speeds) - 2)]
            lower = min(lo, lo - err) - e
            upper = max(hi, hi - err) + e
            return (lower if math.isfinite(hi) else math.nan), upper  # type: ignore[return-value]
        v = np.asarray(vx0, dtype=float)
        self._ensure_all(v)
        hi = self(v)
        lo = np.interp(v, self.speeds, self._below)
        err = np.interp(v, self.speeds, self._err)
        at = np.clip(np.searchsorted(self.speeds, v) - 1, 0, self.speeds.size - 2)
        e = self._interp_err[at]
        lower = np.minimum(lo, lo - err) - e
        upper = np.maximum(hi, hi - err) + e
        return np.where(np.isfinite(hi), lower, np.nan), upper

    # -- the lazy grid -------------------------------------------------------------

    def _interval(self, v: float) -> int:
        """The grid interval [j, j + 1] a query at v reads (the ends outside the grid)."""
        speeds = self._speeds_list
        if v != v:
            return 0
        return min(max(bisect.bisect_right(speeds, v) - 1, 0), len(speeds) - 2)

    def _ensure_all(self, v: Array) -> None:
        speeds = self._speeds_list
        at = np.clip(np.searchsorted(self.speeds, v, side="right") - 1, 0, len(speeds) - 2)
        self._ensure(np.unique(at).tolist())

    def _ensure(self, intervals: Iterable[int]) -> None:
        """The grid speeds the queries in `intervals` read computed (`_todo`)."""
        _fill([(self, *self._todo(intervals))])

    def _todo(self, intervals: Iterable[int]) -> tuple[list[int], list[int]]:
        """(grid speeds whose tau_min is still to compute, those whose sampling error
        is) of the queries in `intervals`: tau_min and the bisection's bracket at
        j - 2 .. j + 3 (the interpolation, and its error estimate from the second
        differences at j - 1 .. j + 1; a query at a grid point j + 1 reads the estimate
        of interval j), the sampling error at j - 1 .. j + 2 (its speeds' tau_min
        interpolated as the whole grid's: from j .. j + 3)."""
        n = self.speeds.size
        coarse: set[int] = set()
        refined: set[int] = set()
        for j in intervals:
            coarse.update(range(max(j - 2, 0), min(j + 4, n)))
            refined.update(range(max(j - 1, 0), min(j + 3, n)))
        return (sorted(i for i in coarse if not self._coarse[i]),
                sorted(i for i in refined if not self._refined[i]))

    def _fill_whole(self) -> None:
        """Every grid speed at once (as the map was built before it was lazy)."""
        n = self.speeds.size
        below, above = _bisect(self._stable, self.speeds, np.full(n, self.tau_lo),
                               np.full(n, self.tau_hi), 64)
        self._tau = np.where(np.isneginf(below), self.tau_lo, above)
        self._below = np.where(np.isneginf(below), self.tau_lo, below)
        base = np.interp(self.speeds, self.speeds, self._tau)
        self._err = _sampling_error_at(self._stable, self.speeds, base, self.tau_lo,
                                       self.tau_hi)
        self._coarse[:] = True
        self._refined[:] = True
        self._to_lists()

    def _to_lists(self) -> None:
        # linear interpolation's error per speed interval: twice the h^2 f'' / 8 estimate
        # from the second differences at its two ends (nan where a neighbour is not
        # computed yet: no query reads it before it is)
        n = self.speeds.size
        tau = np.where(self._coarse, np.nan_to_num(self._tau), np.nan)
        second = np.zeros(n)
        second[1:-1] = np.abs(np.diff(tau, 2))
        self._interp_err = 0.25 * np.maximum(second[:-1], second[1:]) + MAP_TOL
        # the same as plain floats: one speed is queried per plan (see `_interp_scalar`)
        self._lists = tuple(a.tolist() for a in (self.speeds, self._tau, self._below,
                                                  self._err, self._interp_err))


def fill_maps(queries: Sequence[tuple[TauMinMap, float]]) -> None:
    """The grid speeds every (map, vx0) query reads computed, the maps' rows in one set
    of vectorised calls (maps of one envelope: friction, vehicle, factor, yaw model and
    tau range): a re-check asks several C2 TVs' maps at once, and a lazy fill's cost is
    mostly its calls. Each row's bisection is its own: the same answers as one map's
    fill (`TauMinMap._ensure`)."""
    todo: dict[int, tuple[TauMinMap, set[int]]] = {}
    for fmap, v in queries:
        if not fmap._speeds_list[0] <= v <= fmap._speeds_list[-1]:
            continue  # (outside the grid: nan, nothing read)
        todo.setdefault(id(fmap), (fmap, set()))[1].add(fmap._interval(v))
    groups: dict[Any, list[tuple[TauMinMap, list[int], list[int]]]] = {}
    for fmap, intervals in todo.values():
        coarse, refine = fmap._todo(sorted(intervals))
        if coarse or refine:
            groups.setdefault(fmap._shared, []).append((fmap, coarse, refine))
    for group in groups.values():
        _fill(group)


def _joint_stable(group: Sequence[TauMinMap], rows: list[Array]
                  ) -> Callable[[Array, Array, int], Array]:
    """`stable(speeds, taus, n_s)` of rows of several maps of one envelope: map k's
    end speed and width on its rows (`rows[k]`: how many)."""
    mu, vehicle, safety_factor, yaw_model, _, _ = group[0]._shared
    vxf = np.concatenate([np.full(r.size, m.vxf) for m, r in zip(group, rows, strict=True)])
    width = np.concatenate([np.full(r.size, m.width)
                            for m, r in zip(group, rows, strict=True)])

    def stable(speeds: Array, taus: Array, n_s: int) -> Array:
        return envelope_margin(BoundaryConditions(speeds, vxf, width), taus, mu, vehicle,
                               n_s=n_s, safety_factor=safety_factor,
                               yaw_model=yaw_model) <= 1.0
    return stable


def _fill(group: list[tuple[TauMinMap, list[int], list[int]]]) -> None:
    """Maps of one envelope, each with the grid speeds (tau_min, sampling error) to
    compute, filled together: the 64-instant bisection over all their rows, then the
    128- and 256-instant ones over the rows whose error is wanted. A map whose part of
    the grid would not iterate as its whole grid (`_refine_bracket`) is computed
    whole instead."""
    group = [g for g in group if g[1] or g[2]]
    if not group:
        return
    tau_lo, tau_hi = group[0][0].tau_lo, group[0][0].tau_hi
    coarse = [(m, np.array(c, dtype=np.int64)) for m, c, _ in group if c]
    if coarse:
        maps = [m for m, _ in coarse]
        idx = [i for _, i in coarse]
        speeds = np.concatenate([m.speeds[i] for m, i in coarse])
        n = speeds.size
        below, above = _bisect(_joint_stable(maps, idx), speeds, np.full(n, tau_lo),
                               np.full(n, tau_hi), 64)
        at = 0
        for m, i in coarse:
            b, a = below[at:at + i.size], above[at:at + i.size]
            m._tau[i] = np.where(np.isneginf(b), tau_lo, a)
            m._below[i] = np.where(np.isneginf(b), tau_lo, b)
            m._coarse[i] = True
            at += i.size
    # the sampling error: 128 then 256 instants, over the rows that need it
    refine: list[tuple[TauMinMap, Array, Array, Array]] = []  # map, grid index, ok rows, base
    for m, _, r in group:
        if not r:
            continue
        i = np.array(r, dtype=np.int64)
        base = np.interp(m.speeds[i], m.speeds, m._tau)  # (the grid's own values)
        ok = np.isfinite(base) & (base > tau_lo)
        refine.append((m, i, ok, base))
    t128 = _joint_pass(refine, None, REFINE_SPAN, 128, tau_lo, tau_hi)
    t256 = _joint_pass(refine, t128, FINE_SPAN, 256, tau_lo, tau_hi)
    for k, (m, i, ok, base) in enumerate(refine):
        if m._refined.all():  # computed whole meanwhile
            continue
        err = np.zeros(i.size)
        if ok.any():
            b = base[ok]
            # converged tau_min, extrapolated (`_sampling_error_at`)
            est = t256[k] - 0.5 * (t128[k] - t256[k])
            err[ok] = np.nan_to_num(b - est)
        m._err[i] = err
        m._refined[i] = True
    for m, _, _ in group:
        m._to_lists()


def _joint_pass(refine: list[tuple[TauMinMap, Array, Array, Array]],
                previous: list[Array] | None, span: tuple[float, float], n_s: int,
                tau_lo: float, tau_hi: float) -> list[Array]:
    """One refining bisection (`span` around `previous`, each map's 64-instant tau_min
    where None) over the ok rows of every map still lazy; per map its stable sides
    (empty: no ok row, or the map was computed whole here)."""
    out: list[Array] = [np.zeros(0)] * len(refine)
    rows: list[tuple[int, Array, Array]] = []  # refine index, lo, hi
    full = _iterations(np.zeros(1), np.full(1, sum(span) + 1e-9))
    for k, (m, _, ok, base) in enumerate(refine):
        if not ok.any() or m._refined.all():
            continue
        centre = base[ok] if previous is None else previous[k]
        lo = np.maximum(centre - span[0], tau_lo)
        hi = np.minimum(centre + span[1], tau_hi)
        if _iterations(lo, hi) != full:  # its part would iterate less than its whole grid
            m._fill_whole()
            continue
        rows.append((k, lo, hi))
    if not rows:
        return out
    maps = [refine[k][0] for k, _, _ in rows]
    speeds = np.concatenate([refine[k][0].speeds[refine[k][1]][refine[k][2]]
                             for k, _, _ in rows])
    _, stable_side = _bisect(_joint_stable(maps, [lo for _, lo, _ in rows]), speeds,
                             np.concatenate([lo for _, lo, _ in rows]),
                             np.concatenate([hi for _, _, hi in rows]), n_s)
    at = 0
    for k, lo, _ in rows:
        out[k] = stable_side[at:at + lo.size]
        at += lo.size
    return out


def _bisect(stable: Callable[[Array, Array, int], Array], speeds: Array, lo: Array,
            hi: Array, n_s: int) -> tuple[Array, Array]:
    """(unstable side, stable side) of tau_min per speed, to MAP_TOL, with the envelope
    sampled at n_s instants (`stable(speeds, taus, n_s)`); -inf on the unstable side
    where lo is stable already, nan where [lo, hi] holds no stable tau."""
    ok_lo, ok_hi = stable(speeds, lo, n_s), stable(speeds, hi, n_s)
    # nan where the coarser pass found no stable tau (its speeds stay nan)
    span = hi - lo
    widest = float(np.nanmax(span)) if np.isfinite(span).any() else MAP_TOL
    n_iter = int(np.ceil(np.log2(max(widest, MAP_TOL) / MAP_TOL)))
    for _ in range(n_iter):  # bisection, all speeds at once
        mid = 0.5 * (lo + hi)
        ok = stable(speeds, mid, n_s)
        hi = np.where(ok, mid, hi)
        lo = np.where(ok, lo, mid)
    return (np.where(ok_lo, -np.inf, np.where(ok_hi, lo, np.nan)),
            np.where(ok_lo, lo, np.where(ok_hi, hi, np.nan)))


REFINE_SPAN = (0.05, 0.01)  # s, below and above the 64-instant tau_min: the 128 pass's bracket
FINE_SPAN = (0.01, 0.003)  # s, the same around the 128-instant one: the 256 pass's


def _iterations(lo: Array, hi: Array) -> int:
    """`_bisect`'s number of halvings for these brackets."""
    span = hi - lo
    widest = float(np.nanmax(span)) if np.isfinite(span).any() else MAP_TOL
    return int(np.ceil(np.log2(max(widest, MAP_TOL) / MAP_TOL)))


def _sampling_error_at(stable: Callable[[Array, Array, int], Array], v_all: Array,
                       base: Array, tau_lo: float, tau_hi: float) -> Array:
    """s, the error of tau_min sampled at 64 instants (`base`, at the speeds `v_all`, the
    whole grid) against the converged envelope's: the bisection again at 128 and 256
    instants, extrapolated (a part of the grid: `_fill`)."""
    ok = np.isfinite(base) & (base > tau_lo)
    err = np.zeros(v_all.size)
    if ok.any():
        v, b = v_all[ok], base[ok]
        _, t128 = _bisect(stable, v, np.maximum(b - REFINE_SPAN[0], tau_lo),
                          np.minimum(b + REFINE_SPAN[1], tau_hi), 128)
        _, t256 = _bisect(stable, v, np.maximum(t128 - FINE_SPAN[0], tau_lo),
                          np.minimum(t128 + FINE_SPAN[1], tau_hi), 256)
        # converged tau_min, extrapolated: the error goes down about as the step
        # squared where the margin's maximum stays between samples, slower where it
        # jumps (3.7, 0.48, 0.32 ms from 64 to 1024 instants); half the last
        # difference, with the interpolation's allowance below, covers both
        est = t256 - 0.5 * (t128 - t256)
        err[ok] = np.nan_to_num(b - est)
    return err


def _interp_scalar(x: float, xp: list[float], fp: list[float]) -> float:
    """`np.interp(x, xp, fp)` for one float, operation for operation as numpy does it
    (the same value, without numpy's per-call cost): the end values outside xp, fp[j]
    at a grid point, else slope (x - xp[j]) + fp[j], from the other end when nan."""
    if x != x:
        return math.nan
    if x <= xp[0]:
        return fp[0]
    if x >= xp[-1]:
        return fp[-1]
    j = bisect.bisect_right(xp, x) - 1
    if xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    out = slope * (x - xp[j]) + fp[j]
    if out != out:
        out = slope * (x - xp[j + 1]) + fp[j + 1]
        if out != out and fp[j] == fp[j + 1]:
            out = fp[j]
    return out
