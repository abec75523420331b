"""Many closed loops advanced in one compiled call: the fleet's automated vehicles.

Each vehicle's closed loop (`cosim.control.closed_loop.ClosedLoop`) keeps its arrays
(plant state, plant constants and inputs, tyre-force scratch, law and controller
constants, the controller's state, the reference's coefficients) as one row each of
the batch's matrices (structure of arrays): the loop's own names are views of its
rows, so everything that reads a loop reads the batch. `LoopBatch.advance` runs
`advance_core` (the closed loop's substeps) for every row in one call of
`advance_batch`, then what `ClosedLoop.record` reads (the path errors at the step's
end, the plant's accelerations and wheel forces) into the row's outputs: the same
compiled functions on the same numbers as one `ClosedLoop.advance` per vehicle, so
the trajectories are the same to the last bit.

All loops of a batch share the plant kind, the control period, the road frame and
the substeps (a fleet's vehicles drive the scenario's driver on the route's frame).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from cosim.compiled import Array, register_warm_up

from .batch_step import (
    O_ALONG,
    O_AX,
    O_AY,
    O_D,
    O_DELTA,
    O_DMZ,
    O_EX,
    O_FA,
    O_FX,
    O_KAPPA,
    O_PHIE,
    O_PSI,
    O_R,
    O_REL,
    O_S,
    O_SAT,
    O_STATUS,
    O_VX,
    O_VXREF,
    O_VY,
    O_X,
    O_XREF,
    O_Y,
    O_YE,
    O_YREF,
    OUT_SIZE,
    advance_batch,
)
from .closed_loop import ClosedLoop


class BatchRecord(NamedTuple):
    """A vehicle's closed loop at the end of a step (the fields of StepRecord its ego
    reads; SI units, radians, body frame)."""

    t: float
    x: float
    y: float
    heading: float
    vx: float
    vy: float
    yaw_rate: float
    ax: float
    ay: float
    x_ref: float
    y_ref: float
    vx_ref: float
    kappa_ref: float
    ye: float
    phi_e: float
    ex: float
    along: float
    delta_f: float
    dmz: float
    fa: float
    fx: tuple[float, float, float, float]
    saturated: bool


class LoopBatch:
    """The closed loops of many vehicles as rows of one set of arrays (module
    docstring). A loop in a batch is advanced only by the batch."""

    def __init__(self, capacity: int = 8) -> None:
        self.capacity = 0
        self.loops: dict[int, ClosedLoop] = {}  # row -> its loop
        self.paths: dict[int, Any] = {}  # row -> the ReferencePath its coef row holds
        self.free: list[int] = []
        self.kind = -1  # the plant kind of every loop (set by the first)
        self.fp: Array | None = None  # the frame's packed arrays (ClosedLoop's _fp, _fr)
        self.fr: Array | None = None
        self.frame: Any = None
        self.control_every = 1
        self._capacity = capacity
        self.arrays: dict[str, Array] = {}

    @staticmethod
    def _views(loop: ClosedLoop) -> dict[str, Array]:
        plant = loop.plant
        assert loop._path is not None, "a loop joins a batch with its reference set"
        return {"s": plant.state, "pconst": plant._const, "pinputs": plant._inputs,
                "pforces": loop._pforces, "coef": loop._path.coef, "lp": loop._lp,
                "cp": loop._cp, "ff": loop._ff, "cs": loop._cs}

    @staticmethod
    def _bind(loop: ClosedLoop, rows: dict[str, Array]) -> None:
        plant = loop.plant
        plant.state, plant._const, plant._inputs = rows["s"], rows["pconst"], rows["pinputs"]
        if hasattr(plant, "_forces"):
            plant._forces = rows["pforces"]
        loop._pforces, loop._lp, loop._cp = rows["pforces"], rows["lp"], rows["cp"]
        loop._ff, loop._cs = rows["ff"], rows["cs"]
        assert loop._path is not None
        loop._path.coef = rows["coef"]

    def _grow(self, views: dict[str, Array]) -> None:
        old, n = self.arrays, self.capacity
        size = max(self._capacity, 2 * n)
        self.arrays = {name: np.zeros((size, a.size)) for name, a in views.items()}
        self.arrays["counters"] = np.zeros(size, dtype=np.int64)
        self.arrays["out"] = np.zeros((size, OUT_SIZE))
        for name, a in old.items():
            self.arrays[name][:n] = a
        self.free += list(range(size - 1, n - 1, -1))
        self.capacity = size
        for row, loop in self.loops.items():
            self._bind(loop, self._rows(row))

    def _rows(self, row: int) -> dict[str, Array]:
        return {name: a[row] for name, a in self.arrays.items()
                if name not in ("counters", "out")}

    def add(self, loop: ClosedLoop) -> int:
        """Take `loop` in (its reference set); returns its row."""
        views = self._views(loop)
        if self.kind < 0:
            self.kind, self.control_every = loop._kind, loop.control_every
            self.fp, self.fr, self.frame = loop._fp, loop._fr, loop.frame
            self.scratch = np.empty(views["s"].size)
        if (loop._kind, loop.control_every) != (self.kind, self.control_every) \
                or not (loop.frame is self.frame or (np.array_equal(loop._fp, self.fp)
                                                     and np.array_equal(loop._fr, self.fr))):
            raise ValueError("the loops of a batch share the plant, control period and frame")
        if not self.free:
            self._grow(views)
        row = self.free.pop()
        rows = self._rows(row)
        for name, a in views.items():
            rows[name][:] = a
        self.arrays["counters"][row] = loop._counter
        self._bind(loop, rows)
        self.loops[row] = loop
        self.paths[row] = loop._path
        loop.batch_row = row
        return row

    def remove(self, loop: ClosedLoop) -> None:
        """Let `loop` go: its arrays its own again (copies of its rows)."""
        row = loop.batch_row
        self._bind(loop, {name: a.copy() for name, a in self._rows(row).items()})
        loop._counter = int(self.arrays["counters"][row])
        del self.loops[row], self.paths[row]
        loop.batch_row = -1
        self.free.append(row)

    def advance(self, t: float, dt: float, substeps: int,
                steps: list[tuple[ClosedLoop, Any]]) -> list[BatchRecord]:
        """Each (loop, reference) of `steps` from t to t + dt in `substeps` substeps, as
        `ClosedLoop.advance` (a new reference taken up by `set_reference`); their records
        at t + dt, in the same order."""
        if not steps:
            return []
        if substeps < 1 or not dt > 0.0:
            from cosim.errors import InputError

            raise InputError("closed loop", "substeps/dt", (substeps, dt),
                             "substeps >= 1, dt > 0")
        coef = self.arrays["coef"]
        rows = np.empty(len(steps), dtype=np.int64)
        for j, (loop, reference) in enumerate(steps):
            path = loop._path
            if path is None or (reference is not path.trajectory
                                and reference != path.trajectory):
                loop.set_reference(reference)
                path = loop._path
            row = loop.batch_row
            if path is not self.paths[row]:  # a new reference: its coefficients in the row
                assert path is not None
                coef[row] = path.coef
                path.coef = coef[row]
                self.paths[row] = path
            rows[j] = row
        a = self.arrays
        t_end = t + dt
        failed = advance_batch(self.kind, rows, a["s"], a["pconst"], a["pinputs"],
                               a["pforces"], coef, self.fp, self.fr, a["lp"], a["cp"], a["ff"],
                               a["cs"], a["counters"], a["out"], self.scratch, float(t),
                               float(t_end), dt / substeps, substeps, self.control_every)
        if failed >= 0:
            loop = steps[failed][0]
            loop._raise(int(a["out"][rows[failed], O_STATUS]), t)
        records = []
        out = a["out"]
        for (loop, _), row in zip(steps, rows.tolist(), strict=True):
            o = out[row].tolist()
            loop.road_pose = (o[O_S], o[O_D], o[O_REL])
            records.append(BatchRecord(
                t_end, o[O_X], o[O_Y], o[O_PSI], o[O_VX], o[O_VY], o[O_R], o[O_AX], o[O_AY],
                o[O_XREF], o[O_YREF], o[O_VXREF], o[O_KAPPA], o[O_YE], o[O_PHIE], o[O_EX],
                o[O_ALONG], o[O_DELTA], o[O_DMZ], o[O_FA],
                (o[O_FX], o[O_FX + 1], o[O_FX + 2], o[O_FX + 3]), o[O_SAT] != 0.0))
        return records


@register_warm_up
def warm_up() -> None:
    """Compile (or load) `advance_batch` for both plants."""
    from cosim.params import ControllerGains, VehicleParams
    from cosim.planning.trajectory import LaneChangeTrajectory
    from cosim.vehicle.plant import PlantStart

    from .closed_loop import PLANTS, LoopConfig

    ref = LaneChangeTrajectory(t0=0.0, tau=1.0, x0=0.0, y0=0.0, vx0=20.0, vxf=20.0,
                               width=0.0)
    for plant in PLANTS:
        batch = LoopBatch(1)
        loop = ClosedLoop(LoopConfig(plant), VehicleParams(), ControllerGains(), 0.8,
                          PlantStart(vx=20.0))
        loop.set_reference(ref)
        batch.add(loop)
        batch.advance(0.0, 0.05, 10, [(loop, ref)])
        batch.remove(loop)

