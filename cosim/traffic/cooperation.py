"""Gap requests from the SV to a TV in its target lane, and the TV yielding through SUMO.

Two channels carry them (both used by the gap policy only; cosim.sim builds them):
- courtesy (`[traffic] courtesy`, on by default): the traffic's courtesy to a lane
  changer that signals. SUMO's own lane changers get it from SUMO: LC2013's
  `informFollower` asks the blocking follower in the target lane to let them in, and
  the follower's lane-change model honours it (`lcCooperative`, 1 for our TV type,
  SUMO's default). That request travels between SUMO's lane-change models and never
  leaves SUMO for a vehicle moved by moveToXY, so our SV would be the only driver on
  the road nobody makes room for. `COURTESY` restores it: the TV the SV signals to
  is asked at once, always (lcCooperative 1), through the same openGap. No radio:
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
the TV follows; who goes where is still the planner's decision.

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
    max_decel: float = 0.3  # m/s^2, the hardest it brakes to open the gap: gently, so
    # that its braking stays near what SUMO's own SV asks of its followers (sample of
    # study_gap: 2.0 gave a follower_max_decel of ~2.5 m/s^2, 0.3 about 0.8, 0.15 about
    # 0.66 but 10/12 lane changes instead of 12/12; docs/gap_driver.md)

    def check(self, source: str = "cooperation") -> None:
        """Raise InputError naming the first bad field."""
        if not 0.0 <= self.compliance <= 1.0:
            raise InputError(source, "compliance", self.compliance, "a number in [0, 1]")
        for name in ("latency",):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise InputError(source, name, v, "a finite number >= 0 s")
        for name in ("time_headway", "space_headway", "duration", "change_rate", "max_decel"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise InputError(source, name, v, "a finite number > 0")


def open_gap(api: ModuleType, tv_id: str, sv_id: str, cfg: CooperationConfig) -> None:
    """Make `tv_id` open a gap behind `sv_id` (SUMO's openGap, the SV as reference)."""
    api.vehicle.openGap(tv_id, cfg.time_headway, cfg.space_headway, cfg.duration,
                        cfg.change_rate, cfg.max_decel, sv_id)


# the traffic's courtesy to the SV's blinker (module docstring): at once, always honoured,
# braking at most 0.1 m/s^2 on top of the TV's own dawdling (SUMO's Krauss, sigma 0.2 x
# accel 2.6 = up to 0.52 m/s^2 a step): sample of study_gap (densities 10-60, 6 seeds),
# measured p95 of the new follower's braking / lane changes of 30: 0.3 -> 0.82 / 29,
# 0.1 -> 0.62 / 29, 0.02 -> 0.54 / 27 (SUMO's own driver: 0.36-1.02 / 30)
COURTESY = CooperationConfig(enabled=True, compliance=1.0, latency=0.0, max_decel=0.1)


@dataclass
class _Request:
    due: float  # s, when it reaches the TV
    tv_id: str
    honoured: bool


@dataclass
class CooperationChannel:
    """Requests in flight: `request` sends one, `deliver` applies those that are due."""

    cfg: CooperationConfig
    rng: np.random.Generator
    sent: int = 0
    honoured: int = 0
    _queue: list[_Request] = field(default_factory=list)
    _asked: set[str] = field(default_factory=set)
    _yielding: set[str] = field(default_factory=set)

    def request(self, t: float, tv_id: str) -> bool:
        """Send a request to `tv_id` at time t (once per TV: a repeated request is not
        sent). Returns whether it was sent."""
        if not self.cfg.enabled or tv_id in self._asked:
            return False
        self._asked.add(tv_id)
        honoured = bool(self.rng.random() < self.cfg.compliance)
        self._queue.append(_Request(t + self.cfg.latency, tv_id, honoured))
        self.sent += 1
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
                open_gap(api, r.tv_id, sv_id, self.cfg)
                yielding.append(r.tv_id)
        self.honoured += len(yielding)
        self._yielding.update(yielding)
        return yielding

    def release(self, api: ModuleType, ids: Sequence[str], ahead: NDArray[np.bool_]) -> None:
        """End the yielding of the TVs now ahead of the SV (`ids` of the TVs present in
        SUMO, `ahead` true for those ahead of it): openGap keeps the SV as their leader,
        and a TV that has got ahead of it would otherwise stop and wait for it, for good
        (it never reaches the gap it is told to open). Looks only at the yielding TVs."""
        done = {tv for tv in self._yielding if tv in ids and ahead[ids.index(tv)]}
        for tv_id in sorted(done):  # sorted: the same order every run
            api.vehicle.deactivateGapControl(tv_id)
        self._yielding -= done

    def forget(self, tv_id: str) -> None:
        """Allow a new request to `tv_id` (after the lane change it was for)."""
        self._asked.discard(tv_id)
