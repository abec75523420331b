"""cosim/plots/replanning.py: the study figure from a summary table."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from cosim.plots.replanning import plot_replanning
from cosim.study.summary import summarize


def test_figure_from_a_summary(tmp_path: Path) -> None:
    rows = []
    for driver, variant in (("mimo", "paper"), ("mimo", "replan"), ("sumo", "")):
        for density in (10.0, 20.0):
            for seed in (1, 2):
                rows.append({"driver": driver, "variant": variant, "plant": "twotrack",
                             "occupant": 0.5, "mu": 0.8, "density": density, "seed": seed,
                             "status": "ok", "lane_change_completed": seed == 1,
                             "collision": variant == "paper", "collisions_sv": 0,
                             "collisions_manoeuvre": int(variant == "paper"),
                             "lane_change_duration_s": 3.0 + seed, "min_ttc_s": 2.0})
    summary = summarize(pd.DataFrame(rows))
    assert set(summary["manoeuvre_collision_rate"]) == {0.0, 1.0}
    out = plot_replanning(summary, tmp_path / "r.png", title="t")
    assert out.stat().st_size > 10_000
