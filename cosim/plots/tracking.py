"""Tracking figures in the style of the paper's Fig. 13-15 (speed, lateral
offset, heading error over time), and the inputs (steering, yaw moment, wheel
forces), one curve per plant x controller."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from cosim.control.tracking import TrackingRun
from cosim.output import atomic_path

STYLE = {
    ("twotrack", "mimo"): ("tab:blue", "-"),
    ("twotrack", "siso"): ("tab:orange", "-"),
    ("bicycle", "mimo"): ("tab:blue", ":"),
    ("bicycle", "siso"): ("tab:orange", ":"),
}


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
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path


def plot_inputs(runs: Sequence[TrackingRun], path: Path, title: str) -> Path:
    """Steering angle, demanded yaw moment and the wheels' summed |Fx| over time."""
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 7.0), sharex=True)
    for run in runs:
        color, ls = STYLE.get((run.plant, run.controller), ("k", "-"))
        t = run.array("t")
        axes[0].plot(t, np.degrees(run.array("delta_f")), color=color, ls=ls, label=_label(run))
        axes[1].plot(t, run.array("dmz"), color=color, ls=ls, label=_label(run))
        axes[2].plot(t, np.abs(run.array("fx")).sum(axis=1) / 1000.0, color=color, ls=ls,
                     label=_label(run))
    axes[0].set_ylabel("delta_f (deg)")
    axes[1].set_ylabel("dMz demand (N m)")
    axes[2].set_ylabel("sum |Fx| (kN)")
    axes[2].set_xlabel("t (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path
