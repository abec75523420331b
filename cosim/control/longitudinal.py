"""The longitudinal law (eq. 28): Fa = M (-kx1 ex + dVx*/dt), ex = Vx - Vx*, with its
low-speed form: the gain never faster than the tyres can make force.

Drag (eq. 26's Ca Vx^2) is deliberately not cancelled, as in the paper; the
proportional term absorbs it with a small steady speed error.

Low-speed form (beyond the paper). Eq. 28 treats Fa as a force that acts at
once (the paper's design model). A tyre builds its longitudinal force over its
relaxation length: the slip, hence the force, lags the wheel's spin by sigma_kappa / Vx
(Pacejka sec. 7.2), and the wheel spinning on that tyre is a torsional mode of
omega_n = sqrt(R^2 K_kappa / (Iw sigma_kappa)) (about 305 rad/s here) damped only by
Vx / sigma_kappa. The speed loop kx1 / s closed through that mode,
s^3 + (Vx / sigma) s^2 + omega_n^2 s + kx1 omega_n^2, is stable only for
kx1 < Vx / sigma_kappa in continuous time, i.e. below 12 m/s for the paper's kx1 = 200 /s
and sigma_kappa = 0.06 m; the 200 Hz sample-and-hold moves that edge up to ~21 m/s.
Below it the two-track car limit-cycles at about 25 Hz with the wheel force flipping
between the friction limits (+-10 kN, ax +-7.5 m/s^2 at 10 m/s), which the 0.05 s trace
shows as an acceleration changing sign every step. Measured stability limit of kx1 on
Table 1's car (mu 0.8, 200 Hz, ABS on or off alike): 57 /s at 2 m/s, 108 at 5, 135 at 8,
160 at 12, 180 at 16, 197 at 20, 201 at 21 m/s; below 1.5 m/s the tyres' low-speed
damping holds it (354 /s at 1 m/s).

So the gain used is kx1_eff = min(kx1, max(KX1_FLOOR, Vx / (TYRE_LAG_FACTOR sigma_kappa))):
the speed loop's time constant 1 / kx1_eff is at least TYRE_LAG_FACTOR tyre relaxation
times. With 1.8 the paper's kx1 = 200 /s applies in full from 21.6 m/s (the paper's
cases and Table 2 run at 22.2-30.6 m/s: unchanged), and the gain margin grows as the
speed falls (1.1 at 20 m/s, 1.5 at 12, 2.4 at 5, 3 at 2 m/s). KX1_FLOOR keeps a stopped
car's speed loop at a 0.1 s time constant (the low-speed damping makes it stable there).
The same gain drives the bicycle plant (one controller for both plants).
"""

from __future__ import annotations

from cosim.compiled import njit
from cosim.params import ControllerGains, VehicleParams

# -, 1 / kx1_eff >= this many tyre relaxation times sigma_kappa / Vx
TYRE_LAG_FACTOR = 1.8  # tuned: docs/tuned_constants.md
KX1_FLOOR = 10.0  # 1/s, the low-speed form's gain at (near) a standstill


@njit
def speed_gain(kx1: float, vx: float, inv_lag: float) -> float:
    """1/s, eq. 28's gain at speed vx (m/s): kx1, or the low-speed form
    max(KX1_FLOOR, vx * inv_lag) where that is smaller; inv_lag = 1 / (TYRE_LAG_FACTOR
    sigma_kappa) (1/m s; 0 or less: kx1 at every speed, the paper's law)."""
    if inv_lag <= 0.0:
        return kx1
    slow = vx * inv_lag
    if slow >= kx1:
        return kx1
    return slow if slow > KX1_FLOOR else min(KX1_FLOOR, kx1)


def speed_gain_inverse_lag(relaxation_long: float) -> float:
    """1/(m s), the low-speed form's slope 1 / (TYRE_LAG_FACTOR sigma_kappa) for a tyre of
    longitudinal relaxation length `relaxation_long` (m)."""
    return 1.0 / (TYRE_LAG_FACTOR * relaxation_long)


@njit
def longitudinal_core(mass: float, kx1: float, vx: float, vx_ref: float, ax_ref: float
                      ) -> float:
    """N, Fa = M (-kx1 (Vx - Vx*) + dVx*/dt) (eq. 28)."""
    return mass * (-kx1 * (vx - vx_ref) + ax_ref)


def longitudinal_force(
    vehicle: VehicleParams, gains: ControllerGains, vx: float, vx_ref: float, ax_ref: float
) -> float:
    """N, total longitudinal force Fa demanded of the four wheels (the paper's gain)."""
    return longitudinal_core(float(vehicle.mass), float(gains.kx1), float(vx), float(vx_ref),
                             float(ax_ref))
