"""SUMO's own measuring devices for one run: the detectors along the route
([detectors]) and the SSM device ([ssm]), their options for SUMO's start, and the
tables read from their outputs once SUMO has closed (cosim.traffic.detectors,
cosim.traffic.ssm)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from cosim.road.road import Road
from cosim.scenario.model import Scenario
from cosim.traffic.detectors import DetectorLayout, place_detectors
from cosim.traffic.ssm import VehicleDistance, conflicts_table, equip_vtypes, loaded_vehicles
from cosim.traffic.ssm import sumo_options as ssm_options
from cosim.traffic.sumo import SumoSim


class SumoMeasures:
    """The scenario's detectors and SSM device, their outputs written into `output`
    (None: neither, whatever the scenario asks); `sv_id` is the SV's SUMO id."""

    def __init__(self, sc: Scenario, route_road: Road, output: Path | None,
                 sv_id: str) -> None:
        self.output = output
        self.sv_id = sv_id
        self.detectors: DetectorLayout | None = None
        if sc.detectors.enabled and output is not None:
            self.detectors = place_detectors(route_road, sc.detectors)
        self.ssm = sc.ssm if sc.ssm.enabled and output is not None else None
        # every vehicle's km, for conflicts per vehicle-km
        self.distance = VehicleDistance() if self.ssm is not None else None
        self.fleet_vtypes = sc.fleet.vtypes
        # with `[ssm] vehicles = "fleet"`, the fleet's vehicles SUMO builds as it loads the
        # user's routes are equipped by name (cosim.traffic.ssm.loaded_vehicles)
        self._loaded: tuple[str, ...] = ()
        if self.ssm is not None and self.ssm.vehicles == "fleet" and sc.demand is not None:
            self._loaded = loaded_vehicles(sc.demand.route_files, sc.fleet.vtypes)

    def detector_additional(self) -> str:
        """The additional file's path for SUMO's detectors ("" without them)."""
        if self.detectors is None or self.output is None:
            return ""
        return self.detectors.additional(self.output)

    def ssm_options(self) -> tuple[str, ...]:
        """SUMO's command-line options for the SSM device (none without it)."""
        if self.ssm is None or self.output is None:
            return ()
        return ssm_options(self.ssm, self.output, self.sv_id, self._loaded)

    def started(self, sumo: SumoSim) -> None:
        """SUMO has started: count every vehicle's distance (with SSM)."""
        if self.distance is not None:
            sumo.add_hook(self.distance)

    def warmed_up(self, sumo: SumoSim) -> None:
        """The warm-up is over: the fleet's flows' vehicles SUMO builds from now on carry
        the device with `vehicles = "fleet"` (a device costs CPU every step)."""
        if self.ssm is not None and self.ssm.vehicles == "fleet":
            equip_vtypes(sumo.api, self.fleet_vtypes)

    def clock_starts(self, t: float) -> None:
        """The run's clock starts at SUMO's time `t` (s): distances count from there."""
        if self.distance is not None:
            self.distance.since = t

    def detector_table(self, t_warmup: float) -> Any:
        """detectors.csv's rows (cosim.traffic.detectors.DetectorLayout.table) once SUMO
        has closed (its outputs are complete then), times on the run's clock (SUMO's
        minus `t_warmup`, s); None without detectors."""
        if self.detectors is None or self.output is None:
            return None
        return self.detectors.table(self.output, t_warmup)

    def conflict_table(self, t_warmup: float) -> Any:
        """conflicts.csv's rows (cosim.traffic.ssm.conflicts_table) once SUMO has closed,
        times on the run's clock; None without the SSM device."""
        if self.ssm is None or self.output is None:
            return None
        return conflicts_table(self.output, self.ssm, self.sv_id, t_warmup)
