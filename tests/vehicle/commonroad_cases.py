"""Our two-track plant against CommonRoad's multi-body (MB) and single-track (ST) models
(PyPI commonroad-vehicle-models, module vehiclemodels; a test-only dependency) on its
vehicle2 (BMW 320i), at 80 km/h: steady small-steer yaw gain, a step steer, and braking
in a turn on mu 1.0 and 0.4.

Set-up "as MB is": our plant takes CommonRoad's car (`commonroad_vehicle`: Cf, Cr =
|p_ky1| x axle load = 21.92 x axle load) and chassis (`commonroad_chassis`: CG height,
wheels, the lateral load-transfer split of MB's roll stiffnesses, its load transfers (the
body rolling on springs and tyres: 1.161 x the rigid car's laterally; MB's pitch lever:
1.038 x longitudinally), CommonRoad's tyre with its MF coefficients and no load
sensitivity), the wheel torques MB makes of its
acceleration input (brakes 66 % front, drive on the rear axle) and small relaxation
lengths (MB has none). Our anti-lock logic stays on unless asked (it is part of our
plant; MB has none, and its inner wheels lock when braking in a turn). Road friction mu
scales the tyres' D (MB: p_dx1, p_dy1 times mu; ours: mu_y = mu p_dy1). Both models get
the same steering angle (MB's steering-rate input, 0.4 rad/s at most, makes ramps) and
the same speed-holding law u = 2 (v0 - vx) m/s^2 before braking.

`python tests/vehicle/commonroad_cases.py` prints the comparison table of
docs/control_results.md.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from cosim.params import COMMONROAD_CARS, COMMONROAD_TYRE, G, commonroad_vehicle
from cosim.vehicle.chassis import ChassisParams, commonroad_chassis
from cosim.vehicle.plant import PlantStart
from cosim.vehicle.twotrack import TwoTrackPlant

V0 = 80.0 / 3.6  # m/s
DT = 0.005  # s, our substep and the comparison grid
CAR = COMMONROAD_CARS["vehicle2"]
STEER_RATE = 0.4  # rad/s, MB's steering-rate limit (parameters_vehicle2 steering.v_max)
HOLD_GAIN = 2.0  # 1/s, speed-holding law u = HOLD_GAIN (v0 - vx) before braking


@dataclass(frozen=True)
class Manoeuvre:
    """Steer to `delta` (ramp at STEER_RATE) at t = 0, hold speed until `brake_at`, then
    brake at `decel` (m/s^2) until `end` with the wheel held."""

    name: str
    mu: float
    delta: float  # rad
    end: float  # s
    brake_at: float | None = None  # s
    decel: float = 0.0  # m/s^2, > 0


def neutral_steer(ay: float, speed: float = V0) -> float:
    """rad, the steering angle of ay (m/s^2) at speed for a neutral-steer car (vehicle2
    is: Cf lf = Cr lr): L ay / V^2."""
    return (CAR.a + CAR.b) * ay / speed**2


def manoeuvres() -> list[Manoeuvre]:
    """The cases of the comparison."""
    cases = [
        Manoeuvre("steady yaw gain, 0.01 rad", 1.0, 0.01, 6.0),
        Manoeuvre("step steer to 1.5 m/s^2", 1.0, neutral_steer(1.5), 3.0),
    ]
    for mu in (1.0, 0.4):
        cases.append(Manoeuvre(f"braking in a turn, mu {mu:g}", mu,
                               neutral_steer(0.5 * mu * G), 5.0, brake_at=3.0,
                               decel=0.5 * mu * G))
    return cases


def accel_input(m: Manoeuvre, t: float, vx: float) -> float:
    """m/s^2, MB's acceleration input (and what our wheel torques make of it)."""
    if m.brake_at is not None and t >= m.brake_at:
        return -m.decel
    return HOLD_GAIN * (V0 - vx)


def steer_at(m: Manoeuvre, t: float) -> float:
    """rad, the steering angle both models have at t (a ramp at STEER_RATE)."""
    return math.copysign(min(abs(m.delta), STEER_RATE * t), m.delta)


def wheel_forces(u: float, mass: float) -> tuple[float, float, float, float]:
    """N, our four wheel force demands for MB's acceleration input u: MB turns u into a
    brake torque m R u split 66 / 34 front / rear (T_sb) or a drive torque on the rear
    axle (T_se = 0), half per wheel."""
    total = mass * u
    if u < 0.0:
        front, rear = CAR.T_sb * total / 2.0, (1.0 - CAR.T_sb) * total / 2.0
    else:
        front, rear = CAR.T_se * total / 2.0, (1.0 - CAR.T_se) * total / 2.0
    return front, front, rear, rear


def our_chassis(roll_share: float | None = None, anti_lock: bool = True,
                relaxation: tuple[float, float] = (0.05, 0.02)) -> ChassisParams:
    """Our chassis set up as MB is (see the module docstring)."""
    base = commonroad_chassis(CAR)
    tyre = dataclasses.replace(base.tyre, relaxation_lat=relaxation[0],
                               relaxation_long=relaxation[1])
    return dataclasses.replace(
        base, tyre=tyre, anti_lock=anti_lock,
        roll_share_front=base.roll_share_front if roll_share is None else roll_share)


def run_ours(m: Manoeuvre, chassis: ChassisParams | None = None) -> np.ndarray:
    """(t, yaw rate, vx, vy) on the DT grid, our two-track plant."""
    vehicle = commonroad_vehicle(CAR)
    plant = TwoTrackPlant(vehicle, m.mu * COMMONROAD_TYRE["p_dy1"], PlantStart(vx=V0),
                          chassis=chassis or our_chassis())
    n = int(round(m.end / DT))
    out = np.empty((n + 1, 4))
    out[0] = (0.0, plant.state[5], plant.state[3], plant.state[4])
    for k in range(n):
        t = k * DT
        u = accel_input(m, t, plant.state[3])
        plant.step(DT, steer_at(m, t + DT), wheel_forces(u, vehicle.mass))
        out[k + 1] = (t + DT, plant.state[5], plant.state[3], plant.state[4])
    return out


def _params(mu: float):  # noqa: ANN202 (vehiclemodels' own parameter class)
    from vehiclemodels.parameters_vehicle2 import parameters_vehicle2

    p = parameters_vehicle2()
    p.tire = copy.copy(p.tire)
    p.tire.p_dx1 *= mu
    p.tire.p_dy1 *= mu
    return p


def our_peak_slip(mu: float) -> float:
    """-, the longitudinal slip at which our anti-lock logic cuts a wheel's torque."""
    from cosim.vehicle.twotrack import C_PEAK

    plant = TwoTrackPlant(commonroad_vehicle(CAR), mu * COMMONROAD_TYRE["p_dy1"],
                          PlantStart(vx=V0), chassis=our_chassis())
    return float(plant._const[C_PEAK])


ANTI_LOCK_BAND = 0.05  # -, slip over which the surrogate fades a wheel's brake torque out


def run_mb(m: Manoeuvre, anti_lock: bool = False) -> np.ndarray:
    """(t, yaw rate, vx, vy) on the DT grid, CommonRoad's multi-body model (LSODA).

    MB has no anti-lock logic: its brake torque is m R_w u split T_sb / (1 - T_sb),
    whatever the wheel does, so a lightly loaded wheel locks. `anti_lock`: a surrogate of
    ours added outside MB, for the comparison only: a braked wheel's torque fades out
    linearly as its slip (MB's own definition) goes from our anti-lock's peak slip to
    ANTI_LOCK_BAND beyond it (smooth, so that LSODA can integrate it). Note MB's wheel
    labels: its "L" wheels are at y = -T/2 (u_w_lf = (vx + T_f r / 2) ...)."""
    from vehiclemodels.init_mb import init_mb
    from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb

    p = _params(m.mu)
    ramp = abs(m.delta) / STEER_RATE
    peak = our_peak_slip(m.mu) if anti_lock else math.inf
    shares = (p.T_sb / 2.0, p.T_sb / 2.0, (1.0 - p.T_sb) / 2.0, (1.0 - p.T_sb) / 2.0)

    def f(t: float, x: np.ndarray) -> list[float]:
        rate = math.copysign(STEER_RATE, m.delta) if t < ramp else 0.0
        u = accel_input(m, t, x[3])
        d = vehicle_dynamics_mb(list(x), [rate, u], p)
        if u < 0.0 and math.isfinite(peak):
            vx, r, vy, steer = x[3], x[5], x[10], x[2]
            front = (vy + p.a * r) * math.sin(steer)
            speeds = ((vx + 0.5 * p.T_f * r) * math.cos(steer) + front,
                      (vx - 0.5 * p.T_f * r) * math.cos(steer) + front,
                      vx + 0.5 * p.T_r * r, vx - 0.5 * p.T_r * r)
            for i, (uw, share) in enumerate(zip(speeds, shares, strict=True)):
                if uw > 0.1:
                    slip = 1.0 - p.R_w * x[23 + i] / uw
                    kept = min(max((peak + ANTI_LOCK_BAND - slip) / ANTI_LOCK_BAND, 0.0), 1.0)
                    d[23 + i] -= (1.0 - kept) * share * p.m * p.R_w * u / p.I_y_w
        return d

    x0 = init_mb([0.0, 0.0, 0.0, V0, 0.0, 0.0, 0.0], p)
    return _integrate(f, x0, m, ramp, yaw=5, vx=3, vy=10)


def run_st(m: Manoeuvre) -> np.ndarray:
    """(t, yaw rate, vx, vy) on the DT grid, CommonRoad's single-track model (linear tyres
    with mu p_dy1 C_S = |p_ky1|, load transfer from the acceleration input)."""
    from vehiclemodels.init_st import init_st
    from vehiclemodels.vehicle_dynamics_st import vehicle_dynamics_st

    p = _params(m.mu)
    ramp = abs(m.delta) / STEER_RATE

    def f(t: float, x: np.ndarray) -> list[float]:
        rate = math.copysign(STEER_RATE, m.delta) if t < ramp else 0.0
        vx = x[3] * math.cos(x[6])
        return vehicle_dynamics_st(list(x), [rate, accel_input(m, t, vx)], p)

    x0 = init_st([0.0, 0.0, 0.0, V0, 0.0, 0.0, 0.0])
    out = _integrate(f, x0, m, ramp, yaw=5, vx=3, vy=6)
    speed, beta = out[:, 2].copy(), out[:, 3].copy()  # ST's states: speed, side slip
    out[:, 2], out[:, 3] = speed * np.cos(beta), speed * np.sin(beta)
    return out


def _integrate(f, x0: list[float], m: Manoeuvre, ramp: float, *, yaw: int, vx: int,
               vy: int) -> np.ndarray:  # noqa: ANN001
    """Integrate in pieces between the input's jumps (end of the steering ramp, start of
    braking) and sample on the DT grid."""
    n = int(round(m.end / DT))
    grid = np.arange(n + 1) * DT
    cuts = sorted({0.0, m.end, min(ramp, m.end), *([m.brake_at] if m.brake_at else [])})
    out = np.empty((n + 1, 4))
    out[:, 0] = grid
    x = np.asarray(x0, dtype=float)
    for a, b in zip(cuts[:-1], cuts[1:], strict=True):
        if b <= a:
            continue
        idx = np.flatnonzero((grid >= a - 1e-12) & (grid <= b + 1e-12))
        inside = np.clip(grid[idx], a, b)
        t_eval = np.unique(np.append(inside, b))  # b: where the next piece starts
        sol = solve_ivp(f, (a, b), x, method="LSODA", t_eval=t_eval, rtol=1e-5, atol=1e-7)
        pos = np.searchsorted(t_eval, inside)
        out[idx, 1], out[idx, 2], out[idx, 3] = sol.y[yaw, pos], sol.y[vx, pos], sol.y[vy, pos]
        x = sol.y[:, -1]
    return out


def side_slip_deg(a: np.ndarray) -> np.ndarray:
    """deg, the side slip angle atan(vy / vx) of a run's rows."""
    return np.degrees(np.arctan2(a[:, 3], a[:, 2]))


def mb_steady_transfer(mu: float = 1.0, ay: float = 0.5 * G, end: float = 3.0
                       ) -> tuple[float, float, float]:
    """(front, rear in N, ay in m/s^2): the lateral load transfer (F_z outer - inner per
    axle) of MB in a steady turn at 80 km/h, speed held, with the steering of `ay` for a
    neutral-steer car, and the lateral acceleration it reaches; the tyre loads as
    vehicle_dynamics_mb computes them."""
    from vehiclemodels.init_mb import init_mb
    from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb

    p = _params(mu)
    delta = neutral_steer(ay)
    ramp = delta / STEER_RATE

    def f(t: float, x: np.ndarray) -> list[float]:
        rate = STEER_RATE if t < ramp else 0.0
        return vehicle_dynamics_mb(list(x), [rate, HOLD_GAIN * (V0 - x[3])], p)

    x = np.asarray(init_mb([0.0, 0.0, 0.0, V0, 0.0, 0.0, 0.0], p), dtype=float)
    for a, b in ((0.0, ramp), (ramp, end)):
        x = solve_ivp(f, (a, b), x, method="LSODA", rtol=1e-7, atol=1e-9).y[:, -1]

    def load(z: float, roll: float, track: float, side: float) -> float:  # MB's F_z
        return (z + p.R_w * (math.cos(roll) - 1.0) + side * 0.5 * track * math.sin(roll)) \
            * p.K_zt

    front = load(x[16], x[13], p.T_f, -1.0) - load(x[16], x[13], p.T_f, 1.0)
    rear = load(x[21], x[18], p.T_r, -1.0) - load(x[21], x[18], p.T_r, 1.0)
    lateral = x[5] * x[3] + f(end, x)[10]  # r vx + dvy/dt
    return front, rear, lateral


def mb_steady_roll_share(mu: float = 1.0) -> float:
    """-, the front share of MB's lateral load transfer in a steady 0.5 mu g turn."""
    front, rear, _ = mb_steady_transfer(mu, 0.5 * mu * G)
    return front / (front + rear)


def ours_steady_transfer(chassis: ChassisParams | None = None, ay: float = 0.5 * G,
                         end: float = 3.0) -> tuple[float, float]:
    """(N, m/s^2): our plant's lateral load transfer (F_z outer - inner, both axles) in
    the steady turn of `mb_steady_transfer`, and its lateral acceleration."""
    vehicle = commonroad_vehicle(CAR)
    plant = TwoTrackPlant(vehicle, COMMONROAD_TYRE["p_dy1"], PlantStart(vx=V0),
                          chassis=chassis or our_chassis())
    m = Manoeuvre("steady", 1.0, neutral_steer(ay), end)
    for k in range(int(round(end / DT))):
        u = accel_input(m, k * DT, plant.state[3])
        plant.step(DT, steer_at(m, (k + 1) * DT), wheel_forces(u, vehicle.mass))
    out = plant.outputs()
    return (out.fz[1] - out.fz[0]) + (out.fz[3] - out.fz[2]), out.ay  # right wheels outer


def mb_pitch_height(decel: float = 2.0, end: float = 3.0) -> float:
    """m, MB's steady longitudinal load transfer braking straight at `decel`, as the
    height h of m ax h / L: (front axle load - its static) L / (m |ax|)."""
    from vehiclemodels.init_mb import init_mb
    from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb

    p = _params(1.0)

    def f(t: float, x: np.ndarray) -> list[float]:
        return vehicle_dynamics_mb(list(x), [0.0, -decel], p)

    x0 = np.asarray(init_mb([0.0, 0.0, 0.0, V0, 0.0, 0.0, 0.0], p), dtype=float)
    x = solve_ivp(f, (0.0, end), x0, method="LSODA", rtol=1e-8, atol=1e-10).y[:, -1]
    ax = f(end, x)[3]
    front = 2.0 * (x[16] + p.R_w * (math.cos(x[13]) - 1.0)) * p.K_zt
    return (front - 2.0 * x0[16] * p.K_zt) * (p.a + p.b) / (-ax * p.m)


def rms(a: np.ndarray, b: np.ndarray, start: float = 0.0) -> float:
    """rad/s, RMS of the yaw-rate difference from `start` on."""
    keep = a[:, 0] >= start - 1e-12
    return float(np.sqrt(np.mean((a[keep, 1] - b[keep, 1]) ** 2)))


def table() -> str:
    """The comparison (docs/control_results.md): per manoeuvre, yaw rate at the end of
    the steering ramp + 2 s (or of the run), and yaw-rate RMS differences against MB."""
    rows = ["| manoeuvre | r MB (rad/s) | r ours | r ST | RMS ours - MB | RMS ST - MB |",
            "|---|---|---|---|---|---|"]
    for m in manoeuvres():
        mb, ours, st = run_mb(m), run_ours(m), run_st(m)
        k = -1
        rows.append(f"| {m.name} | {mb[k, 1]:.4f} | {ours[k, 1]:.4f} | {st[k, 1]:.4f} | "
                    f"{rms(ours, mb):.4f} | {rms(st, mb):.4f} |")
    return "\n".join(rows)


if __name__ == "__main__":
    print(table())
