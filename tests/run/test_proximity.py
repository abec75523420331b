"""The compiled per-step geometry (cosim.run.proximity) against the numpy rules it
replaces in the loop (cosim.run.metrics.gap_ttc, half_extents) and its own interpreted
form, to the bit, on random scenes."""

from __future__ import annotations

import math

import numpy as np

from cosim.run import metrics as mx
from cosim.run.proximity import gap_ttc_min, lane_neighbours

L, W = 4.32, 1.8


def random_scene(rng: np.random.Generator, n: int) -> dict[str, np.ndarray]:
    return {"x": rng.uniform(-60.0, 60.0, n), "y": rng.uniform(0.0, 11.25, n),
            "vx": rng.uniform(10.0, 35.0, n), "h": rng.normal(0.0, 0.05, n),
            "length": rng.choice([4.32, 5.0, 12.0], n), "width": rng.choice([1.8, 2.5], n),
            "vy": rng.normal(0.0, 0.5, n)}


def test_gap_ttc_min_is_the_minimum_of_metrics_gap_ttc_to_the_bit() -> None:
    rng = np.random.default_rng(7)
    diag = math.hypot(L, W)
    for trial in range(300):
        tv = random_scene(rng, int(rng.integers(0, 40)))
        x, y, h = rng.uniform(-5, 5), rng.uniform(0.0, 11.25), rng.normal(0, 0.05)
        vx = rng.uniform(10.0, 35.0)
        c, s = abs(math.cos(h)), abs(math.sin(h))
        hx, hy = 0.5 * (L * c + W * s), 0.5 * (L * s + W * c)
        near = np.empty(tv["x"].size, dtype=bool)
        got = gap_ttc_min(x, y, vx, hx, hy, diag, tv["x"], tv["y"], tv["vx"], tv["h"],
                          tv["length"], tv["width"], near)
        tv_half = mx.half_extents(tv["length"], tv["width"], tv["h"])
        gap, ttc = mx.gap_ttc(x, y, vx, (hx, hy), tv["x"], tv["y"], tv["vx"], tv_half)
        want = (float(gap.min()) if gap.size else math.inf,
                float(ttc.min()) if ttc.size else math.inf)
        assert got == want, trial
        reach = 0.5 * (np.hypot(tv["length"], tv["width"]) + diag)
        np.testing.assert_array_equal(near, np.hypot(tv["x"] - x, tv["y"] - y) <= reach)


def test_lane_neighbours_compiled_equals_interpreted() -> None:
    rng = np.random.default_rng(8)
    for trial in range(300):
        tv = random_scene(rng, int(rng.integers(0, 40)))
        for lane in (0, 1, 2):
            for use_vy in (False, True):
                args = (lane, 0.0, L, tv["x"], tv["y"], tv["length"], tv["width"], 0.0, 3.75,
                        tv["vy"], use_vy)
                assert lane_neighbours(*args) == lane_neighbours.py_func(*args), trial


def test_lane_neighbours_picks_the_nearest_touching_tv_each_side() -> None:
    x = np.array([30.0, 10.0, -8.0, -20.0, 12.0])
    y = np.array([1.875, 1.875, 1.875, 1.875, 5.625])  # the last one in lane 1
    one = np.full(5, L)
    lead, gap_ahead, foll, gap_behind = lane_neighbours(
        0, 0.0, L, x, y, one, np.full(5, W), 0.0, 3.75, np.zeros(5), False)
    assert (lead, foll) == (1, 2)
    assert gap_ahead == 10.0 - L and gap_behind == 8.0 - L
