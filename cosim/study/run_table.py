"""The vocabulary of a study's runs.csv, shared by the runs (cosim.study.grid,
cosim.study.worker, cosim.study.store) and their summary (cosim.study.summary): the grid
parameters in the order runs.csv lists them, the drivers, the values of a run without a
variant or a plant, a record's status, and the columns a clock measured."""

from __future__ import annotations

from enum import StrEnum

# Grid parameters, in the order runs.csv lists (and sorts) them; `share` is [fleet] share,
# the automated vehicles' share of the inserted ones, `fleet_driver` [fleet] driver, who
# drives them (cosim, or SUMO's sumo / acc / cacc).
PARAMETERS = ("driver", "variant", "plant", "occupant", "mu", "share", "fleet_driver",
              "density", "seed")
NO_FLEET_DRIVER = "cosim"  # [fleet] driver's default: a run's id names any other
# The variant of runs without one (and of the SUMO-native driver, which no variant
# changes): the base scenario as it is.
NO_VARIANT = ""
# The plant of the SUMO-native driver: SUMO moves the SV, no plant of ours runs.
NO_PLANT = "none"
# Columns of runs.csv measured by a clock (`wall_time_s` and the run's own
# `wall_*` and `cpu_*` columns from cosim.run.loop): they differ between two
# executions of the same run; everything else is reproducible.
TIMING_PREFIXES = ("wall_", "cpu_")


class RunStatus(StrEnum):
    """A run's `status` in its record and in runs.csv."""

    OK = "ok"  # the run finished; its metrics are in the record
    FAILED = "failed"  # the run raised or its process died; `error` says why


class Driver(StrEnum):
    """The SV's driver, named by its controller (the scenario's `controller` choices)."""

    MIMO = "mimo"  # our planner and MIMO controller
    SISO = "siso"  # our planner and SISO controller
    SUMO = "sumo"  # SUMO drives the SV: no plant of ours, no variant


def is_timing_column(name: str) -> bool:
    """Whether a runs.csv column is a wall-clock measurement (not reproducible)."""
    return name.startswith(TIMING_PREFIXES)
