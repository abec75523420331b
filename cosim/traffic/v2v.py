"""V2V messages: what a traffic vehicle (TV) tells the subject vehicle (SV).

Assumption S1 of the paper: every TV within range publishes its state, its
lane-change intention and, while changing lanes, its reference trajectory. The
planner's TV prediction (categories C1/C2/C3) reads only these messages.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LateralMotion:
    """A TV's lane change as it broadcasts it (category C3).

    `profile` "quintic": the paper's min-jerk lane change (eq. 2, 4) with these
    boundary values; "linear": SUMO's `--lanechange.duration` motion, constant
    lateral speed width/tau, longitudinal speed constant at vx0.
    """

    t0: float  # s, simulation time the lane change started
    tau: float  # s, its duration
    x0: float  # m, global x of the TV's centre at t0
    y0: float  # m, global y of the TV's centre at t0
    vx0: float  # m/s, longitudinal speed at t0
    vxf: float  # m/s, longitudinal speed at t0 + tau
    width: float  # m, signed lateral displacement (+ to the left)
    profile: str = "quintic"  # "quintic" | "linear"


@dataclass(frozen=True)
class V2VMessage:
    """One TV's broadcast, measured at simulation time `t`."""

    vehicle_id: str
    t: float  # s, simulation time of the measurement
    x: float  # m, global x of the vehicle's centre
    y: float  # m, global y of the vehicle's centre
    heading: float  # rad, math convention (0 along +x, counter-clockwise)
    speed: float  # m/s
    accel: float  # m/s^2, longitudinal
    lane: int  # SUMO lane index
    lateral_speed: float  # m/s, + to the left
    length: float  # m
    width: float  # m
    intention: int  # -1 wants to change right, 0 none, +1 wants to change left (blinker)
    motion: LateralMotion | None = None  # set while the TV is changing lanes (C3)
