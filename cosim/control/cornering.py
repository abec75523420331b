"""Steady-cornering feed-forward on curved roads (beyond the paper): the steering and
yaw moment the two-track car's tyres need on a curve beyond what the MIMO law's
linear single-track model (eq. 21) gives it.

The law's steady-state term (us = -B^-1 A0) is exact for tyres whose lateral force is
Cf alpha, Cr alpha. The two-track plant's tyres (`cosim.vehicle.tyre`: Magic Formula,
load-sensitive cornering stiffness, lateral load transfer) give less force at the same
slip as the lateral acceleration grows: on the curved motorway (R 800 m at 31 m/s,
1.2 m/s^2) the front axle needs 7 % more slip than the linear model says. The law's
integrators make up the difference, but only after ye has built up (their poles decay
at ~0.25 /s with the paper's gains), so without a feed-forward each change of the
road's curvature leaves a few millimetres of ye that take seconds to fade: on curves a
lane-keeping error 6x that of the straight road. This is Rajamani's lane-keeping feed-forward
(Vehicle Dynamics and Control, 2nd ed., sec. 3.2: delta_ff = L kappa + K_v a_y), with
the understeer gradient K_v taken from the tyres' own curve instead of a constant.

On a circle of curvature kappa at speed vx with zero sideslip (what the MIMO law
aims at, phi_e = 0), the rear tyres' slip is fixed by the kinematics, tan(alpha_r) =
lr kappa; the rear axle gives Fyr(alpha_r) at its loads (static, plus the longitudinal
transfer of the car's acceleration, -+ the lateral transfer of ay), the front
axle must give M vx^2 kappa - Fyr, which fixes its slip alpha_f (Newton on the front
tyres' curve at their loads), and the steering is alpha_f + lf kappa. Each wheel also
drives: a quarter of Fa plus -+ the differential force of the yaw moment the law asks
for on the circle (eq. 30's split), and the longitudinal slip that takes costs lateral
grip (the tyres' combined slip, `long_slip`); the steered front wheels' drive force
pushes sideways by sin(delta). The acceleration that moves load is Fa's less the air's
drag (at a steady 31 m/s Fa is all drag, and the load stays). Measured against the
plant's own steady state (closed loop settled on R 800 m at 31 m/s): this gives the
steering it needs beyond eq. 21 within 0.24 %; with the load moved by Fa / M and no
combined slip it is 6.8 % off, and the law's integrators hold the difference (kyI int(ye)
6e-3 m/s^2 on R 1000 m, against 1.5e-4 with both), to be unwound, ye a millimetre off,
wherever the curve ends. The linear model
gives Fyr = Cr lr kappa and alpha_f = (M vx^2 kappa - Cr lr kappa) / Cf. The
feed-forward is the difference: d_delta = alpha_f - alpha_f,lin and, from the yaw
moment balance dMz = -(lf Fyf - lr Fyr), d_dMz = L (Fyr - Cr lr kappa). Near the front
tyres' peak (or past it: then no circle is held with zero sideslip, the car will slip)
d_delta is held at CAP of the linear front slip: uncapped, a brisk lane change on a
curve oscillates (docs/tuned_constants.md).

`curve_feed_forward` is what the closed loop adds: this at the path's curvature less
this at the path's curvature without the road's (the curve's own need and what it adds
to a lane change's; a lane change's own is left to the integrators, as on the
straight road, where it is 0 and the paper's law is unchanged).

The tyres' lateral force follows their slip with the relaxation length sigma_alpha
(0.5 m: a lag in distance, 16 ms at 31 m/s), so a curve's force arrives that late: the
closed loop takes the road's curvature sigma_alpha ahead of the car (`closed_loop`;
out of the curved motorway's first curve with the lane kept, an IAE of ye of
0.0004 m s against 0.0025 without). The feed-forward and this preview are for the
road's curve only; where the road is straight the paper's law is unchanged, bit for bit.

The controller's model of the tyres: the chassis' tyre curve and load transfer with
Table 1's Cf, Cr as the cornering stiffness at the static load (a plant built with
`ChassisParams.cornering_scale` != 1 differs from it, as it differs from eq. 21). The
bicycle plant's tyres are linear: no feed-forward (`enabled` 0).
"""

from __future__ import annotations

import math

from cosim.compiled import Array, njit
from cosim.params import VehicleParams
from cosim.vehicle.chassis import ChassisParams, static_wheel_loads, transfer_per_wheel
from cosim.vehicle.tyre import T_CK, T_CX, T_MUX, T_PD2, combined_forces

# Layout of the feed-forward's constant array; the tyre's coefficients follow at F_TYRE.
(F_ON, F_MASS, F_LF, F_LR, F_KAF, F_KAR, F_FZ0F, F_FZ0R, F_DLAT_F, F_DLAT_R, F_MU,
 F_DLONG, F_PREVIEW, F_DRAG, F_LS, F_TYRE) = range(16)
# -, the largest feed-forward as a share of the linear front slip
CAP = 0.25  # tuned: docs/tuned_constants.md
NEWTON_STEPS = 6  # the front slip converges to 1e-12 rad in 3 at 40 % of the friction


def cornering_params(vehicle: VehicleParams, chassis: ChassisParams, mu: float,
                     enabled: bool) -> Array:
    """The feed-forward's constants for `steady_cornering` (enabled False: it gives 0)."""
    import numpy as np

    fz0f, fz0r = static_wheel_loads(vehicle)
    dlat, dlong = transfer_per_wheel(vehicle, chassis)  # N per m/s^2
    head = [1.0 if enabled else 0.0, vehicle.mass, vehicle.lf, vehicle.lr,
            vehicle.cf / 2.0, vehicle.cr / 2.0, fz0f, fz0r,
            dlat * chassis.roll_share_front, dlat * (1.0 - chassis.roll_share_front), mu,
            dlong, chassis.tyre.relaxation_lat, vehicle.drag, vehicle.half_track]
    return np.array(head + chassis.tyre.array(), dtype=float)


@njit
def long_slip(f: Array, fx: float, fz: float, fz0: float) -> float:
    """-, the longitudinal slip at which one wheel at load fz (static fz0) gives fx (N)
    at zero slip angle: the pure-slip curve inverted (its E taken as 0)."""
    if fx == 0.0 or fz <= 0.0:
        return 0.0
    o = F_TYRE
    scale = 1.0 + f[o + T_PD2] * (fz / fz0 - 1.0)
    mu_x = f[F_MU] * (scale if scale > 0.05 else 0.05) * f[o + T_MUX]
    cx = f[o + T_CX]
    u = min(max(fx / (mu_x * fz), -0.95), 0.95)
    return math.tan(math.asin(u) / cx) * cx * mu_x / f[o + T_CK]


@njit
def axle_loads(fz0: float, dlong: float, dlat: float, ay: float) -> tuple[float, float]:
    """N, (left, right) wheel loads of one axle: static fz0 shifted by the longitudinal
    transfer dlong (+ onto this axle) and the lateral one dlat * ay (left loses, right
    gains for ay > 0)."""
    return fz0 + dlong - dlat * ay, fz0 + dlong + dlat * ay


@njit
def axle_force(f: Array, tan_alpha: float, fz0: float, fzl: float, fzr: float,
               kl: float, kr: float, k_alpha: float) -> float:
    """N, the lateral force of one axle's two wheels at the same slip, at loads fzl, fzr
    (`axle_loads`; static fz0) and longitudinal slips kl, kr (`long_slip`: the slip their
    drive force needs takes lateral grip: combined slip)."""
    inv = 1.0 / fz0
    mu = f[F_MU]
    _, left = combined_forces(kl, tan_alpha, fzl, inv, k_alpha, mu, f, F_TYRE)
    _, right = combined_forces(kr, tan_alpha, fzr, inv, k_alpha, mu, f, F_TYRE)
    return left + right


@njit
def steady_cornering(f: Array, vx: float, kappa: float, ax: float, fa: float
                     ) -> tuple[float, float]:
    """(d_delta rad, d_dMz N m): what the tyres need on a circle of curvature kappa at
    speed vx beyond the linear model's steady-state inputs (module docstring), the car
    accelerating at ax (m/s^2: load moves to the rear axle) with the wheels driving with
    Fa (N, a quarter each) plus the differential forces of the linear model's yaw
    moment; (0, 0) when disabled or on a straight line."""
    if f[F_ON] == 0.0 or kappa == 0.0:
        return 0.0, 0.0
    m, lf, lr, kaf, kar = f[F_MASS], f[F_LF], f[F_LR], f[F_KAF], f[F_KAR]
    ay = vx * vx * kappa
    rear_lin = 2.0 * kar * lr * kappa
    shift = f[F_DLONG] * ax
    # the wheels' longitudinal forces: Fa shared, the yaw moment the law asks for on this
    # circle (`closed_loop.curve_yaw_moment`) made by left / right differences (eq. 30)
    dfx = kappa * (2.0 * kar * lr * (lf + lr) - lf * m * vx * vx) / (4.0 * f[F_LS])
    fxq = 0.25 * fa
    fx_l, fx_r = fxq - dfx, fxq + dfx
    fz0r, fz0f = f[F_FZ0R], f[F_FZ0F]
    rl, rr = axle_loads(fz0r, shift, f[F_DLAT_R], ay)
    rear = axle_force(f, lr * kappa, fz0r, rl, rr, long_slip(f, fx_l, rl, fz0r),
                      long_slip(f, fx_r, rr, fz0r), kar)
    need = m * ay - rear
    alpha_lin = (m * ay - rear_lin) / (2.0 * kaf)
    # the front wheels' drive force turned with them pushes sideways (sin delta ~ delta)
    need = need - (fx_l + fx_r) * (alpha_lin + lf * kappa)
    fl, fr = axle_loads(fz0f, -shift, f[F_DLAT_F], ay)
    kl, kr = long_slip(f, fx_l, fl, fz0f), long_slip(f, fx_r, fr, fz0f)
    alpha = need / (2.0 * kaf)
    for _ in range(NEWTON_STEPS):
        g = axle_force(f, alpha, fz0f, fl, fr, kl, kr, kaf) - need
        da = 1e-6 * (abs(alpha) + 1e-6)
        slope = (axle_force(f, alpha + da, fz0f, fl, fr, kl, kr, kaf) - g - need) / da
        if not slope > 0.0:  # past the tyres' peak: no steady state to aim at
            break
        step = g / slope
        alpha -= step
        if abs(step) < 1e-12:
            break
    # where the tyres need much more than the linear model (near the front axle's peak,
    # or past it: no steady state with zero sideslip) the car will sideslip anyway;
    # the feed-forward is held at CAP of the linear slip there (it stays continuous)
    cap = CAP * abs(alpha_lin)
    return min(max(alpha - alpha_lin, -cap), cap), (lf + lr) * (rear - rear_lin)


@njit
def curve_feed_forward(f: Array, vx: float, kappa: float, k_road: float, ax: float,
                       fa: float) -> tuple[float, float]:
    """(d_delta rad, d_dMz N m) the closed loop adds on a road of curvature k_road (the
    road's line through the car) while its path curves at kappa (KL, the road's curve
    and a lane change's together): `steady_cornering` at kappa less at kappa - k_road.
    So the curve's own need is fed forward, and so is what it adds to a lane change's
    (the tyres give less at the curve's slip than at none), while a lane change's own
    need beyond eq. 21 is left to the law's integrators as on the straight road, where
    this is 0 (k_road = 0: the paper's law, unchanged)."""
    if k_road == 0.0:
        return 0.0, 0.0
    d1, m1 = steady_cornering(f, vx, kappa, ax, fa)
    d0, m0 = steady_cornering(f, vx, kappa - k_road, ax, fa)
    return d1 - d0, m1 - m0
