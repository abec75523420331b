"""The longitudinal law (eq. 28): Fa = M (-kx1 ex + dVx*/dt), ex = Vx - Vx*.

Drag (eq. 26's Ca Vx^2) is deliberately not cancelled, as in the paper; the
proportional term absorbs it with a small steady speed error.
"""

from __future__ import annotations

from cosim.compiled import njit
from cosim.params import ControllerGains, VehicleParams


@njit
def longitudinal_core(mass: float, kx1: float, vx: float, vx_ref: float, ax_ref: float
                      ) -> float:
    """N, Fa = M (-kx1 (Vx - Vx*) + dVx*/dt) (eq. 28)."""
    return mass * (-kx1 * (vx - vx_ref) + ax_ref)


def longitudinal_force(
    vehicle: VehicleParams, gains: ControllerGains, vx: float, vx_ref: float, ax_ref: float
) -> float:
    """N, total longitudinal force Fa demanded of the four wheels."""
    return longitudinal_core(float(vehicle.mass), float(gains.kx1), float(vx), float(vx_ref),
                             float(ax_ref))
