"""The co-simulation loop: our SV (planner + controller + plant) in SUMO traffic.

One step of `dt = scenario.step` (DESIGN.md "One co-simulation step"); at the
top of step k SUMO and the plant are both at t_k = k dt. `CoSimulation.run`
reads top to bottom, one part per job:

1. world (cosim.traffic.world): the vehicles around the SV, one pass, numpy
   arrays; the ego gives the SV's own state (our plant's, or SUMO's),
2. recorder (cosim.recorder): row k of the trace: SV state, reference, errors,
   inputs, our exact overlap check of the SV against every TV, SUMO's
   collisions of the last step, gap / TTC,
3. observer (cosim.observer): this step's V2V messages (scripted TVs: their own),
   through the channel (range, latency, loss), read when the policy plans,
4. policy (cosim.policy): keeping / changing / braking / waiting: a due scripted
   request or the decision rule asks the planner; the re-check of the plan under
   way replans, aborts or brakes; returns the reference to track,
5. ego (cosim.ego): control + plant, `scenario.substeps` substeps from t_k to
   t_k+1 tracking the reference, and the pose to SUMO (moveToXY); the
   SUMO-driven baseline does nothing here,
6. the scripted TVs to their poses at t_k+1,
7. `simulationStep()`: SUMO moves its own vehicles to t_k+1.

Controller "sumo" is the baseline: the SV is an ordinary SUMO vehicle of the
SV's size (`SumoDrivenEgo`); scripted requests become `changeLane` calls, the
decision rule is SUMO's own lane-change model (`SumoDriverPolicy`); the same
trace columns (those SUMO has) and the same metrics.

`run_scenario` runs one scenario and writes trace.csv, plans.csv,
metrics.csv, timing.csv and the figures (cosim.run_output; all atomically, all
but timing.csv byte-identical between two runs of the same scenario and seed).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from cosim.decision import DecisionConfig
from cosim.ego import Ego, PlannedEgo, SumoDrivenEgo
from cosim.gap_policy import GapPolicy
from cosim.observer import Observer, uncertain_config
from cosim.policy import POLICIES, LaneChangePolicy, SumoDriverPolicy, lane_keeping_reference
from cosim.recorder import (  # noqa: F401  (re-exported: the run's columns and records)
    COLUMN,
    METRIC_DOCS,
    PLAN_COLUMNS,
    TIMING_DOCS,
    TRACE_COLUMNS,
    LaneChange,
    Recorder,
    RunResult,
    plan_row,
)
from cosim.scenario import Scenario
from cosim.traffic.cooperation import COURTESY, CooperationChannel, CooperationConfig
from cosim.traffic.gui import GuiSettings
from cosim.traffic.world import SV_ID, Scene, World

ProgressFn = Callable[[int], None]
# [planner] policy -> the lane-change policy of our SV (the paper's, the gap-seeking one)
DRIVERS = {**POLICIES, GapPolicy.name: GapPolicy}
COOPERATION_STREAM = 16  # -, second seed word of the V2V gap requests' generator
COURTESY_STREAM = 17  # -, the same for the traffic's courtesy


def cooperation_channels(sc: Scenario) -> list[CooperationChannel]:
    """The gap requests' channels of a run (cosim.traffic.cooperation): the traffic's
    courtesy (`[traffic] courtesy`) and cooperative V2V (`[v2v] cooperation`); each
    draws from a generator of its own, seeded by the scenario's seed."""
    configs = []
    if sc.traffic.courtesy:
        configs.append((COURTESY_STREAM, COURTESY))
    if sc.v2v.cooperation:
        configs.append((COOPERATION_STREAM, CooperationConfig(
            enabled=True, compliance=sc.v2v.cooperation_compliance,
            latency=sc.v2v.cooperation_latency)))
    return [CooperationChannel(cfg, np.random.default_rng([sc.seed, stream]))
            for stream, cfg in configs]


class CoSimulation:
    """One run of a scenario: the world, the ego, its policy, the observer, the recorder."""

    def __init__(self, scenario: Scenario, *, gui: bool | GuiSettings = False,
                 decision: DecisionConfig | None = None) -> None:
        self.sc = scenario
        self.cfg = decision or DecisionConfig()
        self.dt = scenario.step
        self.n_steps = scenario.n_steps
        self.world = World(scenario, gui=gui)
        self.cooperation: list[CooperationChannel] = []  # gap requests (gap policy)

    def _start(self) -> None:
        """SUMO with its traffic, the scripted TVs, the SV, then the first step that
        inserts them all (the order SUMO sees the vehicles in is part of the result)."""
        sc, world = self.sc, self.world
        road = self.road = world.start()
        ego: Ego
        policy: LaneChangePolicy
        if sc.sv.controller == "sumo":
            self.observer = Observer(sc, road, world, listens=SumoDriverPolicy.listens)
            ego = SumoDrivenEgo(sc, world)
            policy = SumoDriverPolicy(sc, road, self.cfg,
                                      lambda lane: world.sumo.change_lane(SV_ID, lane, 30.0))
        else:
            from cosim.planning.planner import LaneChangePlanner

            self.observer = Observer(sc, road, world)
            y0 = road.lane_center(sc.sv.lane)
            ego = PlannedEgo(sc, world, y0, lane_keeping_reference(
                0.0, world.sv_start_x, y0, sc.sv.speed, 0.0))
            planner = LaneChangePlanner(sc.vehicle, road, uncertain_config(sc))
            blinker = lambda direction: world.sumo.set_blinker(SV_ID, direction)  # noqa: E731
            if sc.planner.policy == GapPolicy.name:
                channels = self.cooperation = cooperation_channels(sc)
                policy = GapPolicy(sc, road, self.cfg, planner, blinker, (
                    lambda t, tv_id: [c.request(t, tv_id) for c in channels]) if channels
                    else None)
            else:
                policy = DRIVERS[sc.planner.policy](sc, road, self.cfg, planner, blinker)
        self.ego, self.policy = ego, policy
        self.recorder = Recorder(self.n_steps, sc.vehicle.length, sc.vehicle.width, road)
        world.insert()
        ego.inserted()

    def run(self, progress: ProgressFn | None = None) -> RunResult:
        wall0 = time.perf_counter()
        cpu0 = time.process_time()
        try:
            self._start()
            world, ego, policy, observer, recorder = (
                self.world, self.ego, self.policy, self.observer, self.recorder)
            for k in range(self.n_steps + 1):
                t = k * self.dt
                everyone = world.read(observer.radius, full=observer.full_scene)
                scene = Scene.around(t, ego.state(everyone), everyone)
                ego.write_trace(recorder.record(k, scene, policy.status(scene.sv)))
                if k == self.n_steps:
                    break
                reference = policy.update(t, scene, observer.inbox(scene))
                if self.cooperation:  # gap requests due reach their TVs
                    tvs, api = scene.tvs, world.sumo.api
                    changing = policy.status(scene.sv).changing
                    ahead = tvs.x > scene.sv.x
                    for channel in self.cooperation:
                        channel.changing(api, SV_ID, changing, tvs.ids)
                        channel.deliver(t, api, SV_ID, tvs.ids)
                        channel.release(api, tvs.ids, ahead)
                ego.advance(t, self.dt, reference)
                observer.move_scripted(t + self.dt)
                recorder.sumo_collisions(world.step())
                if progress is not None:
                    progress(1)
            events = world.events()
        finally:
            self.world.close()
        wall = time.perf_counter() - wall0
        return self._result(wall, time.process_time() - cpu0, events)

    def _result(self, wall: float, cpu: float, events: list[str]) -> RunResult:
        sc, recorder = self.sc, self.recorder
        trace = recorder.trace()
        self.ego.finish_trace(trace)
        done = self.policy.summary(trace["t_s"], trace["y_m"])
        metrics = recorder.metrics(sc, trace, done, plant=self.ego.plant,
                                   tracks_reference=self.ego.tracks_reference,
                                   n_steps=self.n_steps, events=len(events))
        timing = {
            "scenario": sc.name,
            "wall_time_s": wall,
            "wall_sumo_s": self.world.wall,
            "wall_planning_s": self.policy.wall,
            "wall_control_s": self.ego.wall,
            "wall_realtime_factor": float(trace["t_s"][-1]) / wall if wall > 0 else float("nan"),
            "cpu_time_s": cpu,
        }
        return RunResult(sc, self.road, trace, done.plans, done.lane_changes,
                         recorder.tracks.result(), metrics, timing, events,
                         records=self.ego.records, first_plan=done.first_plan)


def run_scenario(
    scenario: Scenario,
    out_dir: Path | None,
    *,
    write_trace: bool = True,
    write_figures: bool = True,
    progress: bool = False,
    gui: bool | GuiSettings = False,
) -> dict[str, Any]:
    """Run one scenario (one libsumo simulation in this process); write its outputs
    into `out_dir` (None: write nothing); return the metrics row merged with the
    wall-time columns (names starting `wall_`)."""
    result = simulate(scenario, progress=progress, gui=gui)
    if out_dir is not None:
        from cosim.run_output import write_outputs

        write_outputs(result, Path(out_dir), write_trace=write_trace,
                      write_figures=write_figures)
    return {**result.metrics, **{k: v for k, v in result.timing.items() if k != "scenario"}}


def simulate(scenario: Scenario, *, progress: bool = False, gui: bool | GuiSettings = False,
             decision: DecisionConfig | None = None) -> RunResult:
    """Run one scenario and return everything it produced (nothing written)."""
    sim = CoSimulation(scenario, gui=gui, decision=decision)
    if not progress:
        return sim.run()
    from cosim.progress import Bar

    # ETA from the rate after the first 5 % of the steps (SUMO's start, the first plan)
    with Bar(sim.n_steps, desc=scenario.name, unit="step", file=sys.stderr,
             leave=False) as bar:
        return sim.run(bar.update)
