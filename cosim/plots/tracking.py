"""Tracking figures in the style of the paper's Fig. 13-15 (speed, lateral
offset, heading error over time), and the inputs (steering, yaw moment, wheel
forces), one curve per plant x controller."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from cosim.control.tracking import TrackingRun
from cosim.plots import save_figure
from cosim.plots.labels import suptitle

STYLE = {
    ("twotrack", "mimo"): ("tab:blue", "-"),
    ("twotrack", "siso"): ("tab:orange", "-"),
    ("bicycle", "mimo"): ("tab:blue", ":"),
    ("bicycle", "siso"): ("tab:orange", ":"),
}


WHEELS = ("front-left", "front-right", "rear-left", "rear-right")  # order of StepRecord.fx


def _label(run: TrackingRun) -> str:
    return f"{run.controller.upper()}, {run.plant}"


def plot_states(runs: Sequence[TrackingRun], path: Path, title: str) -> Path:
    """Fig. 13-15 style: Vx with Vx*, ye and phi_e over time."""
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 8.0), sharex=True)
    for k, run in enumerate(runs):
        color, ls = STYLE.get((run.plant, run.controller), ("k", "-"))
        t = run.array("t")
        if k == 0:
            axes[0].plot(t, run.array("vx_ref") * 3.6, color="k", lw=2.5, alpha=0.3,
                         label="reference Vx*")
        axes[0].plot(t, run.array("vx") * 3.6, color=color, ls=ls, label=_label(run))
        axes[1].plot(t, run.array("ye") * 100.0, color=color, ls=ls, label=_label(run))
        axes[2].plot(t, np.degrees(run.array("phi_e")), color=color, ls=ls, label=_label(run))
    axes[0].set_ylabel("Vx (km/h)")
    axes[0].set_title("longitudinal speed (cf. Fig. 13)", fontsize=9)
    axes[1].set_ylabel("ye (cm)")
    axes[1].set_title("lateral offset (cf. Fig. 14)", fontsize=9)
    axes[2].set_ylabel("phi_e (deg)")
    axes[2].set_title("heading error (cf. Fig. 15)", fontsize=9)
    axes[2].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="lower right")
    suptitle(fig, title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    return path


def held_inputs(run: TrackingRun) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(t, delta_f, dMz, wheel Fx (n, 4)) from the first control update on: the value
    at t[k] is the input held over (t[k-1], t[k]]; the first record (the start,
    before any update) has none."""
    return (run.array("t")[1:], run.array("delta_f")[1:], run.array("dmz")[1:],
            run.array("fx")[1:])


def plot_inputs(runs: Sequence[TrackingRun], path: Path, title: str) -> Path:
    """Steering angle, demanded yaw moment and each wheel's longitudinal force over time.

    An input is computed at a control update and held until the next, so each
    is drawn as a step over the interval it acted in, from the first update on:
    the first record (the start, before any control update) carries no input yet,
    and drawing its zeros made a false jump (0 -> the drag-compensating force)."""
    fig = plt.figure(figsize=(7.5, 9.0))
    grid = fig.add_gridspec(4, 2)
    steer = fig.add_subplot(grid[0, :])
    yaw = fig.add_subplot(grid[1, :], sharex=steer)
    wheels = [fig.add_subplot(grid[2 + k // 2, k % 2], sharex=steer) for k in range(4)]
    for run in runs:
        color, ls = STYLE.get((run.plant, run.controller), ("k", "-"))
        t, delta_f, dmz, fx = held_inputs(run)
        style = {"color": color, "ls": ls, "label": _label(run), "drawstyle": "steps-pre"}
        steer.plot(t, np.degrees(delta_f), **style)
        yaw.plot(t, dmz, **style)
        for k, ax in enumerate(wheels):
            ax.plot(t, fx[:, k] / 1000.0, **style)
    steer.set_ylabel("delta_f (deg)")
    yaw.set_ylabel("dMz demand (N m)")
    for ax, name in zip(wheels, WHEELS, strict=True):
        ax.set_ylabel(f"Fx {name} (kN)")
        ax.set_title(f"{name} wheel longitudinal force", fontsize=8)
    for ax in (steer, yaw, *wheels):
        ax.set_xlabel("t (s)")
        ax.tick_params(labelbottom=True)  # shared x: every panel keeps its labels
    for ax in (steer, yaw, *wheels):
        ax.grid(alpha=0.3)
    steer.legend(fontsize=8)
    suptitle(fig, title, fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    return path
