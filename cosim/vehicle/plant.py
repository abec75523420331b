"""What the closed loop needs from a plant, and what a plant reports."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Protocol

from cosim.compiled import Array
from cosim.errors import SimulationError


@dataclass(frozen=True)
class PlantStart:
    """A plant's state at the start: the CG's pose (global frame) and body velocities."""

    x: float = 0.0  # m, CG global x
    y: float = 0.0  # m, CG global y
    heading: float = 0.0  # rad, math convention
    vx: float = 20.0  # m/s, body longitudinal speed
    vy: float = 0.0  # m/s, body lateral speed
    yaw_rate: float = 0.0  # rad/s


class PlantOutputs(NamedTuple):
    """Accelerations and tyre forces at one state (body frame, wheels FL, FR, RL, RR).

    A named tuple, not a dataclass: the closed loop builds one per record (200 per
    simulated second), and a frozen dataclass costs 1.7 us to build, a tuple 0.3 us."""

    ax: float  # m/s^2, body longitudinal acceleration of the CG
    ay: float  # m/s^2, body lateral acceleration of the CG
    fx: tuple[float, float, float, float]  # N, wheel longitudinal forces (wheel frame)
    fy: tuple[float, float, float, float] | None  # N, wheel lateral forces (2-DOF: axle / 2)
    fz: tuple[float, float, float, float] | None  # N, wheel vertical loads (None: not modelled)


class Plant(Protocol):
    """A vehicle model stepped with held inputs.

    `state[:6]` is always (x, y, heading, vx, vy, yaw_rate): CG position (m),
    heading (rad, math convention), body velocities (m/s) and yaw rate (rad/s).
    The state is a float64 array, integrated in place by compiled code; `_const`
    and `_inputs` are the arrays the closed loop's compiled substep loop passes on.
    """

    kind: str
    state_names: tuple[str, ...]
    state: Array
    _const: Array
    _inputs: Array

    def step(self, h: float, delta: float, fx_cmd: tuple[float, float, float, float]) -> None:
        """Integrate h seconds with road-wheel angle delta (rad) and wheel force demands (N)."""
        ...

    def outputs(self) -> PlantOutputs:
        """Accelerations and wheel forces at the current state with the last inputs."""
        ...


def check_finite(t: float, names: tuple[str, ...], state: list[float] | Array) -> None:
    """Raise SimulationError naming every non-finite state (NaN never propagates silently)."""
    if math.isfinite(sum(state)):  # any NaN or inf makes the sum non-finite
        return
    bad = ", ".join(f"{n} = {v}" for n, v in zip(names, state, strict=True) if not math.isfinite(v))
    shown = ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, state, strict=True))
    raise SimulationError(t, f"non-finite plant state: {bad}", shown)
