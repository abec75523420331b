"""Parameters as frozen dataclasses, SI units, with the unit beside each field.

Defaults are the paper's Table 1 (its lM/wM columns are swapped there: the car
is 4.32 m long and 1.8 m wide) and Section 5.
"""

from __future__ import annotations

from dataclasses import dataclass

G = 9.81  # m/s^2, gravity


def kmh(v_kmh: float) -> float:
    """km/h -> m/s (only at the edges of the code)."""
    return v_kmh / 3.6


@dataclass(frozen=True)
class VehicleParams:
    """Single-track design parameters (Table 1)."""

    mass: float = 1360.0  # kg, M
    yaw_inertia: float = 1993.0  # kg m^2, Iz
    lf: float = 1.45  # m, CG to front axle
    lr: float = 1.06  # m, CG to rear axle
    half_track: float = 0.71  # m, ls
    drag: float = 0.37  # N s^2/m^2, Ca
    cf: float = 151000.0  # N/rad, front axle cornering stiffness Cf
    cr: float = 146000.0  # N/rad, rear axle cornering stiffness Cr
    length: float = 4.32  # m, body length (collision rectangle)
    width: float = 1.8  # m, body width (collision rectangle)

    @property
    def wheelbase(self) -> float:
        """m, lf + lr."""
        return self.lf + self.lr

    @property
    def front_overhang(self) -> float:
        """m, CG to front bumper: the body is taken as centred on the CG."""
        return self.length / 2.0


@dataclass(frozen=True)
class RoadParams:
    """A straight highway along +x; lane 0 (SUMO index) is the rightmost, slowest lane."""

    lane_width: float = 3.75  # m
    # m/s, (min, max) speed band per SUMO lane index: paper 60-90, 90-110, 110-120 km/h
    speed_bands: tuple[tuple[float, float], ...] = (
        (60.0 / 3.6, 90.0 / 3.6),
        (90.0 / 3.6, 110.0 / 3.6),
        (110.0 / 3.6, 120.0 / 3.6),
    )
    mu: float = 0.6  # -, road friction coefficient
    y_right: float = 0.0  # m, global y of the right road edge (lane 0's right line)

    @property
    def n_lanes(self) -> int:
        return len(self.speed_bands)

    def lane_center(self, lane: int) -> float:
        """m, global y of a lane's centre line."""
        return self.y_right + (lane + 0.5) * self.lane_width

    def lane_of(self, y: float) -> int:
        """The lane whose strip holds global y (clipped to the road)."""
        k = int((y - self.y_right) // self.lane_width)
        return min(max(k, 0), self.n_lanes - 1)

    def target_speed(self, origin_lane: int, target_lane: int) -> float:
        """m/s, vxf of a lane change (Section 3.1, Fig. 5): the target lane's
        minimum speed for an accelerating change (to a faster lane), its maximum
        for a decelerating one."""
        lo, hi = self.speed_bands[target_lane]
        return lo if target_lane > origin_lane else hi


@dataclass(frozen=True)
class PlannerConfig:
    """Lane-change planner settings (Section 3)."""

    tau_max: float = 10.0  # s, longest lane change considered
    tau_step: float = 0.05  # s, spacing of the tau grid
    envelope: str = "inverse_dynamics"  # "inverse_dynamics" (default) | "paper_maps" (eq. 31-34)
    safety_factor: float = 0.8  # -, f in the envelope |Omega_z| <= f sqrt((mu g)^2 - Ax^2)/Vx
    collision_test: str = "exact"  # "exact" (separating axes) | "col" (paper, Appendix 9.2)
    # m, added around every rectangle by the exact test: the plant's own tracking error
    # (`cosim bench tracking`, docs/planning_results.md); 0 reproduces the paper
    safety_margin: float = 0.02
    horizon_extra: float = 2.0  # s, collision horizon past the end of the manoeuvre
    tau_min_floor: float = 1.0  # s, shortest tau ever put on the grid
    # beyond the paper (S2): re-check the plan under way, replan / abort (cosim.sim)
    replanning: bool = False  # -, re-check the rest of the plan while it is flown
    recheck_interval: float = 0.1  # s, time between two re-checks
    uncertainty_margin: bool = True  # -, widen safety_margin by V2V latency / loss / noise


@dataclass(frozen=True)
class ControllerGains:
    """MIMO triple-step gains (Section 5.4; stable by eq. 25) and eq. 28's kx1."""

    ky0: float = 10.0  # 1/s^2
    kphi0: float = 100.0  # 1/s^2
    kyI: float = 10.0  # 1/s^3
    kphiI: float = 500.0  # 1/s^3
    ky1: float = 20.0  # 1/s
    kphi1: float = 20.0  # 1/s
    kx1: float = 200.0  # 1/s, longitudinal speed-error gain (eq. 28)
    allocation_eps: float = 1e-6  # -, eps of the least-squares allocation (eq. 30)
