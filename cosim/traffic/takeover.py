"""The fleet's calls into SUMO (cosim.run.fleet): who SUMO inserted in its last step,
their routes and vTypes, taking a vehicle out of SUMO's control (coloured green in
sumo-gui) and handing it back,
an automated vehicle's blinker and the gap requests it sends SUMO's drivers (the
traffic's courtesy and cooperative V2V, as the SV's: cosim.traffic.cooperation), every
collision of a step, who was teleported; and the
fleet's floor (`replay`): SUMO with the SV and the automated vehicles moved along the
paths a fleet run recorded, nothing else (`cosim bench fleet`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from cosim.traffic.world import SV_ID, World, cooperation_channels, deliver_requests

if TYPE_CHECKING:
    from cosim.traffic.cooperation import CooperationChannel
    from cosim.traffic.sumo import TrafficSnapshot


@dataclass(frozen=True)
class RecordedPath:
    """A vehicle's path as a run recorded it, from trace row k0 on: its centre's pose
    (m, m, rad), speed (m/s) and acceleration (m/s^2) at each row."""

    vehicle_id: str
    k0: int  # its first row (the SV: 0; an AV: the row it was taken over at)
    x: list[float]
    y: list[float]
    heading: list[float]
    speed: list[float]
    accel: list[float]
    handed_back: bool = False  # an AV handed back to SUMO at its last row

    @property
    def k_end(self) -> int:
        """Its last row."""
        return self.k0 + len(self.x) - 1

AUTOMATED_COLOUR = (0, 200, 80, 255)  # RGBA, automated vehicles in sumo-gui (the SV: blue)
BASELINE_COLOUR = (230, 140, 0, 255)  # RGBA, the fleet's vehicles SUMO drives (a baseline)
# [fleet] driver -> SUMO's car-following model of its vType copy (process.BASELINE_TYPES)
CAR_FOLLOWING = {"acc": "ACC", "cacc": "CACC"}
# what a vType copy keeps of the vehicle's vType (vehicletype getter / setter suffixes)
TYPE_VALUES = ("Length", "Width", "MinGap", "Accel", "Decel", "EmergencyDecel",
               "ApparentDecel", "Tau", "MaxSpeed", "SpeedFactor", "SpeedDeviation")


class Takeovers:
    """SUMO as the fleet uses it, through the run's World."""

    def __init__(self, world: World) -> None:
        self.sumo = world.sumo
        self.scenario = world.scenario
        self._copies: set[str] = set()  # the vType copies made (drive_as)

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

    def gap_requests(self, number: int) -> list[CooperationChannel]:
        """The gap-request channels of the automated vehicle `number` (its own draws)."""
        return cooperation_channels(self.scenario, (number,))

    def deliver_gap_requests(self, channels: list[CooperationChannel], vehicle_id: str,
                             t: float, tvs: TrafficSnapshot, x: float, changing: bool
                             ) -> None:
        """One step of the requests `vehicle_id` (centre x, m) sent (World's for the SV)."""
        deliver_requests(channels, self.sumo.api, vehicle_id, t, tvs, x,
                         self.scenario.vehicle.length, changing)

    def drive_as(self, vehicle_id: str, driver: str) -> None:
        """A baseline of the fleet: SUMO drives the vehicle on, marked in sumo-gui; for
        `acc` / `cacc` its vType is switched to a copy of its own with SUMO's ACC / CACC
        car-following model (the copy's sizes, accelerations, headway and speeds its
        vType's; its own maximum speed and speed factor kept)."""
        api = self.sumo.api
        vehicle, vt = api.vehicle, api.vehicletype
        vehicle.setColor(vehicle_id, BASELINE_COLOUR)
        model = CAR_FOLLOWING.get(driver)
        if model is None:  # sumo: its own driver, as it is
            return
        from cosim.traffic.process import BASELINE_TYPES

        own = self.vtype_of(vehicle_id)
        copy = f"{own}_{driver}"
        if copy not in self._copies:
            vt.copy(BASELINE_TYPES[model], copy)
            for name in TYPE_VALUES:
                getattr(vt, f"set{name}")(copy, getattr(vt, f"get{name}")(own))
            vt.setVehicleClass(copy, vt.getVehicleClass(own))
            self._copies.add(copy)
        max_speed, factor = vehicle.getMaxSpeed(vehicle_id), vehicle.getSpeedFactor(vehicle_id)
        vehicle.setType(vehicle_id, copy)
        vehicle.setMaxSpeed(vehicle_id, max_speed)
        vehicle.setSpeedFactor(vehicle_id, factor)

    def collision_events(self) -> list[tuple[str, str]]:
        """Every (collider, victim) pair SUMO reported in its last step."""
        return self.sumo.collisions()

    def collisions(self) -> set[tuple[str, ...]]:
        """Every collision SUMO reported in its last step (sorted id pairs)."""
        return {tuple(sorted(p)) for p in self.sumo.collisions()}

    def replay(self, sv: RecordedPath, avs: Sequence[RecordedPath], size: tuple[float, float],
               on_row: Callable[[int], None] | None = None) -> int:
        """The fleet's floor: the SV and the AVs `avs` (bodies `size`, length and width m)
        moved along their recorded paths by moveToXY, nothing read, planned, controlled or
        checked. As the fleet does it: an AV taken over after SUMO's step to its first
        row, moved to its row k + 1 before SUMO's step from row k, handed back at its
        last row if it was. `on_row(k)` is called at the top of each row k. Returns how
        many AVs were not on the network at their takeover (none when SUMO's traffic
        is the recorded run's)."""
        sumo = self.sumo
        starts: dict[int, list[RecordedPath]] = {}
        for av in avs:
            starts.setdefault(av.k0, []).append(av)
        driving: list[RecordedPath] = []
        missing = 0
        for k in range(sv.k_end):
            if on_row is not None:
                on_row(k)
            ending = [av for av in driving if av.k_end == k]
            for av in ending:
                driving.remove(av)
                if av.handed_back:
                    self.hand_back(av.vehicle_id)
            j = k + 1
            sumo.move(SV_ID, sv.x[j], sv.y[j], sv.heading[j], sv.speed[j], sv.accel[j])
            for av in driving:
                i = j - av.k0
                sumo.move(av.vehicle_id, av.x[i], av.y[i], av.heading[i], av.speed[i],
                          av.accel[i])
            sumo.step()
            for av in starts.get(j, ()):
                if av.vehicle_id not in sumo.api.vehicle.getIDList():
                    missing += 1
                    continue
                self.take_over(av.vehicle_id, size)
                driving.append(av)
        if on_row is not None:
            on_row(sv.k_end)
        return missing

    def teleported(self) -> set[str]:
        """The vehicles SUMO teleported during the run."""
        return {e.vehicle_id for e in self.sumo.events if e.kind == "teleport"}
