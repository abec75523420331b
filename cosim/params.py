"""Parameters as frozen dataclasses, SI units, with the unit beside each field.

Defaults are the paper's Table 1 (its lM/wM columns are swapped there: the car
is 4.32 m long and 1.8 m wide) and Section 5. Beside Table 1's car, known cars
are presets (`VEHICLE_PRESETS`): CommonRoad's vehicle1/2/3 (`COMMONROAD_CARS`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any

G = 9.81  # m/s^2, gravity
STANDSTILL_SPEED = 0.1  # m/s, a vehicle slower than this stands: the SV's stopped time, a
# standing leader of the car following, a yielding TV stopped beside the SV


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
    # the preset these values started from (VEHICLE_PRESETS); it also picks the two-track
    # plant's chassis and tyres (cosim.vehicle.chassis.chassis_for)
    preset: str = "table1"

    @property
    def wheelbase(self) -> float:
        """m, lf + lr."""
        return self.lf + self.lr


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
    # m, s (x on the straight road) where lane k ends: an acceleration lane, a lane drop;
    # a lane not listed, or listed as inf, runs on to the end of the route
    lane_ends: tuple[float, ...] = ()
    # m, s where lane k begins beside the others: on a route from an on-ramp the
    # mainline's lanes, on one leaving over an off-ramp the deceleration lane; a lane not
    # listed, or listed as -inf, is there from the route's start. A lane that begins
    # after its end is two in one, there before its end and again from its begin to the
    # end of the route (from an on-ramp over an off-ramp: the acceleration lane, then
    # the deceleration lane)
    lane_begins: tuple[float, ...] = ()
    # (s_lo m, s_hi m, R m): where the route rounds a junction drawn as a corner and the
    # radius its lane takes there (cosim.road.corners): the SV slows to its curve speed
    corners: tuple[tuple[float, float, float], ...] = ()
    # per lane, (s_lo m, s_hi m, v m/s): where the route's speed limit v is below the
    # lane's band (cosim.driving.speed_limits): the SV keeps the limit there
    speed_limits: tuple[tuple[tuple[float, float, float], ...], ...] = ()

    @property
    def n_lanes(self) -> int:
        return len(self.speed_bands)

    def lane_center(self, lane: int) -> float:
        """m, global y of a lane's centre line."""
        return self.y_right + (lane + 0.5) * self.lane_width

    def lane_end(self, lane: int, s: float = -math.inf) -> float:
        """m, s where `lane` ends ahead of `s` (m; inf: it runs to the end of the route):
        of a lane in two (`lane_begins`), past its first part's end, none."""
        end = self.lane_ends[lane] if lane < len(self.lane_ends) else math.inf
        if s >= end and self.lane_begin(lane) > end:
            return math.inf
        return end

    def lane_begin(self, lane: int) -> float:
        """m, s where `lane` begins beside the others (-inf: at the route's start; of a
        lane in two, where its second part begins)."""
        return self.lane_begins[lane] if lane < len(self.lane_begins) else -math.inf

    def split_ends(self) -> tuple[float, ...]:
        """m, the ends of the lanes in two (`lane_begins`), sorted: past each, that lane
        ends nowhere (`lane_end`); () on every road but one from an on-ramp over an
        off-ramp."""
        return tuple(sorted(e for k, e in enumerate(self.lane_ends)
                            if self.lane_begin(k) > e))

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
    # beyond the paper (S2): re-check the plan under way, replan / abort (cosim.run.loop)
    replanning: bool = False  # -, re-check the rest of the plan while it is flown
    recheck_interval: float = 0.1  # s, time between two re-checks
    uncertainty_margin: bool = True  # -, widen safety_margin by V2V latency / loss / noise
    # beyond the paper: the lane-change policy by its registered name
    # (cosim.driving.registry): "paper" plans where the SV is once the target lane is free
    # (cosim.driving.paper); "gap" picks a gap, drives to it, then plans (cosim.driving.gap)
    policy: str = "paper"


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


# ---------------------------------------------------------------- known cars


@dataclass(frozen=True)
class CommonRoadCar:
    """A CommonRoad parameter set (PyPI commonroad-vehicle-models 3.0.2, module
    vehiclemodels, parameters/parameters_vehicleN.yaml; Althoff and Wuersching,
    "CommonRoad: Vehicle Models", 2020, Tab. 6), the entries our presets use.
    tests/vehicle/test_commonroad.py checks each against the package."""

    name: str  # CommonRoad's: vehicle1 (Ford Escort), vehicle2 (BMW 320i), vehicle3 (VW Vanagon)
    l: float  # m, body length
    w: float  # m, body width
    m: float  # kg, total mass
    m_s: float  # kg, sprung mass
    m_uf: float  # kg, unsprung mass front
    m_ur: float  # kg, unsprung mass rear
    a: float  # m, sprung-mass CG to front axle
    b: float  # m, sprung-mass CG to rear axle
    I_z: float  # kg m^2, yaw inertia
    T_f: float  # m, front track
    T_r: float  # m, rear track
    h_cg: float  # m, CG height of the total mass
    h_s: float  # m, sprung-mass CG height
    R_w: float  # m, wheel radius
    I_y_w: float  # kg m^2, wheel spin inertia
    K_sf: float  # N/m, suspension spring rate front (per wheel)
    K_sr: float  # N/m, suspension spring rate rear
    K_tsf: float  # N m/rad, auxiliary torsion roll stiffness front (per axle)
    K_tsr: float  # N m/rad, auxiliary torsion roll stiffness rear
    T_sb: float  # -, brake torque share of the front axle
    T_se: float  # -, drive torque share of the front axle
    K_zt: float  # N/m, vertical tyre stiffness (per wheel)


COMMONROAD_CARS = {
    "vehicle1": CommonRoadCar(
        "vehicle1", 4.298, 1.674, 1225.8878467253344, 1094.542720290477, 65.67256321742863,
        65.67256321742863, 0.88392, 1.50876, 1538.8533713561394, 1.389888, 1.423416,
        0.5577840000000001, 0.59436, 0.344, 1.7, 21898.332429625985, 21898.332429625985,
        -12880.270509148304, 0.0, 0.76, 1.0, 189785.5477234252),
    "vehicle2": CommonRoadCar(
        "vehicle2", 4.508, 1.61, 1093.2952334674046, 965.7108098804363, 63.7921826056784,
        63.7921826056784, 1.1561957064, 1.4227170936, 1791.5995300122856, 1.38684, 1.36398,
        0.5748689544000001, 0.61373004, 0.344, 1.7, 24453.137879749014, 19635.504745231297,
        -6914.881688272133, -2643.6009520155308, 0.66, 0.0, 158294.1398119115),
    "vehicle3": CommonRoadCar(
        "vehicle3", 4.569, 1.844, 1478.8979637767998, 1316.6086552490374, 81.14428941630796,
        81.14428941630796, 1.1507916024, 1.3211363976000001, 2473.1176915564442, 1.574292,
        1.5438120000000002, 0.7478167416, 0.804490644, 0.344, 1.7, 33577.44305875984,
        39125.020607598424, -33948.217142834066, -7731.374238208578, 0.64, 0.0,
        212641.56722464017),
}

# CommonRoad's one tyre (parameters/parameters_tire.yaml, from the ADAMS handbook), the
# Magic Formula coefficients our plant uses. Its multi-body model takes the lateral
# stiffness as K_y = p_ky1 Fz ("simplify K_y0 to p_ky1*F_z", utils/tire_model.py) and its
# single-track model the same through C_S = -p_ky1 / p_dy1 times mu = p_dy1: so a wheel's
# cornering stiffness per unit load is |p_ky1| = 21.92 /rad and an axle's is 21.92 x its load.
COMMONROAD_TYRE = {
    "p_cx1": 1.6411, "p_dx1": 1.1739, "p_ex1": 0.46403, "p_kx1": 22.303,
    "p_cy1": 1.3507, "p_dy1": 1.0489, "p_ey1": -0.0074722, "p_ky1": -21.92,
    "r_bx1": 13.276, "r_bx2": -13.778, "r_cx1": 1.2568, "r_ex1": 0.65225,
    "r_by1": 7.1433, "r_by2": 9.1916, "r_cy1": 1.0719, "r_ey1": -0.27572,
}


def commonroad_vehicle(car: CommonRoadCar) -> VehicleParams:
    """Our single-track parameters of a CommonRoad car: lf = a, lr = b, half track the
    mean of both, no aerodynamic drag (CommonRoad has none), and axle cornering
    stiffnesses |p_ky1| x static axle load (see COMMONROAD_TYRE)."""
    per_load = -COMMONROAD_TYRE["p_ky1"]  # 1/rad
    weight = car.m * G
    wheelbase = car.a + car.b
    return VehicleParams(
        mass=car.m, yaw_inertia=car.I_z, lf=car.a, lr=car.b,
        half_track=(car.T_f + car.T_r) / 4.0, drag=0.0,
        cf=per_load * weight * car.b / wheelbase, cr=per_load * weight * car.a / wheelbase,
        length=car.l, width=car.w, preset=f"commonroad_{car.name}",
    )


VEHICLE_PRESETS: dict[str, VehicleParams] = {
    "table1": VehicleParams(),
    **{f"commonroad_{name}": commonroad_vehicle(car) for name, car in COMMONROAD_CARS.items()},
}


def vehicle_preset(name: str, **changes: float) -> VehicleParams:
    """A preset with some fields changed (SI, VehicleParams' field names)."""
    return replace(VEHICLE_PRESETS[name], **changes)


def vehicle_from_table(values: Mapping[str, Any], given: Iterable[str]) -> VehicleParams:
    """A scenario's validated [vehicle] table (SI, field names, defaults filled in): the
    preset `values["preset"]`, with the fields named in `given` (those the file sets)
    taken from the table."""
    return vehicle_preset(values["preset"],
                          **{k: values[k] for k in given if k != "preset"})
