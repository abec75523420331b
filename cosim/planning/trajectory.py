"""Min-jerk lane-change trajectories (Section 2), vectorised over tau.

Longitudinal: quartic x(t) (eq. 2), lateral: quintic y(t) (eq. 4). The paper
starts from rest in y and from zero acceleration in x; the general form here
takes any initial lateral position, speed and acceleration and any initial
longitudinal acceleration, so a new plan can start mid-manoeuvre without a jump
(beyond the paper). With y0' = y0'' = ax0 = 0 it is exactly eq. 2 / eq. 4.

Shapes: `taus` (n_tau,) and `t` (n_t,) broadcast to (n_tau, n_t). Times are
relative to the start of the manoeuvre; after tau the motion goes on straight at
vxf in the target lane's centre, before 0 it is not defined (clipped to 0).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cosim.compiled import njit

Array = NDArray[np.float64]


@dataclass(frozen=True)
class BoundaryConditions:
    """What every candidate of a cluster shares (eq. 1-4 with a general start): the
    state it starts from and the end it reaches at its own tau (at the end: x' = vxf,
    x'' = 0, y = width, y' = y'' = 0). A field may be an array, one value per candidate
    (shaped to broadcast against tau)."""

    vx0: ArrayLike  # m/s, longitudinal speed at the start
    vxf: ArrayLike  # m/s, longitudinal speed at the end
    width: ArrayLike  # m, signed lateral displacement W (+ to the left)
    ax0: ArrayLike = 0.0  # m/s^2, longitudinal acceleration at the start
    vy0: ArrayLike = 0.0  # m/s, lateral speed at the start
    ay0: ArrayLike = 0.0  # m/s^2, lateral acceleration at the start


def _grid(taus: ArrayLike, t: ArrayLike) -> tuple[Array, Array]:
    tau = np.asarray(taus, dtype=float)
    tt = np.asarray(t, dtype=float)
    if tau.ndim == 1 and tt.ndim == 1:
        return tau[:, None], tt[None, :]
    np.broadcast_shapes(tau.shape, tt.shape)  # raises on a mismatch
    # not broadcast: the coefficients stay per candidate, only the evaluation is (n_tau, n_t)
    return tau, tt


def longitudinal_coefficients(
    vx0: ArrayLike, vxf: ArrayLike, tau: ArrayLike, ax0: ArrayLike = 0.0
) -> tuple[Array, Array]:
    """(c3, c4) of x(t) = vx0 t + ax0 t^2/2 + c3 t^3 + c4 t^4 with x'(tau) = vxf,
    x''(tau) = 0 (eq. 2 when ax0 = 0: c3 = -(vx0 - vxf)/tau^2, c4 = (vx0 - vxf)/(2 tau^3))."""
    tau = np.asarray(tau, dtype=float)
    ax0 = np.asarray(ax0, dtype=float)
    d = np.asarray(vxf, dtype=float) - np.asarray(vx0, dtype=float) - ax0 * tau
    e = -ax0
    # x' = vx0 + ax0 t + b2 t^2 + b3 t^3 with b2, b3 solving the two end conditions
    b3 = (e * tau - 2.0 * d) / tau**3
    b2 = (3.0 * d - e * tau) / tau**2
    return b2 / 3.0, b3 / 4.0


def lateral_coefficients(
    width: ArrayLike, tau: ArrayLike, vy0: ArrayLike = 0.0, ay0: ArrayLike = 0.0
) -> tuple[Array, Array, Array]:
    """(c3, c4, c5) of y(t) - y0 = vy0 t + ay0 t^2/2 + c3 t^3 + c4 t^4 + c5 t^5 reaching
    `width` with zero speed and acceleration at tau (eq. 4 when vy0 = ay0 = 0:
    10 W/tau^3, -15 W/tau^4, 6 W/tau^5)."""
    T = np.asarray(tau, dtype=float)
    W = np.asarray(width, dtype=float)
    v0 = np.asarray(vy0, dtype=float)
    a0 = np.asarray(ay0, dtype=float)
    c3 = (20.0 * W - 12.0 * v0 * T - 3.0 * a0 * T**2) / (2.0 * T**3)
    c4 = (-30.0 * W + 16.0 * v0 * T + 3.0 * a0 * T**2) / (2.0 * T**4)
    c5 = (12.0 * W - 6.0 * v0 * T - a0 * T**2) / (2.0 * T**5)
    return c3, c4, c5


def polynomial_coefficients(bc: BoundaryConditions,
                            tau: Array) -> tuple[list[Array], list[Array]]:
    """Coefficients [c0 .. c4] of x(t) - x0 and [c0 .. c5] of y(t) - y0 (powers of t, on
    [0, tau]), each shaped like tau (eq. 2, 4 with a general start)."""
    c3x, c4x = longitudinal_coefficients(bc.vx0, bc.vxf, tau, bc.ax0)
    c3y, c4y, c5y = lateral_coefficients(bc.width, tau, bc.vy0, bc.ay0)
    zero = np.zeros_like(tau)
    return ([zero, zero + bc.vx0, zero + bc.ax0 / 2.0, c3x, c4x],
            [zero, zero + bc.vy0, zero + bc.ay0 / 2.0, c3y, c4y, c5y])


def _poly_derivs(coeffs: list[Array], t: Array, order: int) -> Array:
    """Evaluate d^order/dt^order of sum_k coeffs[k] t^k (Horner), shaped like t and the
    coefficients broadcast."""
    n = len(coeffs)

    def factor(k: int) -> float:  # k (k-1) ... (k-order+1)
        return float(math.prod(range(k - order + 1, k + 1)))

    if order >= n:
        return np.zeros(np.broadcast_shapes(t.shape, *(np.shape(c) for c in coeffs)))
    out = factor(n - 1) * coeffs[n - 1]
    for k in range(n - 2, order - 1, -1):
        out = out * t + factor(k) * coeffs[k]
    if order < n - 1:  # t took part: out has the broadcast shape already
        return out
    return np.broadcast_to(out, np.broadcast_shapes(t.shape, np.shape(out))).copy()


def cluster_derivatives(
    bc: BoundaryConditions, taus: ArrayLike, t: ArrayLike, orders: tuple[int, ...] = (0,),
) -> dict[int, tuple[Array, Array]]:
    """{order: (x, y)} of every candidate for several derivative orders at once, each
    shaped like taus x t broadcast (eq. 2, 4; the coefficients are computed once).
    Past tau the candidate drives straight at vxf."""
    tau, tt = _grid(taus, t)
    x_coeffs, y_coeffs = polynomial_coefficients(bc, tau)
    vxf = bc.vxf
    ts = np.minimum(np.maximum(tt, 0.0), tau)
    after = tt - ts  # time past the end of the manoeuvre
    rows = _row_coefficients(x_coeffs + y_coeffs + [np.asarray(vxf, dtype=float)], ts)
    if rows is not None:  # (n_c, n_t): one compiled pass per order and axis
        return {order: _cluster_order(rows, ts, after, order) for order in orders}
    ended = after > 0
    out: dict[int, tuple[Array, Array]] = {}
    for order in orders:
        x = _poly_derivs(x_coeffs, ts, order)
        y = _poly_derivs(y_coeffs, ts, order)
        if order == 0:
            x = x + vxf * after
        elif order == 1:
            x = np.where(ended, vxf, x)
            y = np.where(ended, 0.0, y)
        else:
            x = np.where(ended, 0.0, x)
            y = np.where(ended, 0.0, y)
        out[order] = (x, y)
    return out


def _row_coefficients(coeffs: list[Array], ts: Array) -> Array | None:
    """(len(coeffs), n_c) of coefficients that are constant along the time axis of the
    2-D grid `ts` (n_c, n_t) (each shaped (n_c, 1), (1, 1) or a scalar), else None."""
    if ts.ndim != 2 or not ts.flags.c_contiguous:
        return None
    n_c = ts.shape[0]
    rows = np.empty((len(coeffs), n_c))
    for i, c in enumerate(coeffs):
        a = np.asarray(c, dtype=float)
        if a.ndim > 2 or (a.ndim == 2 and (a.shape[1] != 1 or a.shape[0] not in (1, n_c))) \
                or (a.ndim == 1 and a.shape[0] != 1):
            return None
        rows[i] = a.reshape(-1)[0] if a.size == 1 else a[:, 0]
    return rows


def _cluster_order(rows: Array, ts: Array, after: Array, order: int) -> tuple[Array, Array]:
    """(x, y) derivatives of `order` of `cluster_derivatives` from its coefficient rows
    (`_row_coefficients` of x's 5, y's 6 and vxf): the numpy path's operations, in the
    same order, in one compiled pass."""
    factors = _FACTORS.get(order)
    if factors is None:
        factors = _FACTORS[order] = (np.array([_factor(k, order) for k in range(5)]),
                                     np.array([_factor(k, order) for k in range(6)]))
    fx, fy = factors
    x = _horner_rows(rows[:5], fx, ts, after, rows[11], order, True)
    y = _horner_rows(rows[5:11], fy, ts, after, rows[11], order, False)
    return x, y


_FACTORS: dict[int, tuple[Array, Array]] = {}  # order -> `_cluster_order`'s factors of x, y


def _factor(k: int, order: int) -> float:
    """k (k-1) ... (k-order+1): the factor of t^(k-order) in the order-th derivative."""
    return float(math.prod(range(k - order + 1, k + 1)))


@njit
def _horner_rows(coef: Array, fac: Array, ts: Array, after: Array, vxf: Array, order: int,
                 longitudinal: bool) -> Array:
    """d^order/dt^order of sum_k coef[k] t^k at ts (n_c, n_t), coef (n_k, n_c) (Horner, as
    `_poly_derivs`); past tau (after > 0) straight at vxf: x + vxf after for the
    position, vxf for x', 0 otherwise (as `cluster_derivatives`)."""
    n_k = coef.shape[0]
    n_c, n_t = ts.shape
    out = np.zeros((n_c, n_t))
    if order >= n_k:
        return out
    scaled = np.empty(n_k)
    for i in range(n_c):
        for k in range(n_k):
            scaled[k] = fac[k] * coef[k, i]
        top = scaled[n_k - 1]
        v = vxf[i]
        for j in range(n_t):
            t = ts[i, j]
            o = top
            for k in range(n_k - 2, order - 1, -1):
                o = o * t + scaled[k]
            a = after[i, j]
            if order == 0:
                if longitudinal:
                    o = o + v * a
            elif a > 0:
                o = v if (order == 1 and longitudinal) else 0.0
            out[i, j] = o
    return out


def _per_row(a: ArrayLike) -> Array | float:
    """A per-candidate parameter: scalars stay, 1-D arrays become columns."""
    arr = np.asarray(a, dtype=float)
    return float(arr) if arr.ndim == 0 else arr[:, None]


def standard_positions(
    vx0: ArrayLike, vxf: ArrayLike, width: ArrayLike, taus: ArrayLike, t: ArrayLike
) -> tuple[Array, Array]:
    """Relative (x, y) of eq. 2 and eq. 4 exactly (starts with no lateral motion and no
    longitudinal acceleration), shaped (n_tau, n_t), in fewer operations than `cluster`:
    with u = t / tau and s = min(u, 1), y = W (10 s^3 - 15 s^4 + 6 s^5) and
    x = tau (vxf u - (vxf - vx0) (s - s^3 + s^4 / 2)) (straight at vxf after tau)."""
    tau = np.asarray(taus, dtype=float)[:, None]
    vx0, vxf, width = _per_row(vx0), _per_row(vxf), _per_row(width)  # (n,) -> per row
    return standard_positions_at(vx0, vxf, width, tau, np.asarray(t, dtype=float)[None, :])


def standard_positions_at(
    vx0: ArrayLike, vxf: ArrayLike, width: ArrayLike, tau: ArrayLike, t: ArrayLike
) -> tuple[Array, Array]:
    """`standard_positions` at matching (tau, t) pairs (broadcast elementwise):
    `standard_xy` at each."""
    return _elementwise(vx0, vxf, width, tau, t, velocity=False)


def standard_velocities(
    vx0: ArrayLike, vxf: ArrayLike, width: ArrayLike, taus: ArrayLike, t: ArrayLike
) -> tuple[Array, Array]:
    """(x', y') of eq. 2 and eq. 4 at matching (tau, t) pairs (broadcast elementwise):
    `standard_velocity` at each."""
    return _elementwise(vx0, vxf, width, taus, t, velocity=True)


def _elementwise(vx0: ArrayLike, vxf: ArrayLike, width: ArrayLike, tau: ArrayLike,
                 t: ArrayLike, *, velocity: bool) -> tuple[Array, Array]:
    args = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (vx0, vxf, width, tau, t)))
    shape = args[0].shape
    a, b = _standard_flat(*(np.ascontiguousarray(x).reshape(-1) for x in args), velocity)
    return a.reshape(shape), b.reshape(shape)


@njit
def standard_xy(vx0: float, vxf: float, width: float, tau: float,
                t: float) -> tuple[float, float]:
    """Relative (x, y) at time t >= 0 of eq. 2 and eq. 4 from rest (no lateral motion, no
    longitudinal acceleration at the start): with u = t / tau and s = min(u, 1),
    y = W (10 s^3 - 15 s^4 + 6 s^5), x = tau (vxf u - (vxf - vx0) (s - s^3 + s^4 / 2))
    (straight at vxf after tau). One formula for the numpy functions above and the
    collision check (compiled)."""
    u = t * (1.0 / tau)
    s = min(u, 1.0)
    s3 = s * s * s
    y = ((s * 6.0 - 15.0) * s + 10.0) * s3 * width
    x = (((s3 * s * 0.5 - s3) + s) * (vx0 - vxf) + u * vxf) * tau
    return x, y


@njit
def standard_velocity(vx0: float, vxf: float, width: float, tau: float,
                      t: float) -> tuple[float, float]:
    """(x', y') of eq. 2 and eq. 4 from rest: x' = vx0 + (vxf - vx0) (3 s^2 - 2 s^3),
    y' = 30 W s^2 (1 - s)^2 / tau, s = min(t / tau, 1)."""
    s = min(t / tau, 1.0)
    xd = (s * -2.0 + 3.0) * s * s * (vxf - vx0) + vx0
    yd = (1.0 - s) * s
    return xd, yd * yd * (30.0 * width) / tau


@njit
def standard_bounds(vx0: float, vxf: float, width: float,
                    tau: float) -> tuple[float, float, float, float, float]:
    """Bounds over a whole lane change of eq. 2 / eq. 4 from rest: (least x' m/s, most x'
    m/s, most |y'| m/s, most heading rate rad/s, most |heading| rad). x' stays between vx0
    and vxf; |y'| <= 1.875 |W| / tau; |y''| <= 5.7736 |W| / tau^2; |x''| <= 1.5 |vxf - vx0|
    / tau; heading rate <= |y''| / x' + |y'| |x''| / x'^2 (x' taken as at least 1 mm/s)."""
    v_min, v_max = min(vx0, vxf), max(vx0, vxf)
    v_lo = max(v_min, 1e-3)
    w = abs(width)
    yd = 1.875 * w / tau
    rate = 5.7736 * w / tau**2 / v_lo + yd * (1.5 * abs(vxf - vx0) / tau) / v_lo**2
    return v_min, v_max, yd, rate, math.atan(yd / v_lo)


# A lane change from rest (eq. 2 / eq. 4) in closed form, placed in the world: what the
# prediction hands the collision check for every C2 duration and C3 quintic broadcast.
LANE_CHANGE = np.dtype([
    ("v0", np.float64),  # m/s, longitudinal speed at the start
    ("vxf", np.float64),  # m/s, target speed
    ("width", np.float64),  # m, signed lateral displacement W
    ("tau", np.float64),  # s, duration
    ("x0", np.float64),  # m, global x at the start
    ("y0", np.float64),  # m, global y at the start
    ("start", np.float64),  # s, start time on the clock of the check (<= 0: under way)
])


@njit
def lane_change_state(v0: float, vxf: float, width: float, tau: float, x0: float, y0: float,
                      start: float, t: float) -> tuple[float, float, float, float, float]:
    """Global (x m, y m, heading rad, x' m/s, y' m/s) at time t of the lane change from
    rest (eq. 2 / eq. 4) of duration tau that starts at (x0, y0) at time `start`: the one
    closed form of a C2 / C3 trajectory (the fields of `LANE_CHANGE`)."""
    s = t - start
    x, y = standard_xy(v0, vxf, width, tau, s)
    xd, yd = standard_velocity(v0, vxf, width, tau, s)
    return x + x0, y + y0, math.atan2(yd, xd), xd, yd


@njit
def standard_tau_sensitivity(vx0: float, vxf: float, width: float,
                             tau: float) -> tuple[float, float, float]:
    """Bounds, over all times and every duration >= tau, of how the pose of eq. 2 / eq. 4
    from rest moves with the duration: (|dx/dtau| m/s, |dy/dtau| m/s, |dheading/dtau|
    rad/s). With s = t / tau: dx/dtau = (vx0 - vxf) s^3 (2 - 1.5 s) (<= 0.5 |vxf - vx0|),
    dy/dtau = -30 W s^3 (1 - s)^2 / tau (<= 1.0368 |W| / tau), dx'/dtau <= 0.8889
    |vxf - vx0| / tau (m/s^2), dy'/dtau <= 4.0673 |W| / tau^2; heading = atan2(y', x') moves by
    at most |dy'| / x' + |y'| |dx'| / x'^2. Each decreases with tau."""
    v_lo = max(min(vx0, vxf), 1e-3)
    w, dv = abs(width), abs(vxf - vx0)
    yd = 1.875 * w / tau
    rate = 4.0673 * w / (tau * tau) / v_lo + yd * (0.8889 * dv / tau) / (v_lo * v_lo)
    return 0.5 * dv, 1.0368 * w / tau, rate * (1.0 + 1e-9)


@njit
def _standard_flat(vx0: Array, vxf: Array, width: Array, tau: Array, t: Array,
                   velocity: bool) -> tuple[Array, Array]:
    a, b = np.empty(t.size), np.empty(t.size)
    for i in range(t.size):
        if velocity:
            a[i], b[i] = standard_velocity(vx0[i], vxf[i], width[i], tau[i], t[i])
        else:
            a[i], b[i] = standard_xy(vx0[i], vxf[i], width[i], tau[i], t[i])
    return a, b


def cluster(bc: BoundaryConditions, taus: ArrayLike, t: ArrayLike, *,
            order: int = 0) -> tuple[Array, Array]:
    """Relative (x(t), y(t)) of every candidate, or their `order`-th derivatives,
    shaped (n_tau, n_t) (eq. 2, 4). Past tau the candidate drives straight at vxf."""
    return cluster_derivatives(bc, taus, t, (order,))[order]


def jerk_costs(
    vx0: float, vxf: float, width: float, taus: ArrayLike
) -> tuple[Array, Array]:
    """Closed-form Jx = int jx^2/2 dt = 6 (vx0 - vxf)^2 / tau^3 and
    Jy = int jy^2/2 dt = 360 W^2 / tau^5 (eq. 1, 3) for the paper's boundary conditions."""
    tau = np.asarray(taus, dtype=float)
    return 6.0 * (vx0 - vxf) ** 2 / tau**3, 360.0 * width**2 / tau**5


@dataclass(frozen=True)
class LaneChangeTrajectory:
    """One planned lane change in global coordinates: a reference for the controller.

    Holds the start time and state; evaluates position, heading, Vx* (eq. 14),
    KL (eq. 15) at absolute simulation times (arrays allowed).
    """

    t0: float  # s, simulation time the manoeuvre starts
    tau: float  # s, duration
    x0: float  # m, global x of the CG at t0
    y0: float  # m, global y of the CG at t0
    vx0: float  # m/s, longitudinal speed at t0
    vxf: float  # m/s, longitudinal speed at t0 + tau
    width: float  # m, signed lateral displacement (+ to the left)
    ax0: float = 0.0  # m/s^2, longitudinal acceleration at t0
    vy0: float = 0.0  # m/s, lateral speed at t0
    ay0: float = 0.0  # m/s^2, lateral acceleration at t0

    @property
    def boundary(self) -> BoundaryConditions:
        """The start and end this lane change shares with its cluster."""
        return BoundaryConditions(self.vx0, self.vxf, self.width, self.ax0, self.vy0,
                                  self.ay0)

    @property
    def t_end(self) -> float:
        """s, simulation time the manoeuvre ends."""
        return self.t0 + self.tau

    @property
    def y_final(self) -> float:
        """m, global y at the end (target lane centre)."""
        return self.y0 + self.width

    @functools.cached_property
    def _rows(self) -> tuple[Array, Array]:
        """(its tau as a 1 x 1 grid, its coefficient rows): `cluster_derivatives`'s for
        this one candidate, computed once (a policy reads a trajectory many times)."""
        tau = np.array([[self.tau]])
        x_c, y_c = polynomial_coefficients(self.boundary, tau)
        rows = _row_coefficients(x_c + y_c + [np.asarray(self.vxf, dtype=float)], tau)
        assert rows is not None
        return tau, rows

    def derivative(self, t: ArrayLike, order: int) -> tuple[Array, Array]:
        """(x, y) or their derivatives of `order` at absolute times t (same shape as t;
        `cluster` of its one duration)."""
        tt = np.asarray(t, dtype=float)
        tau, rows = self._rows
        rel = (tt.ravel() - self.t0)[None, :]
        ts = np.minimum(np.maximum(rel, 0.0), tau)
        x, y = _cluster_order(rows, ts, rel - ts, order)
        x, y = x[0].reshape(tt.shape), y[0].reshape(tt.shape)
        if order == 0:
            return x + self.x0, y + self.y0
        return x, y

    def position(self, t: ArrayLike) -> tuple[Array, Array]:
        """m, global (x, y) of the reference CG."""
        return self.derivative(t, 0)

    def heading(self, t: ArrayLike) -> Array:
        """rad, path tangent angle atan2(y', x')."""
        vx, vy = self.derivative(t, 1)
        return np.arctan2(vy, vx)

    def speed(self, t: ArrayLike) -> Array:
        """m/s, Vx* = sqrt(x'^2 + y'^2) (eq. 14)."""
        vx, vy = self.derivative(t, 1)
        return np.hypot(vx, vy)

    def acceleration(self, t: ArrayLike) -> Array:
        """m/s^2, dVx*/dt = (x' x'' + y' y'') / Vx*."""
        vx, vy = self.derivative(t, 1)
        ax, ay = self.derivative(t, 2)
        return (vx * ax + vy * ay) / np.hypot(vx, vy)

    def curvature(self, t: ArrayLike) -> Array:
        """1/m, KL = (x' y'' - y' x'') / (x'^2 + y'^2)^(3/2) (eq. 15)."""
        vx, vy = self.derivative(t, 1)
        ax, ay = self.derivative(t, 2)
        return (vx * ay - vy * ax) / np.hypot(vx, vy) ** 3
