"""Gap requests from the SV to a TV in its target lane, and the TV yielding through SUMO.

Two channels carry them (opened by cosim.traffic.world.World for a policy that asks for
gaps, `asks_for_gaps`: the gap policy):
- courtesy (`[traffic] courtesy`, on by default): the traffic's courtesy to a lane
  changer that signals. SUMO's own lane changers get it from SUMO: LC2013's
  `informFollower` asks the blocking follower in the target lane to let them in, and
  the follower's lane-change model honours it (`lcCooperative`, 1 for our TV type,
  SUMO's default). That request travels between SUMO's lane-change models and never
  leaves SUMO for a vehicle moved by moveToXY, so our SV would be the only driver on
  the road nobody makes room for. `COURTESY` restores it: the TV the SV signals to
  is asked at once, always (lcCooperative 1), through the same openGap, braking up to
  `COURTESY_DECEL` (2 m/s^2, a comfortable deceleration) while the SV waits. No radio:
  it holds with perception only.
- cooperative V2V (`[v2v] cooperation`, optional, off by default): a request sent by
  radio, with its own compliance and latency.

The request goes through a channel of its own: each request is honoured with
probability `compliance` (drawn once, when it is sent, from the run's seeded
generator: runs stay reproducible) and reaches the TV `latency` later. A TV that
honours it calls SUMO's `vehicle.openGap` with the SV as reference vehicle: SUMO's
car-following then treats the SV as its leader while it raises its time headway to
`time_headway` and its standstill gap to `space_headway` (the change spread at
`change_rate`, braking at most `max_decel`) and keeps them for `duration` after
reaching them (TraCI's openGap; SUMO_NOTES.md "Cooperation"). This only changes how
the TV follows; who goes where is still the planner's decision. A TV makes room
firmly while the SV waits beside the gap (`max_decel`) and, once the SV moves over,
only holds its speed (`changing_decel`, next to nothing): as SUMO's informed followers
do, the room is made before the change, and the change itself asks nothing more of
a follower that has it. A change planned on the courtesy held (the gap policy's
`GapDecision.held`; the policy's `gaps_held`) moves over while the TV still makes
room: it goes on with `max_decel` until the SV is in its lane, then holds its speed.

The API handle is the SUMO adapter's (`SumoSim.api`): this module does not import
libsumo itself.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from cosim.errors import InputError
from cosim.params import STANDSTILL_SPEED


@dataclass(frozen=True)
class CooperationConfig:
    """What a yielding TV does, and the request channel (SI units)."""

    enabled: bool = False  # the SV sends requests at all
    compliance: float = 1.0  # -, probability that a TV honours a request
    latency: float = 0.1  # s, from the request to the TV's reaction
    time_headway: float = 2.0  # s, the headway the TV opens to the SV
    space_headway: float = 5.0  # m, the standstill gap it opens
    duration: float = 10.0  # s, how long it holds the gap once open
    change_rate: float = 0.5  # 1/s, SUMO's openGap rate of change (fraction per second)
    max_decel: float = 0.5  # m/s^2, the hardest it brakes to open the gap while the SV
    # waits for it (before the SV's change begins) ...
    # tuned: docs/tuned_constants.md
    changing_decel: float = 0.01  # m/s^2, ... and once the SV's change is under way: the
    # braking a TV that still yields may go on with when the SV moves over (re-issued at
    # the change's start): next to nothing, so that it only holds its speed (it does not
    # close in on the SV before SUMO sees the SV in its lane) and asks nothing of a
    # follower that already has room; one that has not brakes for the SV as its own
    # Krauss does once the SV is in its lane (what the policy's entry test predicts).
    # SUMO's dawdling, up to 0.52 m/s^2 a step, comes on top. Released instead, a
    # held-back TV would speed up and then brake hard for the SV.
    # tuned: docs/tuned_constants.md

    def check(self, source: str = "cooperation") -> None:
        """Raise InputError naming the first bad field."""
        if not 0.0 <= self.compliance <= 1.0:
            raise InputError(source, "compliance", self.compliance, "a number in [0, 1]")
        for name in ("latency",):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise InputError(source, name, v, "a finite number >= 0 s")
        for name in ("time_headway", "space_headway", "duration", "change_rate", "max_decel",
                     "changing_decel"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise InputError(source, name, v, "a finite number > 0")


# 1/s, an openGap rate that reaches the target headway in one step: SUMO adds
# rate x step x (target - own) a step, capped at the target (MSVehicle::Influencer)
AT_ONCE = 1e6


def open_gap(api: ModuleType, tv_id: str, sv_id: str, cfg: CooperationConfig,
             changing: bool = False) -> None:
    """Make `tv_id` open a gap behind `sv_id` (SUMO's openGap, the SV as reference),
    braking at most cfg.max_decel, or cfg.changing_decel once the SV is `changing`.
    A request during the change takes the target headway at once: a TV told again
    would otherwise spread it anew from its own (shorter) headway, speed up toward
    the SV for a while and then brake for it."""
    rate, decel = (AT_ONCE, cfg.changing_decel) if changing else (cfg.change_rate,
                                                                  cfg.max_decel)
    api.vehicle.openGap(tv_id, cfg.time_headway, cfg.space_headway, cfg.duration, rate,
                        decel, sv_id)


# the traffic's courtesy to the SV's blinker (module docstring): at once, always honoured
COURTESY_DECEL = 2.0  # m/s^2, the most a TV brakes to let the signalling SV in while it
# waits (before its change begins): a comfortable deceleration (the IDM's b, MOBIL's; the
# gap policy's own GapConfig.comfort_decel), below what SUMO's LC2013 lets its blocking
# followers brake (their decel, 4.5) and what the policy's insisting entry may ask at
# its entry (GapConfig.insist_decel, 4)
# tuned: docs/tuned_constants.md
COURTESY = CooperationConfig(enabled=True, compliance=1.0, latency=0.0,
                             max_decel=COURTESY_DECEL)


@dataclass
class _Request:
    due: float  # s, when it reaches the TV
    tv_id: str
    honoured: bool


def done_yielding(tv_x: NDArray[np.float64], tv_length: NDArray[np.float64],
                  tv_speed: NDArray[np.float64], sv_x: float,
                  sv_length: float) -> NDArray[np.bool_]:
    """Which TVs (centres tv_x, m) can no longer open a gap behind the SV (centre sv_x):
    ahead of it (centre past its centre), or standing level with it (front past its
    rear, slower than STANDSTILL_SPEED). One still rolling level with it is not let go
    (`release`): the SV may be setting off in front of it, and released it would speed
    up beside the SV."""
    x = np.asarray(tv_x, dtype=float)
    level = x + 0.5 * np.asarray(tv_length, dtype=float) > sv_x - 0.5 * sv_length
    return (x > sv_x) | (level & (np.asarray(tv_speed, dtype=float) < STANDSTILL_SPEED))


@dataclass
class CooperationChannel:
    """Requests in flight: `request` sends one, `deliver` applies those that are due,
    `changing` eases the yielding TVs' braking when the SV's change begins, `release`
    ends the yielding of the TVs that got ahead of the SV."""

    cfg: CooperationConfig
    rng: np.random.Generator
    honoured: int = 0  # requests honoured and delivered
    _queue: list[_Request] = field(default_factory=list)
    _asked: set[str] = field(default_factory=set)
    _yielding: set[str] = field(default_factory=set)
    _changing: bool = False  # the SV's change is under way

    def request(self, t: float, tv_id: str) -> bool:
        """Send a request to `tv_id` at time t (once per TV: a repeated request is not
        sent). Returns whether it was sent."""
        if not self.cfg.enabled or tv_id in self._asked:
            return False
        self._asked.add(tv_id)
        honoured = bool(self.rng.random() < self.cfg.compliance)
        self._queue.append(_Request(t + self.cfg.latency, tv_id, honoured))
        return True

    def deliver(self, t: float, api: ModuleType, sv_id: str,
                present: Collection[str] | None = None) -> list[str]:
        """Apply the requests due by time t (a TV no longer in `present`, if given, is
        skipped); returns the ids of the TVs that now yield."""
        if not self._queue:
            return []
        due = [r for r in self._queue if r.due <= t + 1e-9]
        self._queue = [r for r in self._queue if r.due > t + 1e-9]
        yielding = []
        for r in due:  # a handful of requests per run, not a loop over traffic
            if r.honoured and (present is None or r.tv_id in present):
                open_gap(api, r.tv_id, sv_id, self.cfg, self._changing)
                yielding.append(r.tv_id)
        self.honoured += len(yielding)
        self._yielding.update(yielding)
        return yielding

    def changing(self, api: ModuleType, sv_id: str, changing: bool,
                 present: Collection[str]) -> None:
        """Whether the SV's change is under way. At its start, each TV that still yields
        (and is in `present`) is told again, to brake at most `changing_decel` from now
        on (`open_gap`)."""
        if changing and not self._changing and self.cfg.changing_decel != self.cfg.max_decel:
            for tv_id in sorted(self._yielding):  # sorted: the same order every run
                if tv_id in present:
                    open_gap(api, tv_id, sv_id, self.cfg, changing=True)
        self._changing = changing

    def release(self, api: ModuleType, ids: Sequence[str], ahead: NDArray[np.bool_]) -> None:
        """End the yielding of the TVs ahead of the SV or standing level with it (`ids` of
        the TVs present in SUMO, `ahead` true for those: `done_yielding`): openGap keeps
        the SV as their leader, and such a TV would otherwise stop and wait for it, for
        good (it never reaches the gap it is told to open: one asked while the SV stands
        at its stop line would stop level with it, and the SV would find no entry).
        Looks only at the yielding TVs."""
        done = {tv for tv in self._yielding if tv in ids and ahead[ids.index(tv)]}
        for tv_id in sorted(done):  # sorted: the same order every run
            api.vehicle.deactivateGapControl(tv_id)
        self._yielding -= done
