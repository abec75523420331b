"""Two-track validation plant (beyond the paper, which used veDYNA).

Four wheels with their own spin, Magic Formula tyres with combined slip, load
sensitivity and relaxation lengths (`cosim.vehicle.tyre`), static and dynamic load
transfer, aerodynamic drag (Table 1's Ca), active front steering (both front wheels
at delta) and one torque per wheel (in-wheel motors / brakes). Wheels: 1 FL, 2 FR,
3 RL, 4 RR.

State (20): x, y, heading, vx, vy, yaw_rate, omega_1..4 (rad/s), the body
accelerations ax_load, ay_load (m/s^2) that set the load transfer, and the tyres'
relaxed slips kappa_1..4 (-) and alpha_1..4 (tangent of the slip angle). The load
accelerations follow the real ones through a first-order lag
(`ChassisParams.load_lag`), which stands for the body's pitch and roll and breaks
the algebraic loop between loads and forces. The steady transfers are the rigid car's,
m h a over the track (lateral) and the wheelbase (longitudinal), times
`ChassisParams.lateral_transfer_gain` / `longitudinal_transfer_gain` (1 by default; a
body that rolls on compliant springs and tyres transfers more: the CommonRoad presets
take their multi-body model's, docs/control_results.md).

Relaxation (Pacejka, 3rd ed., sec. 7.2): sigma dkappa'/dt + |u| kappa' = omega R - u,
sigma dalpha'/dt + |u| alpha' = -v (u, v: the wheel centre's velocity along and
across the wheel). At speed kappa', alpha' follow the kinematic slips
(omega R - u) / |u| and -v / |u| with the lag sigma / |u|; nothing divides by the
speed, so the plant runs through a standstill. Below `TyreParams.low_speed` the
slips get Pacejka's low-speed damping k_Vlow (slip speed) / K, faded in by
(1 + cos(pi |u| / V_low)) / 2, which damps the tyre-spring modes of a stopped car.

Torques: a positive wheel torque drives (in-wheel motor), a negative one brakes: a
friction brake opposes the wheel's spin and holds a stopped wheel (it never spins it
backwards), so the car stops and stays stopped under a held brake; it does not
reverse. ABS / traction control cut a torque whose wheel is past the tyre's peak
slip (`twotrack_slip_limit`).

The tyres' cornering stiffness is chosen so that each axle has Table 1's Cf or Cr
at the static load: at small slip this plant and the 2-DOF model agree (tested
through the steady-state yaw-rate gain and the tyre's slope at zero slip).

Integration: fixed-step RK4. The stiff modes are the wheel spin on its tyre
(longitudinal relaxation: rate sqrt(R^2 K_kappa / (Iw sigma_kappa)), or |u| /
sigma_kappa when larger) and the low-speed damping, so `step` splits a substep into
RK4 steps no longer than `step_factor` (2.4: RK4 is stable for |h lambda| up to
2.62 at the worst angle, 2.78 on the real axis) over the fastest rate, and no
longer than `max_step` (5 ms): one RK4 step per 5 ms substep at highway speed.

Speed: the derivative, the ABS / traction control and the RK4 loop are compiled
(numba, `cosim.compiled`) and work on float arrays in place; the closed
loop calls `twotrack_step` from its own compiled substep loop, the class methods
wrap the same functions for Python callers.
"""

from __future__ import annotations

import math

import numpy as np

from cosim.compiled import Array, njit
from cosim.errors import InputError
from cosim.params import VehicleParams
from cosim.vehicle.chassis import (
    ChassisParams,
    chassis_for,
    static_wheel_loads,
    transfer_per_wheel,
)
from cosim.vehicle.plant import PlantOutputs, PlantStart
from cosim.vehicle.tyre import N_TYRE, combined_forces, peak_slip

STATE_NAMES = (
    "x", "y", "heading", "vx", "vy", "yaw_rate",
    "omega_fl", "omega_fr", "omega_rl", "omega_rr", "ax_load", "ay_load",
    "kappa_fl", "kappa_fr", "kappa_rl", "kappa_rr",
    "alpha_fl", "alpha_fr", "alpha_rl", "alpha_rr",
)
N_STATE = len(STATE_NAMES)
BRAKE_HOLD = 0.0025  # s, time in which a brake stops a slow wheel (a stiff friction model)
N_FORCES = 14  # ax, ay, Fx1..4, Fy1..4, Fz1..4 at the head of the forces array
# Layout of the constants array (values: `TwoTrackPlant.__init__`); the tyre's
# coefficients (`TyreParams.array`) follow at C_TYRE.
(C_INV_MASS, C_INV_IZ, C_LF, C_LR, C_LS, C_RAD, C_FLOOR, C_MU, C_DRAG, C_INV_IW, C_INV_LAG,
 C_KD_LONG, C_KD_LAT_F, C_KD_LAT_R, C_FZ0F, C_FZ0R, C_KAF, C_KAR, C_PEAK, C_FZ_MAX, C_K_LONG,
 C_K_LAT, C_STIFF, C_INV_SIG_K, C_INV_SIG_A, C_VLOW, C_DAMP_X_F, C_DAMP_X_R, C_DAMP_Y_F, C_DAMP_Y_R,
 C_INV_HOLD, C_DAMP_RATE, C_MAX_STEP, C_STEP_FACTOR, C_TYRE) = range(35)
N_CONST = C_TYRE + N_TYRE


@njit
def low_speed_share(speed: float, vlow: float) -> float:
    """-, how much of the slip damping acts at a wheel moving at `speed` (m/s): 1 at
    rest, falling along a half cosine to 0 at `vlow` and above."""
    return 0.5 * (1.0 + math.cos(math.pi * min(speed / vlow, 1.0)))


@njit
def twotrack_derivative(s: Array, c: Array, inputs: Array, forces: Array, out: Array) -> None:
    """ds/dt at state s into `out`; inputs = (cos delta, sin delta, four wheel torques);
    the accelerations and wheel forces (ax, ay, Fx1..4, Fy1..4, Fz1..4) into `forces`."""
    inv_m, inv_iz, lf, lr, ls, rad = (c[C_INV_MASS], c[C_INV_IZ], c[C_LF], c[C_LR], c[C_LS],
                                      c[C_RAD])
    mu, drag, inv_iw, inv_lag = c[C_MU], c[C_DRAG], c[C_INV_IW], c[C_INV_LAG]
    fz0f, fz0r, kaf, kar = c[C_FZ0F], c[C_FZ0R], c[C_KAF], c[C_KAR]
    psi, vx, vy, r = s[2], s[3], s[4], s[5]
    axl, ayl = s[10], s[11]
    cd, sd = inputs[0], inputs[1]

    # vertical loads: static + longitudinal (pitch) + lateral (roll) transfer
    dlong = c[C_KD_LONG] * axl
    dlat_f = c[C_KD_LAT_F] * ayl
    dlat_r = c[C_KD_LAT_R] * ayl
    fz1 = fz0f - dlong - dlat_f
    fz2 = fz0f - dlong + dlat_f
    fz3 = fz0r + dlong - dlat_r
    fz4 = fz0r + dlong + dlat_r
    # a lifted wheel carries nothing
    fz1 = fz1 if fz1 > 0.0 else 0.0
    fz2 = fz2 if fz2 > 0.0 else 0.0
    fz3 = fz3 if fz3 > 0.0 else 0.0
    fz4 = fz4 if fz4 > 0.0 else 0.0

    # wheel-centre velocities (body frame), then into each wheel's frame
    vl = vx - r * ls  # left wheels' body-x speed
    vr = vx + r * ls  # right wheels' body-x speed
    vyf = vy + r * lf
    vyr = vy - r * lr
    u1 = vl * cd + vyf * sd
    l1 = -vl * sd + vyf * cd
    u2 = vr * cd + vyf * sd
    l2 = -vr * sd + vyf * cd

    # relaxed slips (first-order, no division by speed), then the low-speed damping
    isk, isa = c[C_INV_SIG_K], c[C_INV_SIG_A]
    sx1, sx2, sx3, sx4 = s[6] * rad - u1, s[7] * rad - u2, s[8] * rad - vl, s[9] * rad - vr
    k1, k2, k3, k4 = s[12], s[13], s[14], s[15]
    a1, a2, a3, a4 = s[16], s[17], s[18], s[19]
    au1, au2, au3, au4 = abs(u1), abs(u2), abs(vl), abs(vr)
    out[12] = (sx1 - au1 * k1) * isk
    out[13] = (sx2 - au2 * k2) * isk
    out[14] = (sx3 - au3 * k3) * isk
    out[15] = (sx4 - au4 * k4) * isk
    out[16] = (-l1 - au1 * a1) * isa
    out[17] = (-l2 - au2 * a2) * isa
    out[18] = (-vyr - au3 * a3) * isa
    out[19] = (-vyr - au4 * a4) * isa
    vlow = c[C_VLOW]
    if min(au1, au2, au3, au4) < vlow:
        w1, w2 = low_speed_share(au1, vlow), low_speed_share(au2, vlow)
        w3, w4 = low_speed_share(au3, vlow), low_speed_share(au4, vlow)
        dxf, dyf, dxr, dyr = c[C_DAMP_X_F], c[C_DAMP_Y_F], c[C_DAMP_X_R], c[C_DAMP_Y_R]
        k1, k2, k3, k4 = (k1 + w1 * dxf * sx1, k2 + w2 * dxf * sx2,
                          k3 + w3 * dxr * sx3, k4 + w4 * dxr * sx4)
        a1, a2, a3, a4 = (a1 - w1 * dyf * l1, a2 - w2 * dyf * l2,
                          a3 - w3 * dyr * vyr, a4 - w4 * dyr * vyr)

    ifz0f, ifz0r = 1.0 / fz0f, 1.0 / fz0r
    fx1, fy1 = combined_forces(k1, a1, fz1, ifz0f, kaf, mu, c, C_TYRE)
    fx2, fy2 = combined_forces(k2, a2, fz2, ifz0f, kaf, mu, c, C_TYRE)
    fx3, fy3 = combined_forces(k3, a3, fz3, ifz0r, kar, mu, c, C_TYRE)
    fx4, fy4 = combined_forces(k4, a4, fz4, ifz0r, kar, mu, c, C_TYRE)

    # front forces into the body frame
    fxf = fx1 + fx2
    fyf = fy1 + fy2
    bx1 = fx1 * cd - fy1 * sd
    bx2 = fx2 * cd - fy2 * sd
    fx_body = fxf * cd - fyf * sd + fx3 + fx4
    fy_body = fxf * sd + fyf * cd + fy3 + fy4
    mz = (
        lf * (fxf * sd + fyf * cd)
        - lr * (fy3 + fy4)
        + ls * (bx2 - bx1 + fx4 - fx3)
    )
    ax = (fx_body - drag * vx * abs(vx)) * inv_m
    ay = fy_body * inv_m
    forces[0], forces[1] = ax, ay
    forces[2], forces[3], forces[4], forces[5] = fx1, fx2, fx3, fx4
    forces[6], forces[7], forces[8], forces[9] = fy1, fy2, fy3, fy4
    forces[10], forces[11], forces[12], forces[13] = fz1, fz2, fz3, fz4
    c_, sn = math.cos(psi), math.sin(psi)
    out[0] = vx * c_ - vy * sn
    out[1] = vx * sn + vy * c_
    out[2] = r
    out[3] = ax + vy * r
    out[4] = ay - vx * r
    out[5] = mz * inv_iz
    inv_hold = c[C_INV_HOLD]
    out[6] = wheel_acceleration(inputs[2], rad * fx1, s[6], inv_iw, inv_hold)
    out[7] = wheel_acceleration(inputs[3], rad * fx2, s[7], inv_iw, inv_hold)
    out[8] = wheel_acceleration(inputs[4], rad * fx3, s[8], inv_iw, inv_hold)
    out[9] = wheel_acceleration(inputs[5], rad * fx4, s[9], inv_iw, inv_hold)
    out[10] = (ax - axl) * inv_lag
    out[11] = (ay - ayl) * inv_lag


@njit
def wheel_acceleration(torque: float, tyre_torque: float, omega: float, inv_iw: float,
                       inv_hold: float) -> float:
    """rad/s^2 of one wheel (inv_iw: 1 / its spin inertia): a torque >= 0 drives; a
    torque < 0 is a friction brake of that size, which opposes the spin: it gives the
    torque that would stop the wheel within 1 / inv_hold seconds, at most |torque| (so
    it holds a stopped wheel and never spins it backwards)."""
    if torque >= 0.0:
        return (torque - tyre_torque) * inv_iw
    net = -tyre_torque
    brake = -(omega * inv_hold / inv_iw + net)
    limit = -torque
    brake = brake if brake < limit else limit
    brake = brake if brake > -limit else -limit
    return (net + brake) * inv_iw


@njit
def twotrack_stiff_rate(s: Array, c: Array) -> float:
    """1/s, the fastest rate of the wheel-spin / tyre modes at state s (RK4's step limit):
    a bound on the largest |eigenvalue| of a wheel's 2x2 (relaxed slip, spin) system,
    max(trace, sqrt(det)), or the lateral relaxation's |u| / sigma_alpha if larger, with
    20 % margin on the largest wheel load (loads move within a substep)."""
    v = abs(s[3]) + c[C_LS] * abs(s[5])
    fz_max = c[C_FZ_MAX] + c[C_K_LONG] * abs(s[10]) + c[C_K_LAT] * abs(s[11])
    trace = v * c[C_INV_SIG_K]
    if abs(s[3]) < 2.0 * c[C_VLOW]:  # the low-speed damping acts on some wheel
        trace += c[C_DAMP_RATE] * fz_max
    det = c[C_STIFF] * fz_max
    # complex pair: |lambda| = sqrt(det); real pair: at most the trace (past the tyre's peak
    # the slope, hence det, turns slightly negative: step_factor keeps room for that)
    rate = math.sqrt(det)
    rate = trace if trace > rate else rate
    lateral = v * c[C_INV_SIG_A]  # the lateral relaxation's own rate |u| / sigma_alpha
    return lateral if lateral > rate else rate


@njit
def twotrack_slip_limit(s: Array, c: Array, inputs: Array, forces: Array) -> None:
    """ABS / traction control on the torques inputs[2:6] (in place): a wheel whose
    longitudinal slip is past the peak of its tyre curve, in the direction its torque
    pushes, gets only the torque its tyre transmits (R Fx at the last evaluation), so it
    neither locks nor spins up. Slips are those of state s, forces those of the last
    derivative; inputs[0:2] = cos, sin of the steering angle."""
    vx, vy, r = s[3], s[4], s[5]
    ls, lf, rad, floor, peak = c[C_LS], c[C_LF], c[C_RAD], c[C_FLOOR], c[C_PEAK]
    cd, sd = inputs[0], inputs[1]
    vyf = vy + r * lf
    vl, vr = vx - r * ls, vx + r * ls
    for i in range(4):
        if i == 0:
            u = vl * cd + vyf * sd
        elif i == 1:
            u = vr * cd + vyf * sd
        elif i == 2:
            u = vl
        else:
            u = vr
        t = inputs[2 + i]
        excess = s[6 + i] * rad - u  # slip speed
        limit = peak * (u if u > floor else (-u if -u > floor else floor))
        if (t > 0.0 and excess > limit) or (t < 0.0 and excess < -limit):
            transmitted = rad * forces[2 + i]
            inputs[2 + i] = min(t, transmitted) if t > 0.0 else max(t, transmitted)


@njit
def twotrack_step(s: Array, c: Array, inputs: Array, forces: Array, h: float, delta: float,
                  f1: float, f2: float, f3: float, f4: float) -> None:
    """Integrate state s (in place) h seconds: steering delta (rad), wheel torques R * f
    (N m) cut by `twotrack_slip_limit`; RK4 steps no longer than step_factor over the
    fastest tyre rate and max_step."""
    rad = c[C_RAD]
    inputs[0], inputs[1] = math.cos(delta), math.sin(delta)
    inputs[2], inputs[3], inputs[4], inputs[5] = rad * f1, rad * f2, rad * f3, rad * f4
    twotrack_slip_limit(s, c, inputs, forces)
    limit = c[C_STEP_FACTOR] / twotrack_stiff_rate(s, c)
    if limit > c[C_MAX_STEP]:
        limit = c[C_MAX_STEP]
    n = max(1, math.ceil(h / limit - 1e-9))
    hi = h / n
    half = 0.5 * hi
    sixth = hi / 6.0
    # RK4 stages and the trial state live in `forces` past its first N_FORCES entries
    # (views, no allocation per call: a substep is about 1 us)
    k1 = forces[N_FORCES:N_FORCES + N_STATE]
    k2 = forces[N_FORCES + N_STATE:N_FORCES + 2 * N_STATE]
    k3 = forces[N_FORCES + 2 * N_STATE:N_FORCES + 3 * N_STATE]
    k4 = forces[N_FORCES + 3 * N_STATE:N_FORCES + 4 * N_STATE]
    tmp = forces[N_FORCES + 4 * N_STATE:N_FORCES + 5 * N_STATE]
    for _ in range(n):
        twotrack_derivative(s, c, inputs, forces, k1)
        for j in range(N_STATE):
            tmp[j] = s[j] + half * k1[j]
        twotrack_derivative(tmp, c, inputs, forces, k2)
        for j in range(N_STATE):
            tmp[j] = s[j] + half * k2[j]
        twotrack_derivative(tmp, c, inputs, forces, k3)
        for j in range(N_STATE):
            tmp[j] = s[j] + hi * k3[j]
        twotrack_derivative(tmp, c, inputs, forces, k4)
        for j in range(N_STATE):
            s[j] = s[j] + sixth * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j])


class TwoTrackPlant:
    """Four-wheel planar vehicle with wheel spin, Magic Formula tyres and load transfer."""

    kind = "twotrack"
    state_names = STATE_NAMES

    def __init__(
        self,
        vehicle: VehicleParams,
        mu: float,
        start: PlantStart | None = None,
        *,
        chassis: ChassisParams | None = None,
        max_step: float = 0.005,  # s, longest RK4 step
        step_factor: float = 2.4,  # -, RK4 step x fastest rate (RK4 stable to 2.62 or more)
    ) -> None:
        if not 0.0 < mu <= 1.5:
            raise InputError("twotrack", "mu", mu, "road friction in (0, 1.5]")
        self.vehicle = vehicle
        self.chassis = chassis or chassis_for(vehicle)
        self.chassis.check()
        self.mu = mu
        self.max_step = max_step
        self.step_factor = step_factor
        ch = self.chassis
        self.wheel_radius = ch.wheel_radius
        self.fz0_front, self.fz0_rear = static_wheel_loads(vehicle)
        # cornering stiffness of one wheel at its static load: the axle has Cf (Cr) there
        # (times cornering_scale, 1 by default)
        self.k_alpha_front = ch.cornering_scale * vehicle.cf / 2.0
        self.k_alpha_rear = ch.cornering_scale * vehicle.cr / 2.0
        self._const = self._constants()
        st = start or PlantStart()
        vx, vy, yaw_rate = st.vx, st.vy, st.yaw_rate
        w0 = vx / ch.wheel_radius
        self.state = np.zeros(N_STATE)
        self.state[:10] = [st.x, st.y, st.heading, vx, vy, yaw_rate, w0, w0, w0, w0]
        # relaxed lateral slips start at their kinematic values (no transient at t = 0)
        for i, (px, py) in enumerate(((vehicle.lf, vehicle.half_track),
                                      (vehicle.lf, -vehicle.half_track),
                                      (-vehicle.lr, vehicle.half_track),
                                      (-vehicle.lr, -vehicle.half_track))):
            u, lat = vx - yaw_rate * py, vy + yaw_rate * px
            self.state[16 + i] = -lat / abs(u) if abs(u) > ch.slip_speed_floor else 0.0
        self._delta = 0.0
        # held inputs: cos delta, sin delta, four wheel torques (N m)
        self._inputs = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        # ax, ay, Fx1..4, Fy1..4, Fz1..4 at the last derivative evaluation, then the RK4
        # work space of `twotrack_step`
        self._forces = np.zeros(N_FORCES + 5 * N_STATE)
        self._scratch = np.empty(N_STATE)  # the derivative `outputs` does not need

    def _constants(self) -> Array:
        """The constant array the compiled derivative reads (C_* indices), the tyre's
        coefficients at its end."""
        vehicle, ch, mu = self.vehicle, self.chassis, self.mu
        max_step, step_factor = self.max_step, self.step_factor
        ty = ch.tyre
        dlat, dlong = transfer_per_wheel(vehicle, ch)
        fz_max = 1.2 * max(self.fz0_front, self.fz0_rear)
        # low-speed damping as slip per slip speed (k_Vlow / K at the static load)
        ck = ty.slip_stiffness
        # longitudinal slip at the peak of the pure-slip curve (ABS / TCS): B kappa = peak
        peak = peak_slip(ty.shape_long, ty.curvature_long) * ty.shape_long * mu \
            * ty.friction_long_ratio / ck
        const = [0.0] * C_TYRE
        const[C_INV_MASS], const[C_INV_IZ], const[C_LF], const[C_LR] = (
            1.0 / vehicle.mass, 1.0 / vehicle.yaw_inertia, vehicle.lf, vehicle.lr)
        const[C_LS], const[C_RAD], const[C_FLOOR], const[C_MU] = (
            vehicle.half_track, ch.wheel_radius, ch.slip_speed_floor, mu)
        const[C_DRAG], const[C_INV_IW], const[C_INV_LAG] = (
            vehicle.drag, 1.0 / ch.wheel_inertia, 1.0 / ch.load_lag)
        const[C_KD_LONG] = dlong
        const[C_KD_LAT_F] = dlat * ch.roll_share_front
        const[C_KD_LAT_R] = dlat * (1.0 - ch.roll_share_front)
        const[C_FZ0F], const[C_FZ0R] = self.fz0_front, self.fz0_rear
        const[C_KAF], const[C_KAR] = self.k_alpha_front, self.k_alpha_rear
        const[C_PEAK] = peak if ch.anti_lock else math.inf  # inf: the limit never acts
        const[C_FZ_MAX], const[C_K_LONG], const[C_K_LAT] = fz_max, 1.2 * dlong, 1.2 * dlat
        # wheel spin on the tyre: det = R^2 ck Fz / (Iw sigma_k) per N of load
        const[C_STIFF] = ch.wheel_radius**2 * ck / (ch.wheel_inertia * ty.relaxation_long)
        const[C_INV_SIG_K], const[C_INV_SIG_A] = 1.0 / ty.relaxation_long, 1.0 / ty.relaxation_lat
        const[C_VLOW] = ty.low_speed
        const[C_DAMP_X_F] = ty.damping_long / (ck * self.fz0_front)
        const[C_DAMP_X_R] = ty.damping_long / (ck * self.fz0_rear)
        const[C_DAMP_Y_F] = ty.damping_lat / self.k_alpha_front
        const[C_DAMP_Y_R] = ty.damping_lat / self.k_alpha_rear
        # the brake stops a slow wheel within BRAKE_HOLD (RK4-stable: rate 1 / hold at most
        # step_factor / max_step)
        const[C_INV_HOLD] = 1.0 / max(BRAKE_HOLD, max_step / step_factor)
        # low-speed damping's rate on the wheel spin per N of load: k R^2 / Iw (upper bound)
        const[C_DAMP_RATE] = ty.damping_long * ch.wheel_radius**2 / (
            ch.wheel_inertia * min(self.fz0_front, self.fz0_rear))
        const[C_MAX_STEP], const[C_STEP_FACTOR] = max_step, step_factor
        out = np.array(const + ty.array())
        assert out.size == N_CONST
        return out

    # -- dynamics --------------------------------------------------------------
    def derivative(self, s: list[float] | Array) -> list[float]:
        """ds/dt at state s with the held steering angle and wheel torques."""
        out = np.empty(N_STATE)
        twotrack_derivative(np.asarray(s, dtype=float), self._const, self._inputs,
                            self._forces, out)
        return out.tolist()

    def wheel_time_constant(self) -> float:
        """s, the fastest wheel-spin / tyre time constant at the current state (RK4's step
        is at most step_factor times it)."""
        return 1.0 / float(twotrack_stiff_rate(self.state, self._const))

    def step(self, h: float, delta: float, fx_cmd: tuple[float, float, float, float]) -> None:
        """Integrate h seconds: steering delta (rad), wheel torques R * fx_cmd (N m), cut
        by the ABS / traction control of `twotrack_slip_limit`."""
        self._delta = delta
        f1, f2, f3, f4 = (float(f) for f in fx_cmd)
        twotrack_step(self.state, self._const, self._inputs, self._forces, float(h),
                      float(delta), f1, f2, f3, f4)

    def outputs(self) -> PlantOutputs:
        """Accelerations and tyre forces at the current state."""
        twotrack_derivative(self.state, self._const, self._inputs, self._forces, self._scratch)
        ax, ay, f1, f2, f3, f4, y1, y2, y3, y4, z1, z2, z3, z4 = self._forces[:N_FORCES].tolist()
        return PlantOutputs(ax, ay, (f1, f2, f3, f4), (y1, y2, y3, y4), (z1, z2, z3, z4))
