"""The planned reference as the controller sees it: fast scalar evaluation of a
`LaneChangeTrajectory` and the path errors ye, phi_e (eq. 16) by projection.

`LaneChangeTrajectory` evaluates arrays; the controller needs one point many
thousand times a second, so this takes the same polynomial coefficients
(`longitudinal_coefficients`, `lateral_coefficients`) once and evaluates them
with Python floats. Before t0 the path is extended straight back along its
initial tangent (the trajectory class holds x0 there), after t0 + tau it runs
straight at vxf in the target lane, as the class does.

Errors (the paper's definitions, Section 4.1): ye is the signed distance from
the CG to the closest point of the path (+ when the car is left of it), phi_e
the heading minus the path's tangent angle there, KL the path curvature there
(eq. 15). Vx* (eq. 14) and dVx*/dt are taken at the current time: the paper
tracks speed in time and the path in space.

Low speed (stop-and-go): the path is parameterised by time, so where the reference
stands still (x' -> 0) its tangent, curvature and the projection's Gauss-Newton step
would divide by zero. The geometry therefore uses the along-road speed floored at
PATH_SPEED_FLOOR (every path here runs along +x, eq. 2: x is the along-road
coordinate): a reference at rest points along the road, the projection stops where
the path does not move, Vx* is the path's speed (never negative: the car does not
reverse) and dVx*/dt its along-path acceleration, so a reference starting from rest
carries its feed-forward. Above the floor nothing changes, operation by operation.

Speed: the evaluation, projection and errors are compiled (numba,
`cosim.compiled`) on the path's coefficient array (`ReferencePath.coef`),
so the closed loop's compiled substep loop calls them directly; the methods
wrap the same functions.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np

from cosim.compiled import Array, njit
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.road.frame import FP_D_OFFSET, point_of_frame, pose_in_frame

Point = tuple[float, float, float, float, float, float]
# Layout of the coefficient array: t0, tau, x polynomial (5), y polynomial (6),
# the path at t0 + tau (x, y, x', y', x'', y''), vxf.
N_COEF = 20
PATH_SPEED_FLOOR = 0.1  # m/s, along-road path speed below which the geometry uses this


class PathErrors(NamedTuple):
    """The tracking errors of one state against the reference (immutable)."""

    ye: float  # m, lateral offset from the closest path point (+ left)
    phi_e: float  # rad, heading error (+ counter-clockwise of the path tangent)
    ye_dot: float  # m/s, d ye/dt
    phi_e_dot: float  # rad/s, d phi_e/dt
    kappa: float  # 1/m, KL at the closest point (eq. 15)
    s: float  # s, path parameter (trajectory time) of the closest point
    vx_ref: float  # m/s, Vx*(t) (eq. 14)
    ax_ref: float  # m/s^2, dVx*/dt at t
    x_ref: float  # m, global x of the reference at time t
    y_ref: float  # m, global y of the reference at time t
    along: float  # m, position error along the path at time t (+ ahead of the plan)


@njit
def wrap_angle(a: float) -> float:
    """rad, a wrapped into [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@njit
def path_poly(c: Array, ts: float) -> Point:
    """(x, y, x', y', x'', y'') of the polynomials at trajectory time ts (s after t0)."""
    a0, a1, a2, a3, a4 = c[2], c[3], c[4], c[5], c[6]
    b0, b1, b2, b3, b4, b5 = c[7], c[8], c[9], c[10], c[11], c[12]
    x = a0 + ts * (a1 + ts * (a2 + ts * (a3 + ts * a4)))
    dx = a1 + ts * (2.0 * a2 + ts * (3.0 * a3 + ts * 4.0 * a4))
    ddx = 2.0 * a2 + ts * (6.0 * a3 + ts * 12.0 * a4)
    y = b0 + ts * (b1 + ts * (b2 + ts * (b3 + ts * (b4 + ts * b5))))
    dy = b1 + ts * (2.0 * b2 + ts * (3.0 * b3 + ts * (4.0 * b4 + ts * 5.0 * b5)))
    ddy = 2.0 * b2 + ts * (6.0 * b3 + ts * (12.0 * b4 + ts * 20.0 * b5))
    return x, y, dx, dy, ddx, ddy


@njit
def path_point(c: Array, t: float) -> Point:
    """(x, y, x', y', x'', y'') of the path at absolute time t: straight back along the
    initial tangent before t0, straight at vxf in the target lane after t0 + tau."""
    ts = t - c[0]
    tau = c[1]
    if ts <= 0.0:
        x0, y0, dx, dy, ddx, ddy = path_poly(c, 0.0)
        return x0 + dx * ts, y0 + dy * ts, dx, dy, ddx, ddy
    if ts >= tau:
        vxf = c[19]
        return c[13] + vxf * (ts - tau), c[14], vxf, 0.0, 0.0, 0.0
    return path_poly(c, ts)


@njit
def path_project(c: Array, x: float, y: float, guess: float) -> tuple[float, Point]:
    """(s, point(s)): the path parameter (absolute time) of the point closest to (x, y),
    by Gauss-Newton from `guess` (the last projection),
    s += (P - p(s)) . p'(s) / |p'(s)|^2, stopped when the step is below 1e-7 s
    (a few micrometres at highway speed); where the path's along-road speed is below
PATH_SPEED_FLOOR the point does not move with s and the search stops."""
    s = guess
    for _ in range(8):
        pt = path_point(c, s)
        px, py, dx, dy = pt[0], pt[1], pt[2], pt[3]
        if dx < PATH_SPEED_FLOOR:  # the path stands (nearly) still here: s is as good as any
            return s, pt
        ds = ((x - px) * dx + (y - py) * dy) / (dx * dx + dy * dy)
        if abs(ds) < 1e-7:
            return s, pt
        s += ds
    return s, path_point(c, s)


@njit
def path_errors(
    c: Array, t: float, x: float, y: float, heading: float, vx: float, vy: float,
    yaw_rate: float, guess: float,
) -> tuple[float, float, float, float, float, float, float, float, float, float, float]:
    """The fields of `PathErrors` (in order) for a CG state at time t (a straight road:
    the path's plane is the Cartesian plane)."""
    return road_path_errors(c, t, x, y, heading, vx, vy, yaw_rate, guess, 0.0, 0.0)


@njit
def frame_path_errors(
    c: Array, fp: Array, fr: Array, t: float, x: float, y: float, heading: float,
    vx: float, vy: float, yaw_rate: float, guess: float, s_hint: float,
) -> tuple[float, float, float, float, float, float, float, float, float, float, float,
           float, float, float, float]:
    """The fields of `PathErrors` for a Cartesian CG state and a path given in the road
    frame (s, d) (`cosim.road.frame`, packed: fp, fr), then the car's s, d and heading
    relative to the road, and the curvature of the road's line through the car (1/m).
    The car's pose goes into the frame, the errors are taken there (`road_path_errors`,
    with the road's curvature), and x_ref, y_ref come back Cartesian. On a StraightFrame
    at the origin every value equals `path_errors`'."""
    sv, dv, th_r, k_r = pose_in_frame(fp, fr, x, y, s_hint)
    rel = heading - th_r
    e = road_path_errors(c, t, sv, dv, rel, vx, vy, yaw_rate, guess, k_r, fp[FP_D_OFFSET])
    xr, yr, _, k_ref = point_of_frame(fp, fr, e[8], e[9])
    vx_ref, ax_ref = e[6], e[7]
    if k_ref != 0.0:  # the plan's ds/dt is the speed on the reference line: at d, q times it
        q = 1.0 - k_ref * (e[9] - fp[FP_D_OFFSET])
        vx_ref, ax_ref = vx_ref * q, ax_ref * q
    k_lane = k_r / (1.0 - k_r * (dv - fp[FP_D_OFFSET])) if k_r != 0.0 else 0.0
    return (e[0], e[1], e[2], e[3], e[4], e[5], vx_ref, ax_ref, xr, yr, e[10], sv, dv, rel,
            k_lane)


@njit
def road_path_errors(
    c: Array, t: float, x: float, y: float, heading: float, vx: float, vy: float,
    yaw_rate: float, guess: float, k_road: float, d_offset: float,
) -> tuple[float, float, float, float, float, float, float, float, float, float, float]:
    """`path_errors` in the road frame: (x, y, heading) are s, d and the heading relative
    to the road, `k_road` the road's curvature at the car (constant over the frame's
    0.5 m arc), `d_offset` the reference line's d. The path point closest in (s, d) is
    taken (the Cartesian closest to second order in the offset), and the errors are the
    Cartesian ones there: an s step at the path point's offset d_p is q = 1 - k_road
    (d_p - d_offset) times as long in the plane, so the path's tangent is (q s', d'), ye
    the offset across it, phi_e the heading against it, and KL the path's curvature in
    the plane (Werling et al. 2010, Appendix). k_road = 0: `path_errors` exactly."""
    s, (px, py, dx, dy, ddx, ddy) = path_project(c, x, y, guess)
    dx = max(dx, PATH_SPEED_FLOOR)  # at rest the path points along the road (docstring)
    if k_road == 0.0:
        v2 = dx * dx + dy * dy
        v = math.sqrt(v2)
        cth, sth = dx / v, dy / v
        ye = -(x - px) * sth + (y - py) * cth
        phi_e = wrap_angle(heading - math.atan2(dy, dx))
        kappa = (dx * ddy - dy * ddx) / (v2 * v)
    else:  # on a curve: an s step at the path point is q times as long in the plane
        q = 1.0 - k_road * (py - d_offset)
        qx = q * dx
        v = math.sqrt(qx * qx + dy * dy)
        cth, sth = qx / v, dy / v
        ye = -q * (x - px) * sth + (y - py) * cth
        phi_e = wrap_angle(heading - math.atan2(dy, qx))
        # the path's curvature in the plane (Werling et al. 2010, Appendix): d1 = dd/ds,
        # d2 = d^2d/ds^2 of the (s, d) path, the road's kappa constant over the arc
        d1 = dy / dx
        d2 = (ddy * dx - dy * ddx) / (dx * dx * dx)
        dth = math.atan2(d1, q)
        cd = math.cos(dth)
        kappa = ((d2 + k_road * d1 * math.tan(dth)) * cd * cd / q + k_road) * cd / q
    sp, cp = math.sin(phi_e), math.cos(phi_e)
    # Frenet kinematics (eq. 16 is their small-angle form)
    ye_dot = vx * sp + vy * cp
    path_rate = (vx * cp - vy * sp) / (1.0 - kappa * ye)
    phi_e_dot = yaw_rate - kappa * path_rate
    rx, ry, rdx, rdy, rddx, rddy = path_point(c, t)
    vx_ref = math.sqrt(rdx * rdx + rdy * rdy)
    if rdx < PATH_SPEED_FLOOR:  # at (or near) rest: the speed along the road, not below 0
        vx_ref = max(rdx, 0.0)
        rdx = PATH_SPEED_FLOOR
    rv = math.sqrt(rdx * rdx + rdy * rdy)
    along = ((x - rx) * rdx + (y - ry) * rdy) / rv
    return (ye, phi_e, ye_dot, phi_e_dot, kappa, s,
            vx_ref, (rdx * rddx + rdy * rddy) / rv, rx, ry, along)


@functools.lru_cache(maxsize=64)
def _powers(tau: float) -> tuple[float, float, float, float]:
    """tau^2 .. tau^5 as `longitudinal_coefficients` and `lateral_coefficients` get them
    (numpy on a 0-d array: tau^2 squared, the others numpy's own power, which can differ
    from Python's pow in the last bit), once per tau (lane keeping: always the same)."""
    t = np.asarray(tau, dtype=float)
    return float(t * t), float(t**3), float(t**4), float(t**5)


@functools.lru_cache(maxsize=256)
def _longitudinal(vx0: float, vxf: float, tau: float, ax0: float) -> tuple[float, float]:
    """`longitudinal_coefficients` as floats, remembered: the lane-keeping reference is
    rebuilt every step and often repeats them (cruising). The same operations in the
    same order on Python floats (the powers from `_powers`), so bit for bit the same
    (tests/control/test_reference.py) without numpy's cost on scalars (a miss: about
    a fifth of it)."""
    t2, t3, _, _ = _powers(tau)
    d = vxf - vx0 - ax0 * tau
    e = -ax0
    b3 = (e * tau - 2.0 * d) / t3
    b2 = (3.0 * d - e * tau) / t2
    return b2 / 3.0, b3 / 4.0


@functools.lru_cache(maxsize=256)
def _lateral(width: float, tau: float, vy0: float, ay0: float) -> tuple[float, float, float]:
    """`lateral_coefficients` as floats, remembered (lane keeping: always width 0); bit
    for bit, as `_longitudinal`."""
    t2, t3, t4, t5 = _powers(tau)
    c3 = (20.0 * width - 12.0 * vy0 * tau - 3.0 * ay0 * t2) / (2.0 * t3)
    c4 = (-30.0 * width + 16.0 * vy0 * tau + 3.0 * ay0 * t2) / (2.0 * t4)
    c5 = (12.0 * width - 6.0 * vy0 * tau - ay0 * t2) / (2.0 * t5)
    return c3, c4, c5


class ReferencePath:
    """Scalar evaluator and projector for one `LaneChangeTrajectory`."""

    def __init__(self, trajectory: LaneChangeTrajectory) -> None:
        tr = trajectory
        self.trajectory = tr
        c3x, c4x = _longitudinal(float(tr.vx0), float(tr.vxf), float(tr.tau), float(tr.ax0))
        c3y, c4y, c5y = _lateral(float(tr.width), float(tr.tau), float(tr.vy0), float(tr.ay0))
        coef = np.zeros(N_COEF)
        coef[0:13] = (float(tr.t0), float(tr.tau),
                      float(tr.x0), float(tr.vx0), 0.5 * float(tr.ax0), float(c3x), float(c4x),
                      float(tr.y0), float(tr.vy0), 0.5 * float(tr.ay0),
                      float(c3y), float(c4y), float(c5y))
        coef[13:19] = path_poly(coef, float(tr.tau))
        coef[19] = float(tr.vxf)
        self.coef = coef

    def point(self, t: float) -> Point:
        """(x, y, x', y', x'', y'') of the path at absolute time t (m, m/s, m/s^2)."""
        return path_point(self.coef, float(t))

    def speed(self, t: float) -> tuple[float, float]:
        """(Vx*, dVx*/dt) at absolute time t (eq. 14), as the controller takes them
        (`path_errors`, low-speed form included)."""
        e = path_errors(self.coef, float(t), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, float(t))
        return e[6], e[7]

    def project(self, x: float, y: float, guess: float) -> tuple[float, Point]:
        """(s, point(s)): the path parameter (absolute time) of the point closest to
        (x, y), by Gauss-Newton from `guess` (see `path_project`)."""
        return path_project(self.coef, float(x), float(y), float(guess))

    def errors(
        self, t: float, x: float, y: float, heading: float, vx: float, vy: float,
        yaw_rate: float, guess: float,
    ) -> PathErrors:
        """ye, phi_e, their rates and the reference values for a CG state at time t."""
        args = (t, x, y, heading, vx, vy, yaw_rate, guess)
        return PathErrors(*path_errors(self.coef, *(float(a) for a in args)))
