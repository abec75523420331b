"""Two-track validation plant (beyond the paper, which used veDYNA).

Four wheels with their own spin, nonlinear combined-slip tyres saturating at
mu Fz (`cosim.vehicle.tyre`), static and dynamic load transfer, aerodynamic drag
(Table 1's Ca), active front steering (both front wheels at delta) and one
torque per wheel (in-wheel motors / brakes). Wheels: 1 FL, 2 FR, 3 RL, 4 RR.

State (12): x, y, heading, vx, vy, yaw_rate, omega_1..4 (rad/s), and the body
accelerations ax_load, ay_load (m/s^2) that set the load transfer. They follow
the real accelerations through a first-order lag (`ChassisParams.load_lag`),
which stands for the body's pitch and roll and breaks the algebraic loop
between loads and forces.

The tyres' cornering stiffness is chosen per unit load so that each axle has
Table 1's Cf or Cr at the static load: at small slip this plant and the 2-DOF
model agree (tested through the steady-state yaw-rate gain).

Integration: fixed-step RK4. The wheel-spin mode is the stiff one, with time
constant Iw v / (C_kappa R^2) (about 2.7 ms at 25 m/s with the largest load
expected), so `step` splits a substep into RK4 steps no longer than
`step_factor` (2, inside RK4's real-axis stability limit 2.78) times that
constant and no longer than `max_step` (5 ms): one RK4 step per 5 ms substep at
highway speed, more at low speed. Against a 0.2 ms reference, a 3 s sine-steer
and drive/brake manoeuvre at 25 m/s ends within 1e-6 m and 1e-6 rad/s.
"""

from __future__ import annotations

import math

from cosim.errors import InputError
from cosim.params import G, VehicleParams
from cosim.vehicle.chassis import ChassisParams, static_wheel_loads
from cosim.vehicle.integrate import rk4_step
from cosim.vehicle.plant import PlantOutputs
from cosim.vehicle.tyre import peak_slip

STATE_NAMES = (
    "x", "y", "heading", "vx", "vy", "yaw_rate",
    "omega_fl", "omega_fr", "omega_rl", "omega_rr", "ax_load", "ay_load",
)


class TwoTrackPlant:
    """Four-wheel planar vehicle with wheel spin, combined-slip tyres and load transfer."""

    kind = "twotrack"
    state_names = STATE_NAMES

    def __init__(
        self,
        vehicle: VehicleParams,
        mu: float,
        x: float = 0.0,
        y: float = 0.0,
        heading: float = 0.0,
        vx: float = 20.0,
        vy: float = 0.0,
        yaw_rate: float = 0.0,
        *,
        chassis: ChassisParams | None = None,
        max_step: float = 0.005,  # s, longest RK4 step
        step_factor: float = 2.0,  # -, RK4 step / wheel-spin time constant (RK4 stable to 2.78)
    ) -> None:
        if not 0.0 < mu <= 1.5:
            raise InputError("twotrack", "mu", mu, "road friction in (0, 1.5]")
        self.vehicle = vehicle
        self.chassis = chassis or ChassisParams()
        self.chassis.check()
        self.mu = mu
        self.max_step = max_step
        self.step_factor = step_factor
        ch = self.chassis
        self.wheel_radius = ch.wheel_radius
        self.fz0_front, self.fz0_rear = static_wheel_loads(vehicle)
        # cornering stiffness per unit load: the axle has Cf (Cr) at its static load
        # (times cornering_scale, 1 by default)
        self.c_alpha_front = ch.cornering_scale * vehicle.cf / (2.0 * self.fz0_front)
        self.c_alpha_rear = ch.cornering_scale * vehicle.cr / (2.0 * self.fz0_rear)
        dlat = vehicle.mass * ch.cg_height / (2.0 * vehicle.half_track)  # N per m/s^2
        # constants of `derivative`, unpacked at once (attribute look-ups are slow)
        # (stiffnesses over mu: the normalised slips of `cosim.vehicle.tyre`)
        self._const = (
            vehicle.mass, vehicle.yaw_inertia, vehicle.lf, vehicle.lr, vehicle.half_track,
            ch.wheel_radius, ch.slip_speed_floor, ch.shape, 1.0 / ch.shape,
            ch.slip_stiffness / mu, mu, vehicle.drag, ch.wheel_inertia, ch.load_lag,
            vehicle.mass * ch.cg_height / (2.0 * vehicle.wheelbase),
            dlat * ch.roll_share_front, dlat * (1.0 - ch.roll_share_front),
            self.fz0_front, self.fz0_rear, self.c_alpha_front / mu, self.c_alpha_rear / mu,
        )
        w0 = vx / ch.wheel_radius
        self.state = [x, y, heading, vx, vy, yaw_rate, w0, w0, w0, w0, 0.0, 0.0]
        self._delta = 0.0
        self._cos_sin_delta = (1.0, 0.0)
        self._torque = (0.0, 0.0, 0.0, 0.0)
        self._forces: tuple[float, ...] = (0.0,) * 14
        # longitudinal slip at the peak of the pure-slip tyre curve (ABS / TCS threshold)
        self._kappa_peak = peak_slip(ch.shape) * mu / ch.slip_stiffness
        # constants of `wheel_time_constant`: loads with 20 % margin
        self._tau_const = (
            vehicle.half_track, ch.slip_speed_floor,
            1.2 * max(self.fz0_front, self.fz0_rear),
            1.2 * vehicle.mass * ch.cg_height / (2.0 * vehicle.wheelbase),
            1.2 * vehicle.mass * ch.cg_height / (2.0 * vehicle.half_track),
            ch.wheel_inertia / (ch.slip_stiffness * ch.wheel_radius**2),
        )

    # -- dynamics --------------------------------------------------------------
    def derivative(self, s: list[float]) -> list[float]:
        """ds/dt at state s with the held steering angle and wheel torques."""
        (m, iz, lf, lr, ls, rad, floor, shape, inv_shape, ckm, mu, drag, iw, lag, kd_long,
         kd_lat_f, kd_lat_r, fz0f, fz0r, cafm, carm) = self._const
        _, _, psi, vx, vy, r, w1, w2, w3, w4, axl, ayl = s
        cd, sd = self._cos_sin_delta

        # vertical loads: static + longitudinal (pitch) + lateral (roll) transfer
        dlong = kd_long * axl
        dlat_f = kd_lat_f * ayl
        dlat_r = kd_lat_r * ayl
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

        # tyres: `cosim.vehicle.tyre.tyre_forces` inlined (this is the hot loop)
        atan, sin, sqrt = math.atan, math.sin, math.sqrt
        # FL
        ref = u1 if u1 > floor else (-u1 if -u1 > floor else floor)
        ux, uy = ckm * (w1 * rad - u1) / ref, -cafm * l1 / ref
        u = sqrt(ux * ux + uy * uy)
        d = mu * fz1 * (sin(shape * atan(u * inv_shape)) / u if u > 1e-9 else 1.0)
        fx1, fy1 = d * ux, d * uy
        # FR
        ref = u2 if u2 > floor else (-u2 if -u2 > floor else floor)
        ux, uy = ckm * (w2 * rad - u2) / ref, -cafm * l2 / ref
        u = sqrt(ux * ux + uy * uy)
        d = mu * fz2 * (sin(shape * atan(u * inv_shape)) / u if u > 1e-9 else 1.0)
        fx2, fy2 = d * ux, d * uy
        # RL
        ref = vl if vl > floor else (-vl if -vl > floor else floor)
        ux, uy = ckm * (w3 * rad - vl) / ref, -carm * vyr / ref
        u = sqrt(ux * ux + uy * uy)
        d = mu * fz3 * (sin(shape * atan(u * inv_shape)) / u if u > 1e-9 else 1.0)
        fx3, fy3 = d * ux, d * uy
        # RR
        ref = vr if vr > floor else (-vr if -vr > floor else floor)
        ux, uy = ckm * (w4 * rad - vr) / ref, -carm * vyr / ref
        u = sqrt(ux * ux + uy * uy)
        d = mu * fz4 * (sin(shape * atan(u * inv_shape)) / u if u > 1e-9 else 1.0)
        fx4, fy4 = d * ux, d * uy

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
        ax = (fx_body - drag * vx * abs(vx)) / m
        ay = fy_body / m
        t1, t2, t3, t4 = self._torque
        self._forces = (ax, ay, fx1, fx2, fx3, fx4, fy1, fy2, fy3, fy4, fz1, fz2, fz3, fz4)
        c, sn = math.cos(psi), math.sin(psi)
        return [
            vx * c - vy * sn,
            vx * sn + vy * c,
            r,
            ax + vy * r,
            ay - vx * r,
            mz / iz,
            (t1 - rad * fx1) / iw,
            (t2 - rad * fx2) / iw,
            (t3 - rad * fx3) / iw,
            (t4 - rad * fx4) / iw,
            (ax - axl) / lag,
            (ay - ayl) / lag,
        ]

    def wheel_time_constant(self) -> float:
        """s, fastest wheel-spin time constant Iw v / (C_kappa Fz R^2) at the current state,
        with 20 % margin on the largest wheel load (loads move within a substep)."""
        s = self.state
        half_track, floor, fz_max0, k_long, k_lat, scale = self._tau_const
        v = abs(s[3]) - half_track * abs(s[5])
        fz_max = fz_max0 + k_long * abs(s[10]) + k_lat * abs(s[11])
        return scale * (v if v > floor else floor) / fz_max

    def _slip_limited(self, torques: tuple[float, float, float, float]) -> tuple[
        float, float, float, float
    ]:
        """ABS / traction control: a wheel whose longitudinal slip is past the peak of
        its tyre curve, in the direction its torque pushes, gets only the torque its
        tyre transmits (R Fx at the last evaluation), so it neither locks nor spins up.
        Slips are those of the current state, forces those of the last derivative."""
        s = self.state
        vx, vy, r = s[3], s[4], s[5]
        ls, lf = self.vehicle.half_track, self.vehicle.lf
        cd, sd = self._cos_sin_delta
        vyf = vy + r * lf
        vl, vr = vx - r * ls, vx + r * ls
        speeds = (vl * cd + vyf * sd, vr * cd + vyf * sd, vl, vr)
        rad, floor = self.chassis.wheel_radius, self.chassis.slip_speed_floor
        peak = self._kappa_peak
        out = torques
        for i in (0, 1, 2, 3):
            t = torques[i]
            u = speeds[i]
            excess = s[6 + i] * rad - u  # slip speed
            limit = peak * (u if u > floor else (-u if -u > floor else floor))
            if (t > 0.0 and excess > limit) or (t < 0.0 and excess < -limit):
                transmitted = rad * self._forces[2 + i]
                cut = min(t, transmitted) if t > 0.0 else max(t, transmitted)
                out = (*out[:i], cut, *out[i + 1:])  # type: ignore[assignment]
        return out

    def step(self, h: float, delta: float, fx_cmd: tuple[float, float, float, float]) -> None:
        """Integrate h seconds: steering delta (rad), wheel torques R * fx_cmd (N m), cut
        by the ABS / traction control of `_slip_limited`."""
        rad = self.chassis.wheel_radius
        if delta != self._delta:
            self._delta = delta
            self._cos_sin_delta = (math.cos(delta), math.sin(delta))
        self._torque = self._slip_limited(
            (rad * fx_cmd[0], rad * fx_cmd[1], rad * fx_cmd[2], rad * fx_cmd[3])
        )
        limit = self.step_factor * self.wheel_time_constant()
        if limit > self.max_step:
            limit = self.max_step
        n = max(1, math.ceil(h / limit - 1e-9))
        hi = h / n
        s = self.state
        for _ in range(n):
            s = rk4_step(self.derivative, s, hi)
        self.state = s

    def outputs(self) -> PlantOutputs:
        """Accelerations and tyre forces at the current state."""
        self.derivative(self.state)
        f = self._forces
        return PlantOutputs(
            ax=f[0], ay=f[1], fx=(f[2], f[3], f[4], f[5]), fy=(f[6], f[7], f[8], f[9]),
            fz=(f[10], f[11], f[12], f[13]),
        )

    def max_lateral_acceleration(self) -> float:
        """m/s^2, the friction limit mu g."""
        return self.mu * G

