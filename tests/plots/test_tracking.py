"""Tracking figures: inputs.png shows every wheel's force, from the first control update."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from cosim.control.closed_loop import LoopConfig
from cosim.control.tracking import run_tracking
from cosim.planning.trajectory import LaneChangeTrajectory
from cosim.plots import DPI
from cosim.plots.tracking import WHEELS, held_inputs, plot_inputs

REF = LaneChangeTrajectory(t0=0.0, tau=6.25, x0=0.0, y0=1.875, vx0=80 / 3.6, vxf=90 / 3.6,
                           width=3.75)


def test_inputs_start_at_the_first_control_update(tmp_path: Path) -> None:
    """The first record precedes any control update (all inputs 0): drawing it made a
    0 -> 0.22 kN jump at t = 0. The held inputs start at the first update, where the
    wheels already carry the drag-compensating force."""
    run = run_tracking(LoopConfig("twotrack", "mimo"), REF, mu=0.4, duration=1.0)
    first = run.records[0]
    assert first.fx == (0.0, 0.0, 0.0, 0.0)  # the cause: no input before the first update
    t, delta_f, dmz, fx = held_inputs(run)
    assert t[0] == run.records[1].t > first.t
    assert fx.shape == (len(run.records) - 1, len(WHEELS))
    total = np.abs(fx).sum(axis=1)
    assert total[0] > 100.0  # N: the wheels push from the first update on, no 0
    # what remains is the plant starting untrimmed (free-rolling wheels): with the
    # relaxation-length tyres the speed loop rings on the wheels' spin mode
    # (~33 Hz), decaying; settled (steps below 10 % of the force) within 0.2 s
    settled = np.flatnonzero(t >= t[0] + 0.2)
    assert np.max(np.abs(np.diff(total[settled]))) < 0.1 * total[settled[0]]
    path = plot_inputs([run], tmp_path / "inputs.png", "t")
    with Image.open(path) as img:
        assert round(img.info["dpi"][0]) == DPI
