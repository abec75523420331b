"""Tests of cosim.control.loop_batch: many closed loops in one compiled call give, bit
for bit, what one ClosedLoop.advance per vehicle gives, on both plants, on a curved
frame, with loops joining, leaving and changing reference between steps."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.control.closed_loop import ClosedLoop, LoopConfig
from cosim.control.loop_batch import LoopBatch
from cosim.errors import SimulationError
from cosim.params import ControllerGains, VehicleParams
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.vehicle.plant import PlantStart

sys.path.insert(0, str(Path(__file__).parent))
from arcs import arc_frame  # noqa: E402

VEHICLE = VehicleParams()
GAINS = ControllerGains()
FIELDS = ("t", "x", "y", "heading", "vx", "vy", "yaw_rate", "ax", "ay", "x_ref", "y_ref",
          "vx_ref", "kappa_ref", "ye", "phi_e", "ex", "along", "delta_f", "dmz", "fa", "fx",
          "saturated")


def _ref(rng: np.random.Generator, t0: float, x0: float, y0: float, v: float
         ) -> LaneChangeTrajectory:
    return LaneChangeTrajectory(t0=t0, tau=float(rng.uniform(3.0, 6.0)), x0=x0, y0=y0,
                                vx0=v, vxf=float(v + rng.uniform(-3.0, 3.0)),
                                width=float(rng.choice([-3.75, 0.0, 3.75])))


@pytest.mark.parametrize("plant", ["twotrack", "bicycle"])
def test_a_batch_steps_each_loop_as_its_own_advance(plant: str) -> None:
    rng = np.random.default_rng(7)
    frame = arc_frame(400.0, 400.0, straight=100.0)
    n = 6

    def loops() -> list[ClosedLoop]:
        out = []
        for i in range(n):
            v = 20.0 + 2.0 * i
            start = PlantStart(20.0 * i, 0.3 * (i % 3 - 1), 0.01 * (i - 2), v)
            out.append(ClosedLoop(LoopConfig(plant, "mimo"), VEHICLE, GAINS, 0.6, start,
                                  frame=frame))
        return out

    alone, batched = loops(), loops()
    refs = [_ref(rng, 0.0, 20.0 * i, 0.0, 20.0 + 2.0 * i) for i in range(n)]
    batch = LoopBatch(2)  # grows while they join: the rows move, the loops follow
    for loop, ref in zip(batched, refs, strict=True):
        loop.set_reference(ref)
        batch.add(loop)
    dt, left = 0.05, []
    for k in range(60):
        t = k * dt
        if k % 20 == 10:  # new references for some, between steps
            for i in rng.choice(n, 3, replace=False).tolist():
                s, d, _ = alone[i].road_pose
                refs[i] = _ref(rng, t, s, round(d / 3.75) * 3.75, max(alone[i].plant.state[3], 5.0))
        if k == 30:  # one leaves the batch; it steps on by itself
            batch.remove(batched[2])
            left.append(2)
        steps = [(batched[i], refs[i]) for i in range(n) if i not in left]
        got = dict(zip([i for i in range(n) if i not in left],
                       batch.advance(t, dt, 10, steps), strict=True))
        for i in range(n):
            want = alone[i].advance(t, dt, 10, refs[i])
            if i in left:
                rec = batched[i].advance(t, dt, 10, refs[i])
                assert dataclasses.astuple(rec) == dataclasses.astuple(want)
                continue
            assert tuple(getattr(got[i], f) for f in FIELDS) == \
                tuple(getattr(want, f) for f in FIELDS), (k, i)
            assert batched[i].road_pose == alone[i].road_pose
            assert np.array_equal(batched[i].plant.state, alone[i].plant.state)


def test_a_batch_names_the_vehicle_whose_step_fails() -> None:
    batch = LoopBatch()
    ref = LaneChangeTrajectory(t0=0.0, tau=2.0, x0=0.0, y0=0.0, vx0=20.0, vxf=20.0,
                               width=0.0)
    loops = [ClosedLoop(LoopConfig("bicycle"), VEHICLE, GAINS, 0.8, PlantStart(vx=20.0))
             for _ in range(2)]
    for loop in loops:
        loop.set_reference(ref)
        batch.add(loop)
    loops[1].plant.state[4] = np.nan
    with pytest.raises(SimulationError, match="non-finite"):
        batch.advance(0.0, 0.05, 10, [(loop, ref) for loop in loops])
