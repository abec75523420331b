"""What a decision function is handed: the SV as the rule sees it and the traffic
around it, as two named structures (the numba kernels below them take flat arrays).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from cosim.traffic.world import Scene

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SVView:
    """The SV as the decision rules see it."""

    x: float  # m, centre, along the road
    y: float  # m, centre, across the road
    speed: float  # m/s, the speed the rule reasons with (the car-following reference's)
    length: float  # m
    desired_speed: float  # m/s
    width: float = 0.0  # m (0: unknown, it is taken to enter a lane with its centre)
    accel: float = 0.0  # m/s^2, the car-following reference's acceleration (a change
    # started now starts with it: the gap policy, cosim.driving.gap.geometry.ChangeStart)


@dataclass(frozen=True)
class TrafficView:
    """The TVs around the SV, one entry per TV (arrays of equal length)."""

    x: Array  # m, centres along the road
    y: Array  # m, centres across the road
    speed: Array  # m/s, speed along the road
    length: Array  # m
    width: Array  # m
    lateral_speed: Array | None = None  # m/s, + left (None: unknown, nobody is leaving)
    ids: tuple[str, ...] = ()  # SUMO ids (for a gap request)
    # the lane each TV is announced over V2V to be changing into (an automated vehicle's
    # broadcast lane change, C3; -1: none; None: nobody announces one)
    joining: NDArray[np.int64] | None = None

    @classmethod
    def of(cls, scene: Scene) -> TrafficView:
        """The TVs of a loop's scene (their x velocity as the speed along the road)."""
        tvs = scene.tvs
        return cls(tvs.x, tvs.y, scene.tv_vx, tvs.length, tvs.width, tvs.lateral_speed,
                   tvs.ids)

    @classmethod
    def arrays(cls, x: object, y: object, speed: object, length: object, width: object,
               lateral_speed: object = None, ids: tuple[str, ...] = ()) -> TrafficView:
        """From lists or arrays (hand-made scenes)."""
        def f(a: object) -> Array:
            return np.asarray(a, dtype=float)

        return cls(f(x), f(y), f(speed), f(length), f(width),
                   None if lateral_speed is None else f(lateral_speed), ids)

    def announced(self, joining: dict[str, int]) -> TrafficView:
        """This view with `joining` (TV id -> the lane its announced change goes to)
        marked (itself when nobody announces one)."""
        if not joining:
            return self
        lanes = np.array([joining.get(vid, -1) for vid in self.ids], dtype=np.int64)
        return replace(self, joining=lanes) if (lanes >= 0).any() else self
