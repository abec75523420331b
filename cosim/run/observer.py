"""What the SV knows of the TVs: the V2V channel (or perception), the scripted TVs'
own messages, and the safety margin widened for what the channel does not tell
exactly.

The scripted TVs ([[tv]] in a scenario; the world moves them along their scripts,
cosim.traffic.scripted) publish their planned manoeuvre (`ScriptedTV.message`).
Every other TV is read from SUMO and sent through the channel (range, latency,
loss; or measured with noise in the "perception" mode, scripted TVs included).

Without latency or loss the messages at a planning call are exactly those
published then: the channel runs only when the policy reads its `Inbox` (building
the messages is the costly part); otherwise it runs every step.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from cosim.params import PlannerConfig, RoadParams
from cosim.run.announcements import joining
from cosim.scenario import Scenario
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.world import NEAR_RANGE, SV_ID, Scene, World

if TYPE_CHECKING:
    from cosim.run.announcements import Announcements
    from cosim.traffic.scripted import ScriptedTraffic

UNCERTAIN_CLOSING_SPEED = 5.0  # m/s, closing speed assumed for the V2V latency margin


def uncertain_config(scenario: Scenario) -> PlannerConfig:
    """The planner's settings with the safety margin widened for what V2V does not
    tell exactly ([planner] uncertainty_margin): latency (and the extra age of lost
    messages) times an assumed closing speed, plus, without V2V, two standard
    deviations of the measured position and the speed noise over one second."""
    cfg, v2v = scenario.planner, scenario.v2v
    if not cfg.uncertainty_margin:
        return cfg
    age = v2v.latency + scenario.step * v2v.loss / max(1.0 - v2v.loss, 1e-3)
    extra = age * UNCERTAIN_CLOSING_SPEED
    if v2v.mode == "perception":
        extra += 2.0 * v2v.noise_position + v2v.noise_speed * 1.0
    if extra <= 0.0:
        return cfg
    return replace(cfg, safety_margin=cfg.safety_margin + extra)


class Inbox:
    """The messages the SV has at one step: the channel's (exchanged on the first
    read, or at once when the channel must run every step) and the scripted TVs'."""

    def __init__(self, observer: Observer, scene: Scene) -> None:
        self.observer = observer
        self.scene = scene
        self.received: list[Any] | None = None
        if observer.every_step:
            self.received = observer.exchange(scene)

    def read(self) -> list[Any]:
        if self.received is None:
            self.received = self.observer.exchange(self.scene)
        heard = self.observer.announcements
        received = self.received if heard is None else heard.give_way(
            SV_ID, self.scene.sv.y, self.received)
        return received + self.observer.scripted_messages(self.scene.t)

    def joining(self) -> dict[str, int]:
        """The lane each automated vehicle it hears flies its lane change into, by id
        (none without a fleet)."""
        heard = self.observer.announcements
        if heard is None or not heard.changing_besides(SV_ID):
            return {}
        return joining(heard.road, self.read())


class Observer:
    """The V2V channel of one run and the scripted TVs' messages (see the module
    docstring).

    `listens` False (the SUMO-driven SV never plans): the channel does not run every
    step. `radius` (m) is how far around the SV the world is read each step."""

    def __init__(self, scenario: Scenario, road: RoadParams, world: World,
                 scripted: ScriptedTraffic, *, listens: bool = True) -> None:
        from cosim.traffic.v2v import V2VChannel

        sc = scenario
        self.world = world
        self.v2v = sc.v2v
        self.scripted = scripted
        self.channel = V2VChannel.from_spec(sc.v2v, road, sc.seed)
        v2v = sc.v2v
        every_step = v2v.latency > 0 or v2v.loss > 0 or v2v.mode != "v2v"
        self.every_step = every_step and listens
        # the per-step read covers what the rule, the records and the collision check
        # need; a planning call reads everyone in V2V range once more
        self.radius = (max(NEAR_RANGE, v2v.range) if every_step else NEAR_RANGE) \
            + 2.0 * sc.vehicle.length
        self.read_everyone = not every_step and v2v.range > NEAR_RANGE
        # accelerations and signals each step only when the channel runs each step
        self.full_scene = self.every_step
        # with a fleet: what the automated vehicles announce (cosim.run.announcements)
        self.announcements: Announcements | None = None

    def hear(self, announcements: Announcements) -> None:
        """The automated vehicles' announcements go into the SV's messages."""
        self.announcements = announcements

    def inbox(self, scene: Scene) -> Inbox:
        """This step's messages, for the policy."""
        return Inbox(self, scene)

    def exchange(self, scene: Scene) -> list[Any]:
        """The channel's messages of the TVs around the SV now."""
        everyone = scene.everyone
        if self.read_everyone:
            everyone = self.world.read_all()  # the channel keeps those in range
        elif not self.full_scene:  # the scene's read had no accelerations and signals
            everyone = self.world.read_again(everyone.ids)
        perceived = self.v2v.mode == "perception"  # scripted TVs are measured too
        public = everyone.select(np.array(
            [vid != SV_ID and (perceived or vid not in self.scripted.ids)
             for vid in everyone.ids],
            dtype=bool))
        if perceived and self.scripted.tvs:
            public = self._scripted_accel(public, scene.t)
        heard = self.announcements
        return self.channel.exchange(public, scene.sv.x, scene.sv.y,
                                     None if heard is None else heard.overrides())

    def _scripted_accel(self, snap: TrafficSnapshot, t: float) -> TrafficSnapshot:
        """The snapshot with the scripted TVs' true accelerations: SUMO reports a wrong
        one for vehicles moved by moveToXY (+4 m/s^2 for a TV braking at 8 m/s^2)."""
        accel = np.array(snap.accel, dtype=float)
        for tv, pose in self.scripted.at(t):
            if tv.spec.id in snap.ids:
                accel[snap.index(tv.spec.id)] = pose[4]
        return replace(snap, accel=accel)

    def scripted_messages(self, t: float) -> list[Any]:
        """The scripted TVs' own messages (none in the perception mode: measured)."""
        if self.v2v.mode == "perception":
            return []
        return list(self.scripted.messages(t))
