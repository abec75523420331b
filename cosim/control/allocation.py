"""Control allocation (eq. 20, 27, 29-30): [dMz, Fa] -> four wheel forces.

Wheels 1 FL, 2 FR, 3 RL, 4 RR. The map from wheel forces to the virtual inputs
(eq. 20 and 27) is v = Mm Fx with
Mm = [[-ls c + lf s, ls c + lf s, -ls, ls], [c, c, 1, 1]], c, s = cos, sin(delta);
the least-squares allocation (eq. 30) is Fx = Mm^T (eps I + Mm Mm^T)^-1 v.
"""

from __future__ import annotations

import math

from cosim.compiled import njit
from cosim.params import VehicleParams


def effectiveness(
    vehicle: VehicleParams, delta: float
) -> tuple[tuple[float, float, float, float], tuple[float, float, float, float]]:
    """The two rows of Mm (eq. 29) at road-wheel angle delta."""
    c, s = math.cos(delta), math.sin(delta)
    ls, lf = vehicle.half_track, vehicle.lf
    return (-ls * c + lf * s, ls * c + lf * s, -ls, ls), (c, c, 1.0, 1.0)


def virtual_inputs(
    vehicle: VehicleParams, delta: float, fx: tuple[float, float, float, float]
) -> tuple[float, float]:
    """(dMz N m, Fa N) that wheel forces fx produce (eq. 20, 27)."""
    m1, m2 = effectiveness(vehicle, delta)
    return (
        sum(a * f for a, f in zip(m1, fx, strict=True)),
        sum(a * f for a, f in zip(m2, fx, strict=True)),
    )


@njit
def allocate_core(ls: float, lf: float, delta: float, dmz: float, fa: float, eps: float
                  ) -> tuple[float, float, float, float]:
    """N, wheel forces Fx = Mm^T (eps I + Mm Mm^T)^-1 [dMz, Fa] (eq. 30), written out
    for the 2 x 4 Mm; ls half track, lf CG to front axle (m)."""
    c, s = math.cos(delta), math.sin(delta)
    a1, a2 = -ls * c + lf * s, ls * c + lf * s  # Mm row 1: a1, a2, -ls, ls
    p11 = eps + a1 * a1 + a2 * a2 + 2.0 * ls * ls
    p12 = c * (a1 + a2)  # the rear terms cancel: -ls + ls
    p22 = eps + 2.0 * c * c + 2.0
    det = p11 * p22 - p12 * p12
    l1 = (p22 * dmz - p12 * fa) / det
    l2 = (p11 * fa - p12 * dmz) / det
    return a1 * l1 + c * l2, a2 * l1 + c * l2, -ls * l1 + l2, ls * l1 + l2


def allocate(
    vehicle: VehicleParams, delta: float, dmz: float, fa: float, eps: float
) -> tuple[float, float, float, float]:
    """N, wheel forces Fx = Mm^T (eps I + Mm Mm^T)^-1 [dMz, Fa] (eq. 30) (compiled:
    the closed loop calls `allocate_core` every control step)."""
    return allocate_core(vehicle.half_track, vehicle.lf, float(delta), float(dmz), float(fa),
                         float(eps))
