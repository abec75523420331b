"""A road frame with a circular arc, built directly for the control tests."""

from __future__ import annotations

import numpy as np

from cosim.road.frame import ArcFrame, ArcTable, FrameQuality


def arc_frame(radius: float, length: float, straight: float = 300.0, h: float = 0.5
              ) -> ArcFrame:
    """A straight, then a circular arc of `radius` (left), then straight: the frame's
    table built directly (curvature steps at both ends, no smoothing)."""
    kappa = np.concatenate((np.zeros(int(straight / h)), np.full(int(length / h), 1.0 / radius),
                            np.zeros(int(straight / h))))
    theta = np.concatenate(([0.0], np.cumsum(kappa * h)))
    dth = np.diff(theta)
    mid = theta[:-1] + 0.5 * dth
    step = h * np.sinc(dth / (2.0 * np.pi))
    x = np.concatenate(([0.0], np.cumsum(step * np.cos(mid))))
    y = np.concatenate(([0.0], np.cumsum(step * np.sin(mid))))
    return ArcFrame(ArcTable(0.0, h, x, y, theta, kappa), 1.875, kappa.size * h, 200.0,
                    FrameQuality(0.0, radius, 0.0, 0.0))
