"""The fleet's calls into SUMO (cosim.run.fleet): who SUMO inserted in its last step,
their routes and vTypes, taking a vehicle out of SUMO's control (coloured green in
sumo-gui) and handing it back,
an automated vehicle's blinker, every collision of a step, who was teleported."""

from __future__ import annotations

from cosim.traffic.world import World

AUTOMATED_COLOUR = (0, 200, 80, 255)  # RGBA, automated vehicles in sumo-gui (the SV: blue)


class Takeovers:
    """SUMO as the fleet uses it, through the run's World."""

    def __init__(self, world: World) -> None:
        self.sumo = world.sumo

    def departed(self) -> tuple[str, ...]:
        """The vehicles SUMO inserted in its last step, in its insertion order."""
        return tuple(self.sumo.api.simulation.getDepartedIDList())

    def route_of(self, vehicle_id: str) -> tuple[str, ...]:
        """The edges a vehicle still has to drive, the one it is on first."""
        vehicle = self.sumo.api.vehicle
        route = vehicle.getRoute(vehicle_id)
        return tuple(route[max(int(vehicle.getRouteIndex(vehicle_id)), 0):])

    def vtype_of(self, vehicle_id: str) -> str:
        """A vehicle's vType as its demand names it (not the one SUMO makes for it alone
        when one of its values is set, "<vType>@<vehicle id>")."""
        type_id = str(self.sumo.api.vehicle.getTypeID(vehicle_id))
        return type_id.removesuffix(f"@{vehicle_id}")

    def take_over(self, vehicle_id: str, size: tuple[float, float]) -> float:
        """Take a vehicle SUMO drives out of its control (from now on moved by
        `World.move_xy`), its body `size` (length, width) m; returns its speed now (m/s)."""
        self.sumo.take_over(vehicle_id, size)
        self.sumo.api.vehicle.setColor(vehicle_id, AUTOMATED_COLOUR)  # apart in sumo-gui
        return float(self.sumo.api.vehicle.getSpeed(vehicle_id))

    def hand_back(self, vehicle_id: str) -> None:
        """SUMO drives a vehicle taken over again."""
        self.sumo.hand_back(vehicle_id)

    def set_blinker(self, vehicle_id: str, direction: int) -> None:
        """A controlled vehicle's blinker: -1 right, 0 off, +1 left."""
        self.sumo.set_blinker(vehicle_id, direction)

    def collisions(self) -> set[tuple[str, ...]]:
        """Every collision SUMO reported in its last step (sorted id pairs)."""
        return {tuple(sorted(p)) for p in self.sumo.collisions()}

    def teleported(self) -> set[str]:
        """The vehicles SUMO teleported during the run."""
        return {e.vehicle_id for e in self.sumo.events if e.kind == "teleport"}
