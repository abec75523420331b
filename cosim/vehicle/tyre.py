"""Tyre forces: Pacejka's Magic Formula with combined-slip weighting functions, load
sensitivity and (in the plant) a first-order relaxation length.

Source: H. B. Pacejka, Tyre and Vehicle Dynamics, 3rd ed. (with I. Besselink), 2012,
ch. 4 (sec. 4.3.2, the Magic Formula: pure slip, combined slip by the weighting
functions G_x,alpha and G_y,kappa, load dependence of stiffness and friction) and
ch. 7 (sec. 7.2, the first-order relaxation model and its low-speed damping term).
The same MF 5.2 weighting functions are what CommonRoad's multi-body model uses
(vehiclemodels/utils/tire_model.py); no camber, no shifts, no turn slip here.

Pure slip (kappa longitudinal slip, alpha tangent of the slip angle, forces + along
+ slip):
    F_x0 = D_x sin(C_x atan(B_x kappa - E_x (B_x kappa - atan(B_x kappa)))),
    F_y0 = D_y sin(C_y atan(B_y alpha - E_y (B_y alpha - atan(B_y alpha)))),
    D = mu(Fz) Fz,  B = K / (C D)  so that dF/dslip = K at zero slip.
Combined slip (Pacejka sec. 4.3.2, MF 5.2, with the shifts S_H = 0):
    F_x = G_x,alpha F_x0,  G_x,alpha = cos(C_xa atan(B_xa alpha - E_xa (B_xa alpha
                           - atan(B_xa alpha)))),  B_xa = r_bx1 cos(atan(r_bx2 kappa));
    F_y = G_y,kappa F_y0,  G_y,kappa = the same in kappa with B_yk = r_by1 cos(atan(r_by2
                           alpha)), C_yk = r_cy1, E_yk = r_ey1.
Both weights are 1 with dG/dslip = 0 at zero slip, so the small-slip cornering
stiffness is exactly K_alpha (the plant sets it to Table 1's Cf / 2, Cr / 2 per wheel
at the static load). With C > 1 the cosine would turn negative at large slip and
reverse the force; the weights are held at 0 there instead. Left out: the
kappa-induced side force S_Vy,kappa and the shifts (ply steer, conicity: they make
the tyre asymmetric). Defaults of r_bx1 ... r_cy1: the ADAMS tyre CommonRoad ships
(parameters_tire.yaml), with E_xa = E_yk = 0 (each would cost one more atan per wheel
and derivative: the plant's time is mostly these transcendentals).
Load sensitivity, with dfz = Fz / Fz0 - 1 and x = Fz / Fz0 (Fz0: the static load):
    mu(Fz) = mu (1 + p_D2 dfz)                       (Pacejka's p_Dy2, p_Dx2),
    K_alpha(Fz) = K_alpha(Fz0) x (1 + q) / (1 + q x^2),  q = 1 / p_Ky2^2,
the second being Pacejka's p_Ky1 Fz0 sin(2 atan(Fz / (p_Ky2 Fz0))) normalised to
K_alpha(Fz0) (sin(2 atan u) = 2u / (1 + u^2)): the stiffness per wheel peaks at
Fz = p_Ky2 Fz0, so load transfer within an axle lowers the axle's stiffness.
K_kappa = c_kappa Fz (proportional). p_D2 = 0, p_Ky2 = inf: no load sensitivity.

Relaxation lengths (Pacejka sec. 7.2; the plant integrates the relaxed slips):
sigma_alpha = 0.5 m (C_Falpha over a lateral carcass stiffness of ~150 kN/m), and
sigma_kappa = 0.06 m, the low end of measured values (0.05-0.2 m). The wheel's spin on
the tyre's longitudinal spring is a torsional mode of sqrt(R^2 K_kappa / (Iw sigma_kappa))
(350 rad/s at 0.06 m, 220 rad/s at 0.15 m), damped by |u| / sigma_kappa; the paper's
speed loop (eq. 28, kx1 = 200 /s at 200 Hz) drives the wheel torques near that
frequency, and from sigma_kappa = 0.08 m up it limit-cycles there (case 5.1, MIMO: the
front-left force demand's standard deviation over 1-2 s is 0.02 kN at 0.06 and 0.07 m,
0.7 kN at 0.08 m, 1.6 kN at 0.1 m, 1.8 kN at 0.15 m; measured), which a real car's
motor controllers would not allow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cosim.compiled import Array, njit
from cosim.errors import InputError

# index of each coefficient in the array the compiled functions read (`TyreParams.array`)
(T_CX, T_EX, T_CY, T_EY, T_CK, T_PD2, T_QKY, T_RBX1, T_RBX2, T_RCX1, T_RBY1, T_RBY2,
 T_RCY1, T_MUX, T_REX1, T_REY1) = range(16)
N_TYRE = 16
HALF_PI = 0.5 * math.pi


@dataclass(frozen=True)
class TyreParams:
    """Magic Formula coefficients (Pacejka, 3rd ed., sec. 4.3.2; no camber, no shifts)
    and the first-order relaxation (sec. 7.2). Defaults: a passenger-car tyre; the
    combined-slip coefficients are those of CommonRoad's ADAMS tyre."""

    shape_lat: float = 1.4  # -, C_y (> 1: a peak, then a slide)
    shape_long: float = 1.4  # -, C_x
    curvature_lat: float = 0.0  # -, E_y (< 1; 0: no flattening near the peak)
    curvature_long: float = 0.0  # -, E_x
    slip_stiffness: float = 20.0  # 1 per unit slip, K_kappa / Fz (15-25)
    friction_long_ratio: float = 1.0  # -, mu_x / mu_y (road mu is mu_y at the static load)
    # -, p_D2: d(mu)/mu per unit dfz (typical -0.05 .. -0.15; 0: mu independent of load)
    friction_load: float = -0.1
    # -, p_Ky2: load (x static) at which a wheel's cornering stiffness peaks (1.5 .. 3; inf: K
    # proportional to load)
    cornering_peak_load: float = 2.0
    r_bx1: float = 13.276  # -, G_x,alpha: B_xa = r_bx1 cos(atan(r_bx2 kappa))
    r_bx2: float = -13.778  # -
    r_cx1: float = 1.2568  # -, C_xa
    r_by1: float = 7.1433  # -, G_y,kappa: B_yk = r_by1 cos(atan(r_by2 alpha))
    r_by2: float = 9.1916  # -
    r_cy1: float = 1.0719  # -, C_yk
    r_ex1: float = 0.0  # -, E_xa (CommonRoad: 0.65225)
    r_ey1: float = 0.0  # -, E_yk (CommonRoad: -0.27572)
    relaxation_lat: float = 0.5  # m, sigma_alpha (C_Falpha / lateral carcass stiffness)
    # m, sigma_kappa (measured 0.05-0.2): the low end, see the module docstring
    relaxation_long: float = 0.06
    low_speed: float = 2.0  # m/s, V_low: below it the low-speed damping fades in
    # N s/m, k_Vlow0 per wheel at standstill: about half the critical damping of a quarter
    # car (340 kg) on the tyre's spring K / sigma (lateral 150 kN/m, longitudinal 400 kN/m)
    damping_lat: float = 7000.0
    damping_long: float = 10000.0

    def check(self) -> None:
        """Raise InputError for a coefficient outside the Magic Formula's sense."""
        for key in ("shape_lat", "shape_long"):
            if not 1.0 < getattr(self, key) < 2.0:
                raise InputError("tyre", key, getattr(self, key), "magic-formula C in (1, 2)")
        for key in ("curvature_lat", "curvature_long", "r_ex1", "r_ey1"):
            if not -5.0 < getattr(self, key) < 1.0:
                raise InputError("tyre", key, getattr(self, key), "magic-formula E in (-5, 1)")
        for key in ("slip_stiffness", "friction_long_ratio", "cornering_peak_load",
                    "relaxation_lat", "relaxation_long", "low_speed", "r_bx1", "r_by1",
                    "r_cx1", "r_cy1"):
            if not getattr(self, key) > 0.0:
                raise InputError("tyre", key, getattr(self, key), "must be > 0")
        for key in ("damping_lat", "damping_long"):
            if not getattr(self, key) >= 0.0:
                raise InputError("tyre", key, getattr(self, key), "must be >= 0")
        if not -0.5 <= self.friction_load <= 0.5:
            raise InputError("tyre", "friction_load", self.friction_load, "in [-0.5, 0.5]")

    def array(self) -> list[float]:
        """The coefficients in the order of the T_* indices (compiled code reads them)."""
        return [self.shape_long, self.curvature_long, self.shape_lat, self.curvature_lat,
                self.slip_stiffness, self.friction_load, 1.0 / self.cornering_peak_load**2,
                self.r_bx1, self.r_bx2, self.r_cx1, self.r_by1, self.r_by2, self.r_cy1,
                self.friction_long_ratio, self.r_ex1, self.r_ey1]


@njit
def combined_weight(slip: float, other: float, b1: float, b2: float, e: float,
                    c: float) -> float:
    """-, the weight G of one force under combined slip (Pacejka's cosine form):
    cos(C atan(B1 slip / sqrt(1 + (B2 other)^2) - E (...))), 0 past C atan(.) = pi / 2.
    G_x,alpha: slip = tan(alpha), other = kappa; G_y,kappa: the other way round."""
    r = b2 * other
    z = b1 * slip / math.sqrt(1.0 + r * r)
    if e != 0.0:
        z = z - e * (z - math.atan(z))
    return math.cos(min(c * math.atan(abs(z)), HALF_PI))


@njit
def combined_forces(kappa: float, alpha: float, fz: float, inv_fz0: float, k_alpha0: float,
                    mu: float, t: Array, o: int) -> tuple[float, float]:
    """N, (Fx, Fy) of one wheel: pure-slip Magic Formula times the combined-slip weights.

    kappa: longitudinal slip (-, + driving); alpha: tangent of the slip angle (+ when the
    force points to the wheel's left); fz: load (N); inv_fz0: 1 / the static load (1/N)
    the load sensitivity refers to; k_alpha0: cornering stiffness at that load (N/rad);
    mu: road friction (mu_y at the static load); t[o:o + N_TYRE]: the coefficients
    (`TyreParams.array`). The plant's hot spot: its one helper, `combined_weight`, is
    compiled inline."""
    if fz <= 0.0:
        return 0.0, 0.0
    x = fz * inv_fz0
    scale = 1.0 + t[o + T_PD2] * (x - 1.0)
    mu_y = mu * (scale if scale > 0.05 else 0.05)
    q = t[o + T_QKY]
    cx, cy = t[o + T_CX], t[o + T_CY]
    mu_x = mu_y * t[o + T_MUX]
    # pure slip, B = K / (C D): B_x = c_kappa / (C_x mu_x) (K_kappa = c_kappa Fz), and
    # B_y = K_alpha(Fz) / (C_y mu_y Fz) with K_alpha(Fz) = K_alpha0 x (1 + q) / (1 + q x^2)
    bx = t[o + T_CK] / (cx * mu_x) * kappa
    ex = t[o + T_EX]
    if ex != 0.0:
        bx = bx - ex * (bx - math.atan(bx))
    by = k_alpha0 * inv_fz0 * (1.0 + q) / ((1.0 + q * x * x) * cy * mu_y) * alpha
    ey = t[o + T_EY]
    if ey != 0.0:
        by = by - ey * (by - math.atan(by))
    # combined slip: the weights G_x,alpha and G_y,kappa
    g_xa = combined_weight(alpha, kappa, t[o + T_RBX1], t[o + T_RBX2], t[o + T_REX1],
                           t[o + T_RCX1])
    g_yk = combined_weight(kappa, alpha, t[o + T_RBY1], t[o + T_RBY2], t[o + T_REY1],
                           t[o + T_RCY1])
    return (g_xa * mu_x * fz * math.sin(cx * math.atan(bx)),
            g_yk * mu_y * fz * math.sin(cy * math.atan(by)))


def tyre_forces(kappa: float, tan_alpha: float, fz: float, k_alpha0: float, mu: float,
                tyre: TyreParams | None = None, fz0: float | None = None
                ) -> tuple[float, float]:
    """N, (Fx, Fy) in the wheel frame (see `combined_forces`); fz0 defaults to fz (no
    load-sensitivity effect), k_alpha0 is the cornering stiffness at fz0 (N/rad)."""
    import numpy as np

    if fz <= 0.0:
        return 0.0, 0.0
    coef = np.array((tyre or TyreParams()).array())
    return combined_forces(float(kappa), float(tan_alpha), float(fz),
                           1.0 / float(fz if fz0 is None else fz0), float(k_alpha0), float(mu),
                           coef, 0)


def peak_slip(shape: float, curvature: float = 0.0) -> float:
    """-, normalised slip B s at which the pure-slip curve peaks: C atan(.) = pi / 2,
    i.e. B s - E (B s - atan(B s)) = tan(pi / (2 C)); solved by bisection for E != 0."""
    target = math.tan(math.pi / (2.0 * shape))
    lo, hi = 0.0, 1e3
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid - curvature * (mid - math.atan(mid)) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)
