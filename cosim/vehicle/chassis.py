"""Chassis parameters the paper's Table 1 lacks, for the two-track validation plant.

Table 1 gives mass, yaw inertia, axle positions, half track, drag and axle
cornering stiffnesses. A four-wheel model also needs the CG height, the wheels'
radius and spin inertia, the tyres (`cosim.vehicle.tyre.TyreParams`), and how load
transfer is split, scaled and delayed. The defaults are plausible values for a mid-size
sedan with in-wheel motors (the paper's Remark 5: the yaw moment is made by
differential in-wheel motor torque). A preset car (`cosim.params.VEHICLE_PRESETS`)
brings its own chassis (`chassis_for`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from cosim.errors import InputError
from cosim.params import COMMONROAD_CARS, COMMONROAD_TYRE, CommonRoadCar, G, VehicleParams
from cosim.vehicle.tyre import TyreParams


@dataclass(frozen=True)
class ChassisParams:
    """Two-track model parameters beyond Table 1."""

    cg_height: float = 0.55  # m, CG above ground (sedan: 0.5-0.6)
    wheel_radius: float = 0.31  # m, rolling radius (205/55 R16: 0.316)
    wheel_inertia: float = 1.2  # kg m^2, wheel + tyre + in-wheel motor rotor, per wheel
    roll_share_front: float = 0.55  # -, share of lateral load transfer taken by the front axle
    # -, lateral load transfer over the rigid car's m h ay / track: a body that rolls on its
    # springs and tyres moves its CG outwards (m_s g h_s phi) and transfers more; 1: rigid
    lateral_transfer_gain: float = 1.0
    # -, longitudinal load transfer over m h ax / wheelbase (1: the CG height's)
    longitudinal_transfer_gain: float = 1.0
    load_lag: float = 0.08  # s, first-order lag of load transfer (pitch/roll of the body)
    slip_speed_floor: float = 1.0  # m/s, the ABS / traction control's slip reference floor
    anti_lock: bool = True  # -, ABS / traction control cut the torque of a wheel past its peak
    # -, true tyre cornering stiffness / Table 1's Cf, Cr: 1 makes the design model exact at
    # small slip; below 1 models a plant that differs from what the controller assumes
    cornering_scale: float = 1.0
    tyre: TyreParams = field(default_factory=TyreParams)

    def check(self) -> None:
        """Raise InputError for a value no physical chassis has."""
        positive = {
            "cg_height": self.cg_height,
            "wheel_radius": self.wheel_radius,
            "wheel_inertia": self.wheel_inertia,
            "load_lag": self.load_lag,
            "slip_speed_floor": self.slip_speed_floor,
            "cornering_scale": self.cornering_scale,
            "lateral_transfer_gain": self.lateral_transfer_gain,
            "longitudinal_transfer_gain": self.longitudinal_transfer_gain,
        }
        for key, value in positive.items():
            if not value > 0.0:
                raise InputError("chassis", key, value, "must be > 0")
        if not 0.0 <= self.roll_share_front <= 1.0:
            raise InputError("chassis", "roll_share_front", self.roll_share_front, "in [0, 1]")
        self.tyre.check()


def static_wheel_loads(vehicle: VehicleParams) -> tuple[float, float]:
    """N, static vertical load on one front and one rear wheel."""
    weight = vehicle.mass * G
    return weight * vehicle.lr / (2.0 * vehicle.wheelbase), weight * vehicle.lf / (
        2.0 * vehicle.wheelbase
    )


def transfer_per_wheel(vehicle: VehicleParams, chassis: ChassisParams) -> tuple[float, float]:
    """N per m/s^2, (lateral, longitudinal) load moved onto one wheel by a unit lateral
    (summed over both axles: the roll split shares it out) and longitudinal acceleration:
    m h / (2 half track) and m h / (2 wheelbase), times the chassis' transfer gains."""
    lateral = vehicle.mass * chassis.cg_height / (2.0 * vehicle.half_track)
    longitudinal = vehicle.mass * chassis.cg_height / (2.0 * vehicle.wheelbase)
    return (lateral * chassis.lateral_transfer_gain,
            longitudinal * chassis.longitudinal_transfer_gain)


def commonroad_roll_stiffness(car: CommonRoadCar) -> tuple[float, float]:
    """N m/rad, (front, rear) roll stiffness of each axle's suspension as CommonRoad's
    `vehicle_dynamics_mb` has it: its suspension forces F_SL,R = ... -/+ z K_s -/+ (phi -
    phi_u) K_ts / T, with z = +/- (phi - phi_u) T / 2, give the sprung mass the roll
    moment T/2 (F_SL - F_SR) (sumL) = -(phi - phi_u) (K_s T^2 / 2 - K_ts): the springs'
    K_s T^2 / 2 plus |K_ts| (CommonRoad's K_ts are negative: the torsion bar stiffens the
    axle)."""
    return (car.K_sf * car.T_f**2 / 2.0 - car.K_tsf, car.K_sr * car.T_r**2 / 2.0 - car.K_tsr)


def commonroad_roll_share(car: CommonRoadCar) -> float:
    """-, front share of the steady lateral load transfer of CommonRoad's multi-body model
    with this car's parameters: its roll axis is on the ground (h_raf = h_rar = 0), so the
    sprung mass's roll moment m_s h_s ay goes through the suspensions in the ratio of their
    roll stiffnesses (`commonroad_roll_stiffness`), and each unsprung mass moves its own
    m_u R_w ay across its own track (vehicle2: front share 0.59)."""
    roll_f, roll_r = commonroad_roll_stiffness(car)
    front = car.m_s * car.h_s * roll_f / (roll_f + roll_r) + car.m_uf * car.R_w
    rear = car.m_s * car.h_s * roll_r / (roll_f + roll_r) + car.m_ur * car.R_w
    return front / (front + rear)


def commonroad_lateral_transfer_gain(car: CommonRoadCar) -> float:
    """-, the steady lateral load transfer of the car's body rolling on its suspensions
    and tyres, over the rigid car's m h_cg ay (the moments about the ground; our plant's
    `ChassisParams.lateral_transfer_gain`). A linear roll model with the car's parameters:
    the sprung mass rolls by phi about an axis on the ground (CommonRoad's h_raf = h_rar =
    0) and its CG moves outwards, so its moment is m_s h_s (ay + g phi); each axle's
    suspension carries K (phi - phi_u) (K: `commonroad_roll_stiffness`) onto its unsprung
    mass, which rolls phi_u on its tyres (K_zt T^2 / 2) and adds m_u R_w (ay + g phi_u).
    The tyres carry the sum, Kt phi_u per axle.

    vehicle2: 1.160 (phi 0.0158 rad per m/s^2). CommonRoad's multi-body model (MB) in a
    steady turn: 1.139 at 0.1 g, 1.148 at 0.3 g, 1.166 at 0.5 g (tests/vehicle/
    test_commonroad.py); MB's own make-up differs (its tyres' lateral compliance K_lt moves
    the contact patches inwards, about 8 %; its gravity term is smaller), but the rigid car's
    m h_cg ay / track, which our plant had, is 14-17 % short of it."""
    roll_f, roll_r = commonroad_roll_stiffness(car)
    tyre_f, tyre_r = car.K_zt * car.T_f**2 / 2.0, car.K_zt * car.T_r**2 / 2.0
    ms_hs, uf, ur = car.m_s * car.h_s, car.m_uf * car.R_w, car.m_ur * car.R_w
    # phi_u = (K phi + m_u R_w ay) / (Kt + K - m_u g R_w) per axle, ay = 1 m/s^2
    den_f, den_r = tyre_f + roll_f - uf * G, tyre_r + roll_r - ur * G
    # the sprung mass: K_f (phi - phi_uf) + K_r (phi - phi_ur) = m_s h_s (1 + g phi)
    phi = (ms_hs + roll_f * uf / den_f + roll_r * ur / den_r) / (
        roll_f * (1.0 - roll_f / den_f) + roll_r * (1.0 - roll_r / den_r) - ms_hs * G)
    moment = tyre_f * (roll_f * phi + uf) / den_f + tyre_r * (roll_r * phi + ur) / den_r
    return moment / (car.m * car.h_cg)


def commonroad_longitudinal_transfer_gain(car: CommonRoadCar) -> float:
    """-, the steady longitudinal load transfer of CommonRoad's multi-body model over m
    h_cg ax / L: its pitch equation (sumM_s) takes the whole car's tyre force at the sprung
    CG, h_s above the ground less the sprung mass's static sag (about the tyres' static
    deflection m g / (4 K_zt)); its unsprung masses have no inertia along x of their own.
    vehicle2: 1.038 (MB braking straight: 0.5966 m against 0.5968 m here)."""
    return (car.h_s - car.m * G / (4.0 * car.K_zt)) / car.h_cg


def commonroad_tyre(**changes: float) -> TyreParams:
    """CommonRoad's tyre (COMMONROAD_TYRE) in our Magic Formula: shapes, curvatures, slip
    stiffness, mu_x / mu_y and the combined-slip weights as its multi-body model has them;
    no load sensitivity (its K_y = p_ky1 Fz and D = p_d1 Fz are proportional to load);
    our relaxation lengths and low-speed damping (it has none: it switches to a kinematic
    model below 0.1 m/s)."""
    t = COMMONROAD_TYRE
    base = TyreParams(
        shape_lat=t["p_cy1"], shape_long=t["p_cx1"], curvature_lat=t["p_ey1"],
        curvature_long=t["p_ex1"], slip_stiffness=t["p_kx1"],
        friction_long_ratio=t["p_dx1"] / t["p_dy1"], friction_load=0.0,
        cornering_peak_load=float("inf"), r_bx1=t["r_bx1"], r_bx2=t["r_bx2"],
        r_cx1=t["r_cx1"], r_by1=t["r_by1"], r_by2=t["r_by2"], r_cy1=t["r_cy1"],
        r_ex1=t["r_ex1"], r_ey1=t["r_ey1"],
    )
    return TyreParams(**{**base.__dict__, **changes})


def commonroad_chassis(car: CommonRoadCar) -> ChassisParams:
    """Our chassis of a CommonRoad car: its CG height, wheel radius and inertia, roll split
    (`commonroad_roll_share`), load transfers (`commonroad_lateral_transfer_gain`,
    `commonroad_longitudinal_transfer_gain`) and tyre (`commonroad_tyre`)."""
    return ChassisParams(
        cg_height=car.h_cg, wheel_radius=car.R_w, wheel_inertia=car.I_y_w,
        roll_share_front=commonroad_roll_share(car),
        lateral_transfer_gain=commonroad_lateral_transfer_gain(car),
        longitudinal_transfer_gain=commonroad_longitudinal_transfer_gain(car),
        tyre=commonroad_tyre(),
    )


def chassis_for(vehicle: VehicleParams) -> ChassisParams:
    """The chassis of the vehicle's preset (Table 1's car: `ChassisParams()`)."""
    prefix = "commonroad_"
    if vehicle.preset.startswith(prefix):
        return commonroad_chassis(COMMONROAD_CARS[vehicle.preset[len(prefix):]])
    return ChassisParams()
