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

Guards: the controller divides by max(vx, speed_floor); the yaw moment is
limited to what the wheels can give without eating the lateral grip the
planner counts on (`yaw_moment_share`, below); an integrator stops while its
actuator saturates in the direction its error pushes (conditional integration,
anti-windup); a non-finite plant state or control output raises
`SimulationError` naming the state. The two-track plant itself has ABS /
traction control (`TwoTrackPlant._slip_limited`).

Yaw-moment limit (beyond the paper): the MIMO law asks for the yaw moment that
keeps the heading on the path tangent (zero sideslip). For the oversteering
Table 1 car this grows with lateral acceleration as KL (L lr Cr - lf M Vx^2)
(about 2 kN m at 1.8 m/s^2 and 80 km/h), made by differential wheel forces;
on mu = 0.4 those forces plus the cornering forces overrun the inner wheels'
friction circles (the allocation, eq. 30, ignores wheel loads): on the
two-track car the yaw loop ends in a growing oscillation (3 m off the path at
tau = 3.5 s, a spin at 2.78 s). So |dMz| is limited to
share * mu * M * g * ls: every wheel's differential force then stays below
`share` of its static friction limit; with the planner's lateral use of
f = 0.8, sqrt(0.2^2 + 0.8^2) = 0.82 leaves room for the load the inner wheels
lose in the turn. The share trades path for heading: on mu = 0.4 at case 5.1
speeds and tau = 2.78 s, shares 0.1 / 0.2 / 0.3 give a largest |ye| of
0.03 / 0.08 / 0.12 m and a phi_e IAE of 1.01 / 0.75 / 0.69 deg s (SISO: 0.025 m,
1.26 deg s); the default 0.2 sits between. None: no limit, the paper's law as
printed. The steering law does not use dMz (B's
first row), so while the limit is active ye is still regulated and only phi_e
is left to the zero dynamics, as in the SISO baseline.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from cosim.errors import InputError, SimulationError
from cosim.params import ControllerGains, G, VehicleParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.vehicle.actuators import ActuatorLimits
from cosim.vehicle.bicycle import BicyclePlant
from cosim.vehicle.chassis import ChassisParams
from cosim.vehicle.plant import Plant, check_finite
from cosim.vehicle.twotrack import TwoTrackPlant

from .allocation import allocate
from .longitudinal import longitudinal_force
from .reference import PathErrors, ReferencePath
from .triple_step import check_gains, mimo_law, siso_law

PLANTS = ("twotrack", "bicycle")
YAW_MOMENT_SHARE = 0.2  # -, default friction share of the yaw-moment limit (see above)
CONTROLLERS = ("mimo", "siso")


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


class ClosedLoop:
    """One subject vehicle: plant, controller and actuators."""

    def __init__(
        self,
        plant: str,
        controller: str,
        vehicle: VehicleParams,
        gains: ControllerGains,
        mu: float,
        x: float,
        y: float,
        heading: float,
        speed: float,
        *,
        chassis: ChassisParams | None = None,
        limits: ActuatorLimits | None = None,
        control_every: int = 1,
        speed_floor: float = 1.0,  # m/s, the control laws never divide by less
        yaw_moment_share: float | None = YAW_MOMENT_SHARE,  # -, friction share of dMz (None: off)
    ) -> None:
        if plant not in PLANTS:
            raise InputError("closed loop", "plant", plant, f"one of {', '.join(PLANTS)}")
        if controller not in CONTROLLERS:
            raise InputError(
                "closed loop", "controller", controller, f"one of {', '.join(CONTROLLERS)}"
            )
        if control_every < 1:
            raise InputError("closed loop", "control_every", control_every, "an integer >= 1")
        if not 0.0 < mu <= 1.5:
            raise InputError("closed loop", "mu", mu, "road friction in (0, 1.5]")
        if not speed_floor > 0.0:
            raise InputError("closed loop", "speed_floor", speed_floor, "> 0 m/s")
        check_gains(gains)
        self.limits = limits or ActuatorLimits()
        self.limits.check()
        self.vehicle = vehicle
        self.gains = gains
        self.controller = controller
        self.control_every = control_every
        self.speed_floor = speed_floor
        if yaw_moment_share is not None and not yaw_moment_share > 0.0:
            raise InputError("closed loop", "yaw_moment_share", yaw_moment_share,
                             "> 0, or None for no limit")
        self.dmz_limit = (
            math.inf if yaw_moment_share is None
            else yaw_moment_share * mu * vehicle.mass * G * vehicle.half_track
        )
        ch = chassis or ChassisParams()
        self.plant: Plant
        if plant == "twotrack":
            self.plant = TwoTrackPlant(vehicle, mu, x, y, heading, speed, chassis=ch)
        else:
            self.plant = BicyclePlant(vehicle, x, y, heading, speed)
        # both plants get the force the same motors could deliver through wheels of radius R
        self._force_bounds = self.limits.wheel_force_bounds(ch.wheel_radius)
        self._path: ReferencePath | None = None
        self._s = 0.0  # last projection (path parameter, s)
        self._int_ye = 0.0  # m s
        self._int_phi = 0.0  # rad s
        self._delta = 0.0  # rad, applied road-wheel angle
        self._dmz = 0.0
        self._fa = 0.0
        self._fx: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self._saturated = False
        self._counter = 0

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
        self._s, _ = self._path.project(s[0], s[1], reference.t0)
        if reset:
            self.reset_integrators()

    def reset_integrators(self) -> None:
        """Zero int(ye) and int(phi_e) (eq. 24)."""
        self._int_ye = 0.0
        self._int_phi = 0.0

    # -- stepping ---------------------------------------------------------------
    def errors(self, t: float) -> PathErrors:
        """Path errors of the current plant state at time t (the reference must be set)."""
        assert self._path is not None
        x, y, psi, vx, vy, r = self.plant.state[:6]
        e = self._path.errors(t, x, y, psi, vx, vy, r, self._s)
        self._s = e.s
        return e

    def _control(self, t: float, h_ctrl: float) -> None:
        """Sample the state, compute and limit the inputs (held until the next call)."""
        e = self.errors(t)
        vx = max(self.plant.state[3], self.speed_floor)
        v, g = self.vehicle, self.gains
        if self.controller == "mimo":
            delta_cmd, dmz = mimo_law(
                v, g, vx, e.kappa, e.ye, e.phi_e, e.ye_dot, e.phi_e_dot,
                self._int_ye, self._int_phi,
            )
        else:
            delta_cmd = siso_law(
                v, g, vx, e.kappa, e.ye, e.phi_e, e.ye_dot, e.phi_e_dot, self._int_ye
            )
            dmz = 0.0
        fa = longitudinal_force(v, g, self.plant.state[3], e.vx_ref, e.ax_ref)
        if not (math.isfinite(delta_cmd) and math.isfinite(dmz) and math.isfinite(fa)):
            state = ", ".join(
                f"{n} = {val:.6g}" for n, val in zip(
                    self.plant.state_names, self.plant.state, strict=True)
            )
            raise SimulationError(
                t, f"non-finite control output: delta_f = {delta_cmd}, dMz = {dmz}, Fa = {fa} "
                f"(ye = {e.ye:.4g}, phi_e = {e.phi_e:.4g})", state,
            )
        delta = self.limits.steer(self._delta, delta_cmd, h_ctrl)
        steer_sat = abs(delta_cmd) > self.limits.max_steer
        yaw_sat = abs(dmz) > self.dmz_limit
        dmz_cmd = dmz
        if yaw_sat:
            dmz = math.copysign(self.dmz_limit, dmz)
        fx = allocate(v, delta, dmz, fa, g.allocation_eps)
        lo, hi = self._force_bounds
        f1, f2, f3, f4 = fx
        force_sat = not (lo <= min(f1, f2, f3, f4) and max(f1, f2, f3, f4) <= hi)
        if force_sat:
            fx = (min(max(f1, lo), hi), min(max(f2, lo), hi),
                  min(max(f3, lo), hi), min(max(f4, lo), hi))
        self._saturated = steer_sat or yaw_sat or force_sat
        # conditional integration (anti-windup): an integrator stops only while its
        # actuator is saturated AND the error would push it further in. int(ye) acts
        # through the steering (on delta_f with the sign of -ye), int(phi_e) through
        # the wheel forces (on dMz with the sign of -phi_e). Freezing regardless can
        # hold a saturated demand for ever.
        if not (steer_sat and e.ye * delta_cmd < 0.0):
            self._int_ye += e.ye * h_ctrl
        if not ((yaw_sat or force_sat) and e.phi_e * dmz_cmd < 0.0):
            self._int_phi += e.phi_e * h_ctrl
        self._delta, self._dmz, self._fa = delta, dmz, fa
        self._fx = fx

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
        h = dt / substeps
        plant = self.plant
        saturated = False
        for k in range(substeps):
            tk = t + k * h
            if self._counter % self.control_every == 0:
                self._control(tk, h * self.control_every)
                saturated = saturated or self._saturated
            self._counter += 1
            plant.step(h, self._delta, self._fx)
            check_finite(tk + h, plant.state_names, plant.state)
        return self.record(t + dt, saturated)

    def record(self, t: float, saturated: bool = False) -> StepRecord:
        """The closed loop's state at time t (no control update)."""
        e = self.errors(t)
        out = self.plant.outputs()
        x, y, psi, vx, vy, r = self.plant.state[:6]
        return StepRecord(
            t=t, x=x, y=y, heading=psi, vx=vx, vy=vy, yaw_rate=r, ax=out.ax, ay=out.ay,
            x_ref=e.x_ref, y_ref=e.y_ref, vx_ref=e.vx_ref, kappa_ref=e.kappa,
            ye=e.ye, phi_e=e.phi_e, ex=vx - e.vx_ref, along=e.along,
            delta_f=self._delta, dmz=self._dmz, fa=self._fa, fx=out.fx, fy=out.fy, fz=out.fz,
            saturated=saturated,
        )
