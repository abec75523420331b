"""The closed loop the co-simulation steps: plant + path errors + control laws +
allocation + actuator limits, advanced one SUMO step at a time.

Per substep (h = dt / substeps): every `control_every` substeps the controller
samples the plant state, computes (delta_f, dMz) by the MIMO triple-step law
(eq. 22-24) or steering alone by the SISO baseline, Fa by eq. 28, the four
wheel forces by eq. 30, and passes them through the actuator limits (steering
angle and rate, wheel torque); the plant is then integrated over the substep
with these inputs held (zero-order hold). Default: the controller runs every
substep, i.e. at 200 Hz for the default 0.05 s step with 10 substeps. Keep the
control period T well under 2 / kx1: eq. 28 with kx1 = 200 /s is a sampled
proportional loop on speed, stable only for kx1 T < 2; at 100 Hz (T = 10 ms,
kx1 T = 2) the speed error after a step keeps oscillating at +-0.03 m/s, at
67 Hz it grows until the wheel forces saturate.

Eq. 28's gain has a low-speed form (`longitudinal.speed_gain`): below 21.6 m/s it is held
under the tyres' force build-up rate Vx / sigma_kappa, through whose lag the paper's
kx1 = 200 /s would make the two-track car limit-cycle at ~25 Hz.

Guards: the controller divides by max(vx, speed_floor); below speed_floor (stop-and-go)
the integrators run over distance (ye * h * vx / speed_floor: they hold at a standstill,
where the errors cannot change) and dMz fades in proportion (a yaw moment at rest only
pivots the car); the reference's own low-speed form is in `reference`; the yaw moment is
limited to what the wheels can give without eating the lateral grip the
planner counts on (`yaw_moment_share`, below); an integrator stops while its
actuator saturates in the direction its error pushes (conditional integration,
anti-windup); a non-finite plant state or control output raises
`SimulationError` naming the state. The two-track plant itself has ABS /
traction control (`TwoTrackPlant._slip_limited`).

On a curved road (beyond the paper; 0 where the road is straight, so the paper's law
there is unchanged, bit for bit): the steady-cornering feed-forward of `cornering`
(what the two-track car's nonlinear tyres need beyond eq. 21's linear model) on the
steering and yaw moment, and Iz times the yaw acceleration a lane asks for where the
road's curvature changes (`road_yaw_acceleration`: eq. 21 takes kappa as constant);
for the two-track car the road's curvature in both and in the law is taken one tyre
relaxation length ahead of the car (`lane_curvature`: the tyres' force lags their slip
by that distance), and its yaw moment is also held where it overloads no wheel (`grip`,
below).

Yaw-moment limit (beyond the paper): the MIMO law asks for the yaw moment that
keeps the heading on the path tangent (zero sideslip). For the oversteering
Table 1 car this grows with lateral acceleration as KL (L lr Cr - lf M Vx^2)
(about 2 kN m at 1.8 m/s^2 and 80 km/h), made by differential wheel forces;
on mu = 0.4 those forces plus the cornering forces overrun the inner wheels'
friction circles (the allocation, eq. 30, ignores wheel loads): on the
two-track car the yaw loop ends in a growing oscillation (with the Magic Formula
tyres: a spin at tau = 2.5 s; it still tracks at 3.5 s, 0.05 m off;
tests/control/test_closed_loop.py). So |dMz| is limited to
share * mu * M * g * ls: every wheel's differential force then stays below
`share` of its static friction limit; with the planner's lateral use of
f = 0.8, sqrt(0.2^2 + 0.8^2) = 0.82 leaves room for the load the inner wheels
lose in the turn. The share trades path for heading: a smaller share keeps ye
smaller and leaves phi_e larger (the default, YAW_MOMENT_SHARE, sits between;
docs/tuned_constants.md). None: no limit, the paper's law as printed. The steering
law does not use dMz (B's first row), so while the limit is active ye is still
regulated and only phi_e is left to the zero dynamics, as in the SISO baseline.
On a curve the limit is centred on the moment that holds the road's curve, and the
cornering takes part of each wheel's friction (the inner front wheel's most: unloaded,
and at zero sideslip the front axle carries nearly all the cornering force), so the
two-track car's yaw moment is further held where it asks no wheel for more than
GRIP_USE of its friction at the plan's accelerations (`grip.grip_moment_range`). Without
it a lane change to the inner lane of a R 400 m curve at 28 m/s (mu 0.8) overran the
inner front tyre: the car ran 7 cm wide, and the integrators, wound up, still held it
1.6 cm off 10 s later.

Speed: the substep loop (`advance_core`: projection, laws, allocation, limits,
anti-windup, plant RK4, finiteness check) is compiled with numba
(`cosim.compiled`) and runs on float arrays: one call per `advance`.
The Python side builds the records and raises the errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from cosim.compiled import Array, njit, register_warm_up
from cosim.errors import InputError, SimulationError
from cosim.params import ControllerGains, G, VehicleParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.road.frame import (
    FP_CURVED,
    FP_D_OFFSET,
    FP_H,
    FP_S_MIN,
    Frame,
    StraightFrame,
    pose_in_frame,
)
from cosim.vehicle.actuators import ActuatorLimits, steer_core
from cosim.vehicle.bicycle import BicyclePlant, bicycle_step
from cosim.vehicle.chassis import ChassisParams, chassis_for
from cosim.vehicle.plant import Plant, PlantStart, check_finite
from cosim.vehicle.twotrack import TwoTrackPlant, twotrack_step

from .allocation import allocate_core
from .cornering import F_DRAG, F_ON, F_PREVIEW, cornering_params, curve_feed_forward
from .grip import GRIP_USE, grip_moment_range
from .longitudinal import longitudinal_core, speed_gain, speed_gain_inverse_lag
from .reference import PathErrors, ReferencePath, frame_path_errors
from .triple_step import check_gains, law_params, mimo_core, siso_core


class PlantKind(StrEnum):
    """The vehicle model the closed loop steps."""

    TWOTRACK = "twotrack"  # four wheels, Magic Formula tyres, load transfer (validation)
    BICYCLE = "bicycle"  # the paper's 2-DOF single-track design model


class ControlLaw(StrEnum):
    """The lateral law."""

    MIMO = "mimo"  # the triple-step law on ye and phi_e (eq. 22-24)
    SISO = "siso"  # the baseline on ye alone, no yaw moment


PLANTS = tuple(p.value for p in PlantKind)
# -, default friction share of the yaw-moment limit (see the module docstring)
YAW_MOMENT_SHARE = 0.2  # tuned: docs/tuned_constants.md
CONTROLLERS = tuple(c.value for c in ControlLaw)


@dataclass(frozen=True)
class StepRecord:
    """The closed loop at the end of one `advance` (SI units, radians, body frame)."""

    t: float  # s, simulation time
    x: float  # m, CG global x
    y: float  # m, CG global y
    heading: float  # rad, math convention
    vx: float  # m/s, body longitudinal speed
    vy: float  # m/s, body lateral speed
    yaw_rate: float  # rad/s
    ax: float  # m/s^2, body longitudinal acceleration
    ay: float  # m/s^2, body lateral acceleration
    x_ref: float  # m, reference x*(t) at this time
    y_ref: float  # m, reference y*(t) at this time
    vx_ref: float  # m/s, Vx*(t) (eq. 14)
    kappa_ref: float  # 1/m, KL at the closest path point (eq. 15)
    ye: float  # m, lateral offset from the path (+ left)
    phi_e: float  # rad, heading error
    ex: float  # m/s, speed error Vx - Vx*
    along: float  # m, position error along the path against x*(t), y*(t) (+ ahead)
    delta_f: float  # rad, road-wheel angle applied
    dmz: float  # N m, yaw moment demanded (eq. 24; 0 for SISO)
    fa: float  # N, longitudinal force demanded (eq. 28)
    fx: tuple[float, float, float, float]  # N, wheel longitudinal forces FL, FR, RL, RR
    fy: tuple[float, float, float, float] | None  # N, wheel lateral forces (2-DOF: axle / 2)
    fz: tuple[float, float, float, float] | None  # N, wheel loads (two-track only)
    saturated: bool  # an actuator limit was active during the step


# Layout of the controller's constant array `cp` and state array `cs` (compiled code).
CP_FLOOR, CP_MIMO, CP_MAX_STEER, CP_STEER_RATE, CP_DMZ_LIMIT = 0, 1, 2, 3, 4
CP_FORCE_LO, CP_FORCE_HI, CP_LS, CP_LF, CP_EPS, CP_MASS, CP_KX1 = 5, 6, 7, 8, 9, 10, 11
CP_KX1_SLOPE = 12  # 1/(m s), eq. 28's low-speed form (`longitudinal.speed_gain`; 0: off)
CP_CURVE_STIFF, CP_CURVE_MASS = 13, 14  # N m, kg m: L lr Cr and lf M (`curve_yaw_moment`)
CP_IZ = 15  # kg m^2, Iz (`road_yaw_acceleration`)
CP_GRIP_USE = 16  # -, the friction share the yaw moment may load a wheel to on a curve
# cs: 0 projection (path parameter, s), 1 int(ye) (m s), 2 int(phi_e) (rad s),
# 3 delta_f applied (rad), 4 dMz (N m), 5 Fa (N), 6-9 wheel forces (N),
# 10 last control saturated (0/1), 11-15 a non-finite control output
# (delta_f, dMz, Fa, ye, phi_e), 16 time of a non-finite plant state (s),
# 17 the car's s in the road frame at the last sample (m; the next search's hint)
CS_SIZE = 18
CS_S_ROAD = 17
OK, BAD_CONTROL, BAD_STATE = 0, 1, 2
PLANT_CODES = {"twotrack": 0, "bicycle": 1}


@njit
def curve_yaw_moment(cp: Array, kappa: float, vx: float) -> float:
    """N m, the yaw moment that holds the single-track car on a circle of curvature kappa
    at speed vx with zero sideslip (the MIMO law's aim, phi_e = 0): with beta = 0 the rear
    axle's slip is lr kappa, its force Cr lr kappa, the front's M vx^2 kappa - Cr lr
    kappa, and the moments balance at kappa (L lr Cr - lf M vx^2)."""
    return kappa * (cp[CP_CURVE_STIFF] - cp[CP_CURVE_MASS] * vx * vx)


KAPPA_SPAN = 2.5  # m, either side of the car: the road's curvature's slope taken over it


@njit
def lane_curvature(fp: Array, fr: Array, s: float, d: float) -> float:
    """1/m, the curvature of the road's line at offset d through road position s (the
    frame's arc there: kappa / (1 - kappa (d - d_offset)), as `frame_path_errors`' k_lane)."""
    s_min, h = fp[FP_S_MIN], fp[FP_H]
    n = fr.shape[1]
    j = min(max(int(math.floor((s - s_min) / h)), 0), n - 1)
    k = fr[4, j]
    return k / (1.0 - k * (d - fp[FP_D_OFFSET])) if k != 0.0 else 0.0


@njit
def road_yaw_acceleration(fp: Array, fr: Array, s: float, d: float, vx: float) -> float:
    """rad/s^2, how fast the yaw rate of a car following its lane at speed vx must change
    where the road's curvature changes: the lane's heading turns at kappa(s) ds/dt, with
    ds/dt = vx / q (q = 1 - kappa (d - d_offset)), so its yaw acceleration is
    kappa'(s) (ds/dt)^2 (at a steady speed). Eq. 21 takes the path's curvature as
    constant (phi_e'' has no kappa' term): fed forward as Iz times this, the yaw moment
    a transition into or out of a curve needs does not have to come from phi_e. kappa'
    is the slope of the frame's curvature over +-KAPPA_SPAN."""
    s_min, h = fp[FP_S_MIN], fp[FP_H]
    n = fr.shape[1]
    j0 = min(max(int(math.floor((s - KAPPA_SPAN - s_min) / h)), 0), n - 1)
    j1 = min(max(int(math.floor((s + KAPPA_SPAN - s_min) / h)), 0), n - 1)
    slope = (fr[4, j1] - fr[4, j0]) / (2.0 * KAPPA_SPAN)
    j = min(max(int(math.floor((s - s_min) / h)), 0), n - 1)
    sdot = vx / (1.0 - fr[4, j] * (d - fp[FP_D_OFFSET]))
    return slope * sdot * sdot


@njit
def control_core(s: Array, coef: Array, fp: Array, fr: Array, lp: Array, cp: Array,
                 ff: Array, cs: Array, t: float, h_ctrl: float) -> int:
    """Sample state s at time t, compute and limit the inputs into cs (held until the
    next call): projection and errors (eq. 16; the reference in the road frame fp, fr),
    MIMO (eq. 22-24) or SISO law, Fa (eq. 28), allocation (eq. 30), actuator limits,
    conditional integration. Returns OK, or BAD_CONTROL with the non-finite outputs in
    cs[11:16]."""
    (ye, phi_e, ye_dot, phi_e_dot, kappa, sproj, vx_ref, ax_ref, _, _, _, s_road, d_road,
     _, k_lane) = frame_path_errors(coef, fp, fr, t, s[0], s[1], s[2], s[3], s[4], s[5],
                                    cs[0], cs[CS_S_ROAD])
    cs[0] = sproj
    cs[CS_S_ROAD] = s_road
    if fp[FP_CURVED] != 0.0 and ff[F_ON] != 0.0:
        # the tyres' lateral force lags their slip by the relaxation length sigma (a lag
        # in distance, not time): the road's curvature is taken sigma ahead, so the
        # force the lane's curve asks for arrives where it is needed (`cornering`; a
        # straight road, StraightFrame, and the bicycle's lag-free tyres: unchanged)
        dk = lane_curvature(fp, fr, s_road + ff[F_PREVIEW], d_road) - k_lane
        kappa += dk
        k_lane += dk
    vx = max(s[3], cp[CP_FLOOR])
    # below the floor the lateral errors barely move: integrate over distance, not time,
    # and fade the yaw moment (at rest it would only pivot the car); 1 above the floor
    slow = min(max(s[3] / cp[CP_FLOOR], 0.0), 1.0)
    if cp[CP_MIMO] != 0.0:
        delta_cmd, dmz = mimo_core(lp, vx, kappa, ye, phi_e, ye_dot, phi_e_dot, cs[1], cs[2])
        dmz *= slow
    else:
        delta_cmd = siso_core(lp, vx, kappa, ye, phi_e, ye_dot, phi_e_dot, cs[1])
        dmz = 0.0
    # eq. 28 with its gain held below the tyres' force build-up rate (`longitudinal`)
    kx1 = speed_gain(cp[CP_KX1], s[3], cp[CP_KX1_SLOPE])
    fa = longitudinal_core(cp[CP_MASS], kx1, s[3], vx_ref, ax_ref)
    if k_lane != 0.0:
        # on a curve: what the tyres need beyond eq. 21's linear model for the path's
        # curvature, less what they would need for it without the road's (`cornering`:
        # the part the road's curve adds; 0 on a straight road, as the paper's law), at
        # the acceleration Fa gives beyond the air's drag (the load moves with that, not
        # with Fa: at a steady 31 m/s Fa is all drag) and with Fa on the wheels
        ax_ff = (fa - ff[F_DRAG] * s[3] * abs(s[3])) / cp[CP_MASS]
        d_delta, d_dmz = curve_feed_forward(ff, vx, kappa, k_lane, ax_ff, fa)
        delta_cmd += d_delta
        if cp[CP_MIMO] != 0.0:
            dmz += (d_dmz + cp[CP_IZ] * road_yaw_acceleration(fp, fr, s_road, d_road, vx)) * slow
    if not (math.isfinite(delta_cmd) and math.isfinite(dmz) and math.isfinite(fa)):
        cs[11], cs[12], cs[13], cs[14], cs[15] = delta_cmd, dmz, fa, ye, phi_e
        return BAD_CONTROL
    max_steer, dmz_limit = cp[CP_MAX_STEER], cp[CP_DMZ_LIMIT]
    delta = steer_core(max_steer, cp[CP_STEER_RATE], cs[3], delta_cmd, h_ctrl)
    steer_sat = abs(delta_cmd) > max_steer
    # the limit is on what the law asks beyond holding the road's curve without
    # sideslip (`curve_yaw_moment`; 0 on a straight road)
    dmz_road = curve_yaw_moment(cp, k_lane, vx) if k_lane != 0.0 else 0.0
    yaw_sat = abs(dmz - dmz_road) > dmz_limit
    dmz_cmd = dmz
    if yaw_sat:
        dmz = dmz_road + math.copysign(dmz_limit, dmz - dmz_road)
    push = dmz_cmd - dmz_road  # the side the law pushes a saturated yaw moment to
    if k_lane != 0.0 and ff[F_ON] != 0.0 and cp[CP_MIMO] != 0.0:
        # on a curve the cornering takes part of the wheels' friction: the yaw moment is
        # also held where it asks no wheel for more than GRIP_USE of it at the plan's
        # accelerations (`grip`; the plan's, not the speed loop's transients, 8 kN for a
        # moment where a curve begins; the two-track car only, never on a straight road)
        fa_plan = cp[CP_MASS] * ax_ref + ff[F_DRAG] * s[3] * abs(s[3])
        g_lo, g_hi = grip_moment_range(ff, vx * vx * kappa, ax_ref, fa_plan,
                                       cp[CP_GRIP_USE])
        if dmz < g_lo or dmz > g_hi:
            dmz = min(max(dmz, g_lo), g_hi)
            yaw_sat = True
            push = dmz_cmd - dmz
    f1, f2, f3, f4 = allocate_core(cp[CP_LS], cp[CP_LF], delta, dmz, fa, cp[CP_EPS])
    lo, hi = cp[CP_FORCE_LO], cp[CP_FORCE_HI]
    force_sat = not (lo <= min(f1, f2, f3, f4) and max(f1, f2, f3, f4) <= hi)
    if force_sat:
        f1, f2 = min(max(f1, lo), hi), min(max(f2, lo), hi)
        f3, f4 = min(max(f3, lo), hi), min(max(f4, lo), hi)
    cs[10] = 1.0 if (steer_sat or yaw_sat or force_sat) else 0.0
    # conditional integration (anti-windup): an integrator stops only while its
    # actuator is saturated AND the error would push it further in. int(ye) acts
    # through the steering (on delta_f with the sign of -ye), int(phi_e) through
    # the wheel forces (on dMz with the sign of -phi_e). Freezing regardless can
    # hold a saturated demand for ever.
    if not (steer_sat and ye * delta_cmd < 0.0):
        cs[1] += ye * (h_ctrl * slow)
    if not ((yaw_sat or force_sat) and phi_e * push < 0.0):
        cs[2] += phi_e * (h_ctrl * slow)
    cs[3], cs[4], cs[5] = delta, dmz, fa
    cs[6], cs[7], cs[8], cs[9] = f1, f2, f3, f4
    return OK


@njit
def advance_core(kind: int, s: Array, pconst: Array, pinputs: Array, pforces: Array,
                 coef: Array, fp: Array, fr: Array, lp: Array, cp: Array, ff: Array,
                 cs: Array,
                 t: float, h: float,
                 substeps: int, control_every: int, counter: int) -> tuple[int, int, bool]:
    """`substeps` substeps of h from time t: the controller every `control_every`-th
    substep (`control_core`), then the plant (kind 0 two-track, 1 bicycle) over the
    substep with the inputs held. Returns (status, counter, saturated): status OK,
    BAD_CONTROL, or BAD_STATE with the time in cs[16]."""
    saturated = False
    for k in range(substeps):
        tk = t + k * h
        if counter % control_every == 0:
            if control_core(s, coef, fp, fr, lp, cp, ff, cs, tk, h * control_every) != OK:
                return BAD_CONTROL, counter, saturated
            saturated = saturated or cs[10] != 0.0
        counter += 1
        if kind == 0:
            twotrack_step(s, pconst, pinputs, pforces, h, cs[3], cs[6], cs[7], cs[8], cs[9])
        else:
            bicycle_step(s, pconst, pinputs, h, cs[3], cs[6], cs[7], cs[8], cs[9])
        total = 0.0
        for j in range(s.size):
            total += s[j]
        if not math.isfinite(total):  # any NaN or inf makes the sum non-finite
            cs[16] = tk + h
            return BAD_STATE, counter, saturated
    return OK, counter, saturated


@dataclass(frozen=True)
class LoopConfig:
    """Which plant and which law the closed loop runs, and how (beyond the gains)."""

    plant: str = PlantKind.TWOTRACK  # one of PLANTS
    controller: str = ControlLaw.MIMO  # one of CONTROLLERS
    control_every: int = 1  # substeps from one control update to the next
    speed_floor: float = 1.0  # m/s, the control laws never divide by less
    yaw_moment_share: float | None = YAW_MOMENT_SHARE  # -, friction share of dMz (None: off)
    low_speed_gain: bool = True  # eq. 28's gain within the tyres' lag (False: as printed)


def _check_config(config: LoopConfig, mu: float) -> None:
    """InputError for a plant, law or setting the closed loop does not have."""
    if config.plant not in PLANTS:
        raise InputError("closed loop", "plant", config.plant, f"one of {', '.join(PLANTS)}")
    if config.controller not in CONTROLLERS:
        raise InputError("closed loop", "controller", config.controller,
                         f"one of {', '.join(CONTROLLERS)}")
    if config.control_every < 1:
        raise InputError("closed loop", "control_every", config.control_every,
                         "an integer >= 1")
    if not 0.0 < mu <= 1.5:
        raise InputError("closed loop", "mu", mu, "road friction in (0, 1.5]")
    if not config.speed_floor > 0.0:
        raise InputError("closed loop", "speed_floor", config.speed_floor, "> 0 m/s")


class ClosedLoop:
    """One subject vehicle: plant, controller and actuators."""

    def __init__(
        self,
        config: LoopConfig,
        vehicle: VehicleParams,
        gains: ControllerGains,
        mu: float,
        start: PlantStart,
        *,
        chassis: ChassisParams | None = None,
        limits: ActuatorLimits | None = None,
        frame: Frame | None = None,  # the road frame the references are given in (None: x, y)
    ) -> None:
        """`start`: the plant's state at the start (on a curve the yaw rate is the lane's,
        speed x kappa)."""
        _check_config(config, mu)
        plant, controller = config.plant, config.controller
        yaw_moment_share = config.yaw_moment_share
        check_gains(gains)
        self.limits = limits or ActuatorLimits()
        self.limits.check()
        self.config = config
        self.vehicle = vehicle
        self.gains = gains
        self.controller = controller
        self.control_every = config.control_every
        self.speed_floor = config.speed_floor
        if yaw_moment_share is not None and not yaw_moment_share > 0.0:
            raise InputError("closed loop", "yaw_moment_share", yaw_moment_share,
                             "> 0, or None for no limit")
        self.dmz_limit = (
            math.inf if yaw_moment_share is None
            else yaw_moment_share * mu * vehicle.mass * G * vehicle.half_track
        )
        ch = chassis or chassis_for(vehicle)
        self.plant: Plant
        if plant == PlantKind.TWOTRACK:
            self.plant = TwoTrackPlant(vehicle, mu, start, chassis=ch)
        else:
            self.plant = BicyclePlant(vehicle, start)
        self._kind = PLANT_CODES[plant]
        self._pforces = getattr(self.plant, "_forces", np.zeros(1))
        self._lp = law_params(vehicle, gains)
        self._cp = self._controller_constants(ch)
        # the two-track car's tyres on curves (`cornering`; the bicycle's are linear)
        self._ff = cornering_params(vehicle, ch, mu, plant == PlantKind.TWOTRACK)
        self._cs = np.zeros(CS_SIZE)
        self._cs[CS_S_ROAD] = math.nan
        self.frame = frame or StraightFrame(0.0, 0.0, 0.0)
        self._fp, self._fr = self.frame.packed()
        self.road_pose = (math.nan, math.nan, math.nan)  # `errors`: s, d, heading to the road
        self._path: ReferencePath | None = None
        self._counter = 0
        self.batch_row = -1  # its row in a LoopBatch (cosim.control.loop_batch; -1: none)

    def _controller_constants(self, ch: ChassisParams) -> Array:
        """The controller's constant array `cp` (CP_* indices) for the compiled loop."""
        vehicle, gains, config = self.vehicle, self.gains, self.config
        # both plants get the force the same motors could deliver through wheels of radius R
        lo, hi = self.limits.wheel_force_bounds(ch.wheel_radius)
        return np.array([
            config.speed_floor, 1.0 if config.controller == ControlLaw.MIMO else 0.0,
            self.limits.max_steer, self.limits.max_steer_rate, self.dmz_limit, lo, hi,
            vehicle.half_track, vehicle.lf, gains.allocation_eps, vehicle.mass, gains.kx1,
            speed_gain_inverse_lag(ch.tyre.relaxation_long) if config.low_speed_gain else 0.0,
            vehicle.wheelbase * vehicle.lr * vehicle.cr, vehicle.lf * vehicle.mass,
            vehicle.yaw_inertia, GRIP_USE,
        ])

    @property
    def _int_ye(self) -> float:
        """m s, int(ye) of eq. 24."""
        return float(self._cs[1])

    @property
    def _int_phi(self) -> float:
        """rad s, int(phi_e) of eq. 24."""
        return float(self._cs[2])

    # -- reference --------------------------------------------------------------
    @property
    def reference(self) -> LaneChangeTrajectory | None:
        return None if self._path is None else self._path.trajectory

    def set_reference(self, reference: LaneChangeTrajectory, *, reset: bool = False) -> None:
        """Follow a new reference from now on. The integrators are kept (bumpless:
        the control output does not jump) unless `reset`; the projection restarts
        from the closest point of the new path."""
        self._path = ReferencePath(reference)
        s = self.plant.state
        s_road, d_road, _, _ = pose_in_frame(self._fp, self._fr, float(s[0]), float(s[1]),
                                             float(self._cs[CS_S_ROAD]))
        self._cs[0], _ = self._path.project(s_road, d_road, float(reference.t0))
        if reset:
            self.reset_integrators()

    def reset_integrators(self) -> None:
        """Zero int(ye) and int(phi_e) (eq. 24)."""
        self._cs[1] = 0.0
        self._cs[2] = 0.0

    # -- stepping ---------------------------------------------------------------
    def errors(self, t: float) -> PathErrors:
        """Path errors of the current plant state at time t (the reference must be set)."""
        assert self._path is not None
        x, y, psi, vx, vy, r = self.plant.state[:6].tolist()
        e = frame_path_errors(self._path.coef, self._fp, self._fr, t, x, y, psi, vx, vy, r,
                              float(self._cs[0]), float(self._cs[CS_S_ROAD]))
        self._cs[0] = e[5]
        self._cs[CS_S_ROAD] = e[11]
        self.road_pose = (e[11], e[12], e[13])
        return PathErrors(*e[:11])

    def advance(
        self, t: float, dt: float, substeps: int, reference: LaneChangeTrajectory
    ) -> StepRecord:
        """Advance from time t to t + dt in `substeps` substeps following `reference`;
        a reference different from the current one is taken up by `set_reference`."""
        if substeps < 1 or not dt > 0.0:
            raise InputError("closed loop", "substeps/dt", (substeps, dt), "substeps >= 1, dt > 0")
        if self._path is None or (
            reference is not self._path.trajectory and reference != self._path.trajectory
        ):
            self.set_reference(reference)
        assert self._path is not None
        plant = self.plant
        status, self._counter, saturated = advance_core(
            self._kind, plant.state, plant._const, plant._inputs, self._pforces,
            self._path.coef, self._fp, self._fr, self._lp, self._cp, self._ff, self._cs,
            float(t),
            dt / substeps,
            substeps, self.control_every, self._counter,
        )
        if status != OK:
            self._raise(status, t)
        return self.record(t + dt, bool(saturated))

    def _raise(self, status: int, t: float) -> None:
        """The SimulationError of a step from t that ended in `status` (BAD_STATE:
        the plant's state not finite; BAD_CONTROL: the control output)."""
        plant = self.plant
        if status == BAD_STATE:
            check_finite(float(self._cs[16]), plant.state_names, plant.state.tolist())
            return
        delta_cmd, dmz, fa, ye, phi_e = self._cs[11:16].tolist()
        state = ", ".join(
            f"{n} = {val:.6g}" for n, val in zip(
                plant.state_names, plant.state.tolist(), strict=True)
        )
        raise SimulationError(
            t, f"non-finite control output: delta_f = {delta_cmd}, dMz = {dmz}, "
            f"Fa = {fa} (ye = {ye:.4g}, phi_e = {phi_e:.4g})", state,
        )

    def record(self, t: float, saturated: bool = False) -> StepRecord:
        """The closed loop's state at time t (no control update)."""
        e = self.errors(t)
        out = self.plant.outputs()
        x, y, psi, vx, vy, r = self.plant.state[:6].tolist()
        delta, dmz, fa = self._cs[3:6].tolist()
        return StepRecord(
            t=t, x=x, y=y, heading=psi, vx=vx, vy=vy, yaw_rate=r, ax=out.ax, ay=out.ay,
            x_ref=e.x_ref, y_ref=e.y_ref, vx_ref=e.vx_ref, kappa_ref=e.kappa,
            ye=e.ye, phi_e=e.phi_e, ex=vx - e.vx_ref, along=e.along,
            delta_f=delta, dmz=dmz, fa=fa, fx=out.fx, fy=out.fy, fz=out.fz,
            saturated=saturated,
        )


@register_warm_up
def warm_up() -> None:
    """Compile (or load from numba's cache) every compiled function, for every plant
    and controller, by calling each entry point once (a function compiled only as the
    callee of another has no entry of its own for Python callers): a process that
    forks runs from it (a fork server) calls this once, so that no run pays for it."""
    from cosim.planning.trajectory import LaneChangeTrajectory as Trajectory

    from .allocation import allocate
    from .longitudinal import longitudinal_force
    from .triple_step import LawErrors, design_terms, mimo_law, siso_law

    vehicle, gains = VehicleParams(), ControllerGains()
    ref = Trajectory(t0=0.0, tau=1.0, x0=0.0, y0=0.0, vx0=20.0, vxf=20.0, width=0.0)
    for plant in PLANTS:
        for controller in CONTROLLERS:
            loop = ClosedLoop(LoopConfig(plant, controller), vehicle, gains, 0.8,
                              PlantStart(vx=20.0))
            loop.advance(0.0, 0.05, 10, ref)
        p = loop.plant
        p.step(0.005, 0.0, (0.0, 0.0, 0.0, 0.0))
        p.derivative(p.state)
        p.outputs()
        if isinstance(p, TwoTrackPlant):
            p.wheel_time_constant()
        else:
            p.set_inputs(0.0, (0.0, 0.0, 0.0, 0.0))
            p.lateral_forces(p.state)
        path = ReferencePath(ref)
        path.point(0.5)
        path.project(1.0, 0.0, 0.0)
    allocate(vehicle, 0.0, 0.0, 0.0, gains.allocation_eps)
    longitudinal_force(vehicle, gains, 20.0, 20.0, 0.0)
    design_terms(vehicle, 20.0, 0.0, 0.0)
    mimo_law(vehicle, gains, 20.0, 0.0, LawErrors(0.0, 0.0, 0.0, 0.0))
    siso_law(vehicle, gains, 20.0, 0.0, LawErrors(0.0, 0.0, 0.0, 0.0))
    ActuatorLimits().steer(0.0, 0.0, 0.005)
