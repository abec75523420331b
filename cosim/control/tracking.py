"""A tracking run without SUMO: one closed loop following one reference, and the
integral absolute errors of the paper's Table 2.

Table 2 gives, for "the single lane change", IAE of Vx (m/s), ye (m), phi_e
(deg), delta_f (deg) and Fx (kN). The paper does not define the integration
window or which Fx; here: the whole run (by default 10 s from the start of the
manoeuvre), |Vx - Vx*|, |ye|, |phi_e|, |delta_f| (road-wheel angle) and the sum
of the four wheels' |Fx|, each integrated over time (trapezoid on the 0.01 s
record grid), so the units carry an extra "s".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cosim.params import ControllerGains, VehicleParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.vehicle.chassis import ChassisParams
from cosim.vehicle.plant import PlantStart

from .closed_loop import ClosedLoop, LoopConfig, StepRecord

# The paper's Table 2 (IAE of the single lane change, veDYNA), for comparison only.
PAPER_TABLE2: dict[str, dict[str, float]] = {
    "mimo": {"vx": 0.187, "ye": 0.151, "phi_e_deg": 3.711, "delta_f_deg": 5.607, "fx_kn": 7.673},
    "siso": {"vx": 0.013, "ye": 0.149, "phi_e_deg": 5.119, "delta_f_deg": 2.717, "fx_kn": 6.552},
}
IAE_COLUMNS = ("vx", "ye", "phi_e_deg", "delta_f_deg", "fx_kn")


@dataclass(frozen=True)
class TrackingRun:
    """The records of one run (the first at the start time, before any step)."""

    plant: str
    controller: str
    mu: float  # -, road friction
    records: tuple[StepRecord, ...]

    def array(self, name: str) -> NDArray[np.float64]:
        """One StepRecord field over time (fx, fy, fz give (n, 4))."""
        return np.array([getattr(r, name) for r in self.records], dtype=float)

    def iae(self) -> dict[str, float]:
        """Integral absolute errors as in Table 2 (keys: IAE_COLUMNS)."""
        t = self.array("t")

        def integral(values: NDArray[np.float64]) -> float:
            return float(np.trapezoid(np.abs(values), t))

        return {
            "vx": integral(self.array("ex")),
            "ye": integral(self.array("ye")),
            "phi_e_deg": math.degrees(integral(self.array("phi_e"))),
            "delta_f_deg": math.degrees(integral(self.array("delta_f"))),
            "fx_kn": integral(np.abs(self.array("fx")).sum(axis=1)) / 1000.0,
        }


RECORD_STEP = 0.01  # s, between two records (the IAE's trapezoid grid)
SUBSTEPS = 2  # per record: 5 ms, as the co-simulation's 0.05 s step with 10 substeps


def run_tracking(
    config: LoopConfig,
    reference: LaneChangeTrajectory,
    *,
    mu: float,
    duration: float,
    vehicle: VehicleParams | None = None,
    gains: ControllerGains | None = None,
    chassis: ChassisParams | None = None,
) -> TrackingRun:
    """Start on the reference at its t0 (position, heading, speed) and follow it for
    `duration` seconds with the plant and law of `config`, recorded every RECORD_STEP
    in SUBSTEPS substeps."""
    vehicle = vehicle or VehicleParams()
    gains = gains or ControllerGains()
    t0 = reference.t0
    heading = float(reference.heading(t0))
    x0, y0 = (float(v) for v in reference.position(t0))
    loop = ClosedLoop(config, vehicle, gains, mu,
                      PlantStart(x0, y0, heading, float(reference.speed(t0))), chassis=chassis)
    loop.set_reference(reference, reset=True)
    records = [loop.record(t0)]
    n = int(round(duration / RECORD_STEP))
    for k in range(n):
        records.append(loop.advance(t0 + k * RECORD_STEP, RECORD_STEP, SUBSTEPS, reference))
    return TrackingRun(config.plant, config.controller, mu, tuple(records))
