"""What the automated vehicles of a run announce to each other over V2V, and who of two
that want the same lane goes first.

The paper's prediction classes C2 and C3 assume V2V partners; with a fleet
(cosim.run.fleet) they exist. Every automated vehicle (the SV and each AV) broadcasts,
besides its state:
- its intention (C2): the blinker its policy sets (-1 right, +1 left; a policy signals
  while it seeks a gap and while it changes lanes), with the time it began (`since`);
- while it changes lanes, the lane change it flies (C3): the planner's min-jerk
  trajectory (eq. 2, 4), or a re-check's rescue that replaced it, exactly as flown.
These replace what SUMO would show of the vehicle (its signal bits, a lateral motion
rebuilt from its sideways speed) in the messages every receiver's own V2V channel
carries (cosim.traffic.v2v: range, latency, loss), so the receivers' planners predict
it with C2 / C3 as they predict scripted TVs' broadcasts.

Right of way (`give_way`). Two automated vehicles signalling into the same lane, from
both sides or from one lane at one gap, would each find its plan crossing the other's
C2 cluster (every lane change the other may start now) and wait for good. One already
changing lanes goes first, else the one that began signalling first (equal: the smaller
id): the other keeps predicting its C2 cluster and waits, while the first predicts the
other as keeping its lane (C1) as long as it only signals. A lane change under way (C3)
is always predicted as sent.
Both sides apply the same rule to the same broadcast numbers, so they agree, whatever
the channel's latency, once each has heard the other: an automated vehicle therefore
signals for `notice` before it starts a change (the channel's latency and enough steps
that a partner in range misses all of them with a chance below NOTICE_MISS), and one
whose intention began later has heard the earlier one's before it could start.

Gap requests (`GapRequests`): a policy that asks the vehicle blocking its gap for room
reaches SUMO's drivers through the traffic's courtesy; one that names an automated
vehicle sends the request over V2V instead (latency, loss), and that vehicle makes
room as SUMO's drivers do for the courtesy (cosim.driving.gap.yielding.MakingRoom).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from cosim.driving.gap.yielding import ROOM_DURATION
from cosim.traffic.v2v import LateralMotion, Override, V2VMessage

NOTICE_MISS = 1e-3  # -, the chance a partner in range missed every message of the notice

if TYPE_CHECKING:
    from cosim.params import RoadParams
    from cosim.planning.trajectory import LaneChangeTrajectory


@dataclass(frozen=True)
class Announcement:
    """What one automated vehicle announces now."""

    intention: int = 0  # -1 right, 0 none, +1 left (its blinker)
    since: float = math.nan  # s, when that intention began (nan: none)
    motion: LateralMotion | None = None  # the lane change it flies (C3; None: none)

    def override(self) -> Override:
        return Override(self.intention, self.motion, self.since)


def _changes_lane(trajectory: LaneChangeTrajectory | None) -> bool:
    """Whether a reference moves sideways (a lane change, an abort, a rescue), not the
    straight lane-keeping reference (width 0 from rest)."""
    return trajectory is not None and (trajectory.width != 0.0 or trajectory.vy0 != 0.0)


class Announcements:
    """The current announcement of every automated vehicle of a run, by SUMO id."""

    def __init__(self, road: RoadParams) -> None:
        self.road = road
        self.t = 0.0  # s, the step being decided (the time a new intention begins)
        self.now: dict[str, Announcement] = {}

    def blinker(self, vehicle_id: str, forward: Callable[[int], None]
                ) -> Callable[[int], None]:
        """A blinker port for `vehicle_id` that announces its intention and sets the
        blinker in SUMO through `forward`."""
        def signal(direction: int) -> None:
            old = self.now.get(vehicle_id, Announcement())
            if direction != old.intention:
                since = self.t if direction != 0 else math.nan
                self.now[vehicle_id] = replace(old, intention=direction, since=since)
            forward(direction)
        return signal

    def flying(self, vehicle_id: str, reference: LaneChangeTrajectory | None) -> None:
        """The reference `vehicle_id` tracks from now: broadcast while it moves sideways."""
        old = self.now.get(vehicle_id, Announcement())
        motion = LateralMotion.of(reference) if (
            reference is not None and _changes_lane(reference)) else None
        if motion != old.motion:
            self.now[vehicle_id] = replace(old, motion=motion)

    def changing_besides(self, vehicle_id: str) -> bool:
        """Whether an automated vehicle other than `vehicle_id` flies a lane change now
        (none: nothing to hear of one, the channel need not run for it)."""
        return any(a.motion is not None for vid, a in self.now.items() if vid != vehicle_id)

    def forget(self, vehicle_id: str) -> None:
        """SUMO drives it again: what SUMO shows of it is its broadcast."""
        self.now.pop(vehicle_id, None)

    def overrides(self) -> dict[str, Override]:
        """The announcements as a V2V channel's overrides (cosim.traffic.v2v.messages)."""
        return {vid: a.override() for vid, a in self.now.items()}

    def give_way(self, vehicle_id: str, y: float, messages: Sequence[V2VMessage]
                 ) -> list[V2VMessage]:
        """`messages` as `vehicle_id` (at lateral position y) plans with them: the
        intentions of those that give way to it dropped (module docstring)."""
        me = self.now.get(vehicle_id)
        if me is None or me.intention == 0 or not messages:
            return list(messages)
        road = self.road
        target = road.lane_of(y) + me.intention
        # who goes first: one changing lanes already, then the earlier intention, then
        # the smaller id
        mine = (me.motion is None, _tick(me.since), vehicle_id)
        out = []
        for m in messages:
            if (m.intention != 0 and m.motion is None and math.isfinite(m.since)
                    and road.lane_of(m.y) + m.intention == target
                    and mine < (True, _tick(m.since), m.vehicle_id)):
                m = replace(m, intention=0)  # it waits for this vehicle: C1
            out.append(m)
        return out


def joining(road: RoadParams, messages: Sequence[V2VMessage]) -> dict[str, int]:
    """The lane each automated vehicle heard in `messages` flies its announced lane
    change into (its C3 motion's end lane), by id. An automated vehicle's own
    announcement has its intention's start (`since`); SUMO's drivers' lane changes,
    rebuilt from their sideways motion, and the scripted TVs' have none."""
    return {m.vehicle_id: road.lane_of(m.motion.y0 + m.motion.width) for m in messages
            if m.motion is not None and math.isfinite(m.since)}


def notice(latency: float, loss: float, step: float) -> float:
    """s, how long an automated vehicle signals before it starts a lane change: the
    channel's `latency` plus the steps after which every message of it was lost with a
    chance below NOTICE_MISS (one step without loss)."""
    steps = 1 if loss <= 0.0 else (
        math.inf if loss >= 1.0 else max(1, math.ceil(math.log(NOTICE_MISS) / math.log(loss))))
    return latency + steps * step


def _tick(t: float) -> float:
    """s, a time compared as both sides see it (the step times, free of rounding)."""
    return round(t, 6)


@dataclass(frozen=True)
class _Request:
    due: float  # s, when it arrives
    sender: str
    receiver: str


class GapRequests:
    """Gap requests between automated vehicles, over V2V: a policy asking an automated
    vehicle for room (the gap policy's `ask_gap` port naming one) sends it `latency`
    later, lost with `loss` (one draw per request from the run's seeded `rng`); the
    receiver, if its policy makes room (`make_room`), follows the sender as its leader
    (cosim.driving.gap.yielding.MakingRoom). A pair's request is sent once per
    ROOM_DURATION. Requests to anyone else go to `forward` (SUMO's drivers: the
    traffic's courtesy, cooperative V2V)."""

    def __init__(self, latency: float, loss: float, rng: np.random.Generator,
                 enabled: bool = True) -> None:
        self.latency, self.loss, self.rng, self.enabled = latency, loss, rng, enabled
        self.policies: dict[str, object] = {}  # automated vehicles' policies, by id
        self._queue: list[_Request] = []
        self._sent: dict[tuple[str, str], float] = {}  # (sender, receiver) -> s, when
        self.sent = 0  # requests sent between automated vehicles
        self.lost = 0  # of them, lost

    def port(self, sender: str, forward: Callable[[float, str], bool | None]
             ) -> Callable[[float, str], bool | None]:
        """`sender`'s ask_gap port: a request to an automated vehicle over V2V, else
        `forward`."""
        def ask(t: float, vehicle_id: str) -> bool | None:
            if vehicle_id not in self.policies:
                return forward(t, vehicle_id)
            if not self.enabled:
                return False
            last = self._sent.get((sender, vehicle_id), -math.inf)
            if t - last >= ROOM_DURATION - 1e-9:
                self._sent[(sender, vehicle_id)] = t
                self.sent += 1
                if self.rng.random() < self.loss:
                    self.lost += 1
                else:
                    self._queue.append(_Request(t + self.latency, sender, vehicle_id))
            return True
        return ask

    def deliver(self, t: float) -> None:
        """The requests due by t reach their receivers' policies."""
        if not self._queue:
            return
        due = [r for r in self._queue if r.due <= t + 1e-9]
        self._queue = [r for r in self._queue if r.due > t + 1e-9]
        for r in due:
            make_room = getattr(self.policies.get(r.receiver), "make_room", None)
            if make_room is not None:
                make_room(t, r.sender)
