"""The yaw moment the wheels' friction leaves on a curve (beyond the paper).

The MIMO law holds the heading on the path's tangent (zero sideslip). For the
oversteering Table 1 car that takes a yaw moment of kappa (L lr Cr - lf M Vx^2) against
the turn (`closed_loop.curve_yaw_moment`), made by differential wheel forces (eq. 30
shares it out equally), and it leaves the front axle most of the cornering force (the
rear's slip is only lr kappa: the front carries 85 % on R 400 m at 28 m/s). On a curve
at speed both fall on the inner front wheel, which the lateral load transfer unloads:
R 400 m at 28 m/s (2 m/s^2) on mu 0.8 keeps it at 0.8 of its friction while the lane is
kept, and a lane change to the inner lane (up to 3.6 m/s^2) asks it for more than it
has (the yaw-moment limit, `closed_loop.YAW_MOMENT_SHARE`, is centred on the curve's
moment, and allowed 4.4 kN m). Its lateral force then falls short of eq. 21's, the car
runs wide (ye 7 cm), and the law's integrators wind up: 1.6 cm are left 10 s later.

So on a curve the yaw moment is also held where no wheel is asked for more than a share
`use` of its friction at the plan's accelerations (Vx^2 KL across, dVx*/dt along, the
wheels driving with M dVx*/dt plus the air's drag; not the speed loop's transients):
each wheel's load (static, plus the transfers), its friction mu (1 + p_D2
dfz) Fz, its lateral force the axle's share by load of the single-track car's (front
(lr M ay - dMz) / L, rear (lf M ay + dMz) / L: a moment against the turn loads the
front), its longitudinal force Fa / 4 -+ dMz / (4 ls) (eq. 30 with the steering's small
angle left out), and (Fx^2 + Fy^2) <= (use mu Fz)^2 (a friction circle). Each wheel
gives a range of dMz (its quadratic's roots); the yaw moment is held in all four. Where
they have none in common (the path asks for more than `use` of some wheel whatever the
moment) the moment is the one that loads the most used wheel least (the smallest `use`
that has a common range, by bisection). Held there, the heading gives instead of the
path: the rear tyres take more of the cornering force and the front ones keep the grip
the path needs. That R 400 m change: largest |ye| 6.7 mm and an IAE of 0.023 m s (7.3
cm and 0.26 m s before; the same change on the straight road at 110 km/h: 4.3 mm,
0.014 m s; at the same speed, 28.2 m/s: 5.7 mm, 0.019 m s), its phi_e IAE 0.78 deg s
(0.40 before). On the curved motorway a change with tau 4 s at 30 m/s on mu 0.6 keeps
within 4.1 mm instead of 15 (the straight road's: 3.4 mm;
tests/control/test_curved_road.py); curved_case1_overtaking and the study_curved runs
(tau 6.2 s) never reach the range and are unchanged.
"""

from __future__ import annotations

import math

from cosim.compiled import Array, njit
from cosim.vehicle.tyre import T_PD2

from .cornering import (
    F_DLAT_F,
    F_DLAT_R,
    F_DLONG,
    F_FZ0F,
    F_FZ0R,
    F_LF,
    F_LR,
    F_LS,
    F_MASS,
    F_MU,
    F_TYRE,
)

# -, the share of each wheel's friction the yaw moment may load it to on a curve
GRIP_USE = 0.9  # tuned: docs/tuned_constants.md
BISECTION_STEPS = 20  # the least use where none is within GRIP_USE, to 1e-6 of 4
USE_MAX = 4.0  # -, the bisection's upper end (a wheel at four times its friction)


@njit
def wheel_moment_range(a: float, b: float, c: float, d: float, r: float
                       ) -> tuple[float, float]:
    """N m, (lo, hi): the yaw moments dMz with (a dMz + b)^2 + (c dMz + d)^2 <= r^2 (one
    wheel's longitudinal and lateral force, both linear in dMz, within a circle of
    radius r); lo > hi when there are none."""
    qa = a * a + c * c
    qb = a * b + c * d
    disc = qb * qb - qa * (b * b + d * d - r * r)
    if disc < 0.0:
        return 1.0, -1.0
    root = math.sqrt(disc)
    return (-qb - root) / qa, (-qb + root) / qa


@njit
def moment_range(f: Array, ay: float, ax: float, fa: float, use: float
                 ) -> tuple[float, float]:
    """N m, (lo, hi): the yaw moments that load no wheel beyond `use` of its friction at
    lateral acceleration ay and longitudinal ax (m/s^2) with the drive force Fa (N)
    (module docstring); f: `cornering.cornering_params`. lo > hi: none."""
    m, lf, lr, ls = f[F_MASS], f[F_LF], f[F_LR], f[F_LS]
    wheelbase = lf + lr
    shift = f[F_DLONG] * ax
    lo, hi = -math.inf, math.inf
    for wheel in range(4):  # FL, FR, RL, RR
        front = wheel < 2
        fz0 = f[F_FZ0F] if front else f[F_FZ0R]
        lateral = (f[F_DLAT_F] if front else f[F_DLAT_R]) * ay
        base = fz0 - shift if front else fz0 + shift
        left_load, right_load = base - lateral, base + lateral
        fz = left_load if wheel % 2 == 0 else right_load
        if fz <= 0.0:  # a lifted wheel gives nothing either way
            continue
        axle = left_load + right_load
        share = fz / axle
        scale = 1.0 + f[F_TYRE + T_PD2] * (fz / fz0 - 1.0)
        radius = use * f[F_MU] * max(scale, 0.05) * fz
        a = (-1.0 if wheel % 2 == 0 else 1.0) / (4.0 * ls)
        if front:
            c, d = -share / wheelbase, share * lr * m * ay / wheelbase
        else:
            c, d = share / wheelbase, share * lf * m * ay / wheelbase
        w_lo, w_hi = wheel_moment_range(a, 0.25 * fa, c, d, radius)
        lo, hi = max(lo, w_lo), min(hi, w_hi)
    return lo, hi


@njit
def grip_moment_range(f: Array, ay: float, ax: float, fa: float, use: float
                      ) -> tuple[float, float]:
    """N m, (lo, hi): `moment_range` at `use`, or where it has none, at the least use
    that has one (the moment that loads the most used wheel least)."""
    lo, hi = moment_range(f, ay, ax, fa, use)
    if lo <= hi:
        return lo, hi
    below, above = use, USE_MAX
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (below + above)
        lo, hi = moment_range(f, ay, ax, fa, mid)
        if lo <= hi:
            above = mid
        else:
            below = mid
    lo, hi = moment_range(f, ay, ax, fa, above)
    if lo > hi:  # beyond USE_MAX (a car on its side): no moment
        return 0.0, 0.0
    return lo, hi
