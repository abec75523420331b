"""The corners' fillets (cosim/road/corners.py): clothoid, arc, clothoid, curvature
continuous, tangent to the straights at its ends, within half a lane of SUMO's corner."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cosim.road.corners import (
    LAT_JERK,
    RADIUS_SHARE,
    CornerSite,
    corner_vertex,
    fillet,
    fillet_shape,
    rounding,
)


def _site(turn_deg: float, speed: float, room: float = 300.0) -> CornerSite:
    """A corner turning `turn_deg` to the right at (0, 0), straights `room` m long, the
    SV's lane (3.2 m) centred 1.6 m right of the line, as a ramp's one lane."""
    t = math.radians(-turn_deg)
    q1 = (room * math.cos(t), room * math.sin(t))
    return CornerSite((-room, 0.0), (0.0, 0.0), (0.0, 0.0), q1, "J", speed, 3.2, 1.6, 3.2)


def _curvature(points: np.ndarray) -> np.ndarray:
    """1/m, each inner vertex's turn over its two segments' mean length (+ left)."""
    seg = np.diff(points, axis=0)
    heading = np.unwrap(np.arctan2(seg[:, 1], seg[:, 0]))
    length = np.hypot(seg[:, 0], seg[:, 1])
    return np.diff(heading) / (0.5 * (length[:-1] + length[1:]))


@pytest.mark.parametrize(("turn_deg", "speed"), [(11.3, 22.22), (43.0, 13.89)])
def test_a_corners_fillet_is_curvature_continuous_and_tangent_to_its_straights(
        turn_deg: float, speed: float) -> None:
    """The weaving section's 11-degree ramp corner at 80 km/h (a symmetric clothoid
    pair, no room for an arc within half a lane) and game/ramp's 43-degree one at 50
    km/h (clothoid, arc, clothoid): sampled every 0.5 m with the straights' last and
    first points, the curvature never steps by more than the spiral's rate x the step
    (a circular fillet steps by 1/R at its ends), its ends lie on the straights and run
    along them within 1e-9, its lane within half a lane of SUMO's corner, the spirals
    long enough for LAT_JERK at the arc's speed or as long as the corner allows."""
    site = _site(turn_deg, speed)
    ((radius, lane, deviation, tangent, spiral),) = rounding([site], 2.0, 3.7)
    assert spiral > 0.0 and deviation <= 0.5 * site.width + 1e-9
    assert lane == pytest.approx(radius - 1.6)  # the lane on the turn's inside
    assert fillet_shape(radius, spiral, -math.radians(turn_deg))[0] == pytest.approx(tangent)
    v = min(speed, math.sqrt(2.0 * lane))  # the arc's speed (CornerSpeeds)
    jerk = v**3 * radius / (lane * lane * spiral)  # m/s^3 on the lane's spiral
    sec = 1.0 / math.cos(0.5 * math.radians(turn_deg)) - 1.0
    circular = min(speed**2 / 2.0, 0.5 * site.width / sec) + 1.6  # the arc alone's radius
    spirals = (jerk <= LAT_JERK * (1 + 1e-9)  # as long as the jerk asks, or a pair
               or spiral == pytest.approx(radius * math.radians(turn_deg)))
    # or shortened where the arc's radius is down to RADIUS_SHARE of the arc alone's
    assert spirals or radius == pytest.approx(RADIUS_SHARE * circular)
    _, u, w, _ = corner_vertex(site)
    step = 0.5
    points, kappa = fillet(site, radius, spiral, tangent, step)
    line = np.vstack([points[0] - step * u, points, points[-1] + step * w])
    rate = 1.0 / (radius * spiral)  # 1/m^2, the spiral's
    assert np.abs(np.diff(_curvature(line))).max() <= rate * step * 1.01
    assert np.abs(np.diff(kappa)).max() <= rate * step * (1 + 1e-9)
    assert kappa.min() == pytest.approx(-1.0 / radius)
    assert kappa[0] == kappa[-1] == 0.0
    # the ends on the straights (y = 0 before; along w after), heading along them
    fine, _ = fillet(site, radius, spiral, tangent, 1e-3)
    assert abs(fine[0, 1]) <= 1e-9 and abs(fine[-1] @ np.array([-w[1], w[0]])) <= 1e-9
    assert fine[0, 0] == pytest.approx(-tangent, abs=1e-9)
    assert np.linalg.norm(fine[-1] - tangent * w) <= 1e-9
    first, last = fine[1] - fine[0], fine[-1] - fine[-2]
    assert abs(first[1] / first[0]) <= 1e-9
    assert abs(last @ np.array([-w[1], w[0]])) / np.linalg.norm(last) <= 1e-9
    # continuous in position: no gap where the spirals meet the arc
    gaps = np.hypot(*np.diff(fine, axis=0).T)
    assert gaps.max() <= 1e-3 * (1 + 1e-6)
    # the deviation measured: the lane 1.6 m inside the line, from SUMO's lane's corner
    normal = np.column_stack((-np.gradient(fine[:, 1]), np.gradient(fine[:, 0])))
    normal /= np.hypot(normal[:, 0], normal[:, 1])[:, None]
    lane_points = fine - 1.6 * normal  # right of the line
    half = 0.5 * math.radians(turn_deg)
    corner = np.array([-1.6 * math.tan(half), -1.6])  # SUMO's lane's corner
    assert np.hypot(*(lane_points - corner).T).min() == pytest.approx(deviation, abs=1e-3)
