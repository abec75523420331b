"""The co-simulation loop: our SV (planner + controller + plant) in SUMO traffic.

One step of `dt = scenario.step` (DESIGN.md "One co-simulation step"); at the
top of step k SUMO and the plant are both at t_k = k dt. `CoSimulation.run`
reads top to bottom, one part per job:

1. world (cosim.traffic.world): the vehicles around the SV, one pass, numpy
   arrays; the ego gives the SV's own state (our plant's, or SUMO's),
2. recorder (cosim.run.recorder): row k of the trace: SV state, reference, errors,
   inputs, our exact overlap check of the SV against every TV, SUMO's
   collisions of the last step, gap / TTC; the stop rules (cosim.run.stop) say
   whether the run ends with this row,
3. observer (cosim.run.observer): this step's V2V messages (scripted TVs: their own),
   through the channel (range, latency, loss), read when the policy plans,
4. policy (cosim.driving, chosen by name from its registry): when to change lanes
   and, through its manoeuvre, plan / fly / re-check / replan / abort / brake;
   returns the reference to track; then the gap requests it sent reach their TVs
   (cosim.traffic.world: the cooperation channels),
5. ego (cosim.run.ego): control + plant, `scenario.substeps` substeps from t_k to
   t_k+1 tracking the reference, and the pose to SUMO (moveToXY); the
   SUMO-driven baseline does nothing here,
6. the world moves the scripted TVs to their poses at t_k+1,
7. `simulationStep()`: SUMO moves its own vehicles to t_k+1.

Start and end: right after the step that inserts everyone, the SV's speed is
lowered to one it can brake from if its leader is random traffic too close and slow
(`World.start_speed`, SUMO's departSpeed rule), and the policy is built from that speed;
the run ends early by the stop rules (cosim.run.stop): with the row of our check's
first collision onset (`[scenario] on_collision = "stop"`, the default), never
driving on through the TV, or with our SV at the end of a lane that ends.

Controller "sumo" is the baseline: the SV is an ordinary SUMO vehicle of the
SV's size (`SumoDrivenEgo`); scripted requests become `changeLane` calls, the
decision rule is SUMO's own lane-change model (cosim.driving.sumo); the same
trace columns (those SUMO has) and the same metrics.

`run_scenario` runs one scenario and writes trace.csv, plans.csv,
metrics.csv, timing.csv and the figures (cosim.run.outputs; all atomically, all
but timing.csv byte-identical between two runs of the same scenario and seed).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cosim.driving import registry
from cosim.driving.base import DrivingContext, LaneChangePolicy, WorldPorts
from cosim.driving.curve_speed import curve_speed, keep_to
from cosim.driving.following import lane_keeping_reference
from cosim.driving.rule import DecisionConfig
from cosim.errors import check_signals
from cosim.road.road import Road
from cosim.run.ego import Ego, PlannedEgo, SumoDrivenEgo
from cosim.run.encounters import Encounters
from cosim.run.metrics_row import MetricsRow
from cosim.run.observer import Observer, uncertain_config
from cosim.run.recorder import Recorder
from cosim.run.result import RunResult
from cosim.run.stop import StopRules
from cosim.scenario import Scenario
from cosim.scenario.model import OnCollision
from cosim.traffic.gui import GuiSettings
from cosim.traffic.world import SV_ID, Scene, World

if TYPE_CHECKING:
    from cosim.planning.planner import RoadCurve
    from cosim.run.fleet import Fleet

ProgressFn = Callable[[int], None]
SUMO_DRIVES = "sumo"  # the registered policy of the SUMO-driven SV (controller "sumo")


class CoSimulation:
    """One run of a scenario: the world, the ego, its policy, the observer, the recorder."""

    def __init__(self, scenario: Scenario, *, gui: bool | GuiSettings = False,
                 decision: DecisionConfig | None = None,
                 fcd_output: Path | None = None, detector_output: Path | None = None
                 ) -> None:
        self.sc = scenario
        self.cfg = decision or DecisionConfig()
        self.dt = scenario.step
        self.n_steps = scenario.n_steps
        self.world = World(scenario, gui=gui, fcd_output=fcd_output,
                           detector_output=detector_output)

    def _start(self) -> None:
        """SUMO with its traffic, the scripted TVs, the SV, then the first step that
        inserts them all (the order SUMO sees the vehicles in is part of the result)."""
        sc = self.sc = self.sc.in_tracks(self.world.sv_start_track)
        world = self.world
        road = self.road = world.start()
        sumo_drives = sc.sv.controller == "sumo"
        self.curve_speed = math.inf  # m/s, the SV's curve speed (cosim.driving.curve_speed)
        if world.route_road.curved and not sumo_drives:  # SUMO's driver takes curves at will
            kappa, d_abs = world.route_road.curvature_bound()
            self.curve_speed = curve_speed(kappa, d_abs, road.mu, sc.sv.curve_lat_accel)
            if self.curve_speed < max(sc.sv.speed, sc.sv.desired_speed or 0.0,
                                      *(hi for _, hi in road.speed_bands)):
                sc, road = keep_to(sc, road, self.curve_speed)
                self.sc, self.road = sc, road
        cls = registry.policy_class(SUMO_DRIVES if sumo_drives else sc.planner.policy)
        scripted = world.add_scripted(road)
        self.observer = Observer(sc, road, world, scripted, listens=cls.listens)
        ego: Ego
        planner = None
        y0 = road.lane_center(sc.sv.lane)
        if sumo_drives:
            ego = SumoDrivenEgo(sc, world)
        else:
            from cosim.planning.planner import LaneChangePlanner

            ego = PlannedEgo(sc, world, y0, lane_keeping_reference(
                0.0, world.sv_start_x, y0, sc.sv.speed, 0.0))
            planner = LaneChangePlanner(sc.vehicle, road, uncertain_config(sc),
                                        prediction=cls.prediction,
                                        curve=road_curve(world.route_road, sc))
        self.recorder = Recorder(self.n_steps, sc.vehicle.length, sc.vehicle.width, road,
                                 route_road=world.route_road)
        self.stop = StopRules(road, sc.vehicle.length, self.dt, self.n_steps,
                              on_collision=sc.on_collision == OnCollision.STOP,
                              at_lane_ends=ego.tracks_reference)
        world.insert()
        ego.inserted()
        # the SV starts at a speed it can brake from for the random traffic ahead (SUMO's
        # departSpeed rule, `World.start_speed`); the policy is built from that speed
        sumo_traffic = sc.traffic.density > 0 or sc.demand is not None
        v0 = world.start_speed(sc.sv.speed, road.mu) if sumo_traffic else sc.sv.speed
        if v0 < sc.sv.speed:
            keep = sc.sv.desired_speed if (sc.sv.desired_speed or sc.sv.decision) else sc.sv.speed
            sc = self.sc = replace(sc, sv=replace(sc.sv, speed=v0, desired_speed=keep))
            ego.start_speed(v0, lane_keeping_reference(0.0, world.sv_start_x, y0, v0, 0.0))
        if cls.asks_for_gaps:
            world.open_gap_requests()
        self.fleet: Fleet | None = None  # automated vehicles besides the SV ([fleet])
        blinker, ask_gap = world.set_sv_blinker, world.ask_gap
        if sc.fleet.enabled:
            from cosim.planning.planner import LaneChangePlanner
            from cosim.run.fleet import Fleet

            self.fleet = Fleet(sc, world, road, cls, self.cfg, self.observer, partial(
                LaneChangePlanner, sc.vehicle, road, uncertain_config(sc),
                prediction=cls.prediction, curve=road_curve(world.route_road, sc)))
            # the SV announces its intention to the AVs and asks them for room as they do
            blinker = self.fleet.announcements.blinker(SV_ID, blinker)
            ask_gap = self.fleet.requests.port(SV_ID, ask_gap)
        ports = WorldPorts(blinker=blinker, change_lane=world.change_sv_lane,
                           ask_gap=ask_gap)
        policy: LaneChangePolicy = cls(DrivingContext.of(
            sc, road, decision=self.cfg, planner=planner, ports=ports,
            notice=0.0 if self.fleet is None else self.fleet.notice))
        self.ego, self.policy = ego, policy
        if self.fleet is not None:  # an AV may ask the SV for room
            self.fleet.requests.policies[SV_ID] = policy
        # our exact TTC / PET for every automated vehicle, beside SUMO's SSM device
        self.encounters = Encounters(sc.ssm) if (
            self.fleet is not None and self.world.measures.ssm is not None) else None

    def run(self, progress: ProgressFn | None = None) -> RunResult:
        wall0 = time.perf_counter()
        cpu0 = time.process_time()
        try:
            self._start()
            world, ego, policy, observer, recorder, stop, fleet = (
                self.world, self.ego, self.policy, self.observer, self.recorder, self.stop,
                self.fleet)
            for k in range(self.n_steps + 1):
                check_signals()  # a signal ends the run here, between two steps
                t = k * self.dt
                everyone = world.read(observer.radius, full=observer.full_scene)
                scene = Scene.around(t, ego.state(everyone), everyone)
                ego.write_trace(recorder.record(k, scene, policy.status(scene.sv)))
                if fleet is not None:  # the AVs' rows k (cosim.run.fleet)
                    fleet.observe(k, t)
                    if self.encounters is not None:  # our TTC / PET of every AV and the SV
                        self.encounters.observe(
                            world.read_all() if fleet.everyone is None else fleet.everyone,
                            fleet.automated())
                if k == self.n_steps or stop.stops(k, scene.sv, recorder.first_collision):
                    break  # the end, or a stop rule (cosim.run.stop)
                reference = policy.update(t, scene, observer.inbox(scene))
                if world.gap_requests:  # gap requests due reach their TVs
                    world.deliver_gap_requests(t, scene.tvs, scene.sv.x,
                                               not policy.gaps_held(scene.sv))
                ego.advance(t, self.dt, reference)
                if fleet is not None:  # the SV's broadcast; the AVs' policies and loops
                    fleet.announcements.flying(SV_ID, reference)
                    fleet.decide(t)
                    fleet.advance(t, self.dt)
                world.move_scripted(t + self.dt)
                recorder.sumo_collisions(world.step())
                if fleet is not None:  # their SUMO collisions; the next takeovers
                    fleet.stepped(k + 1)
                if progress is not None:
                    progress(1)
            events = world.events()
        finally:
            self.world.close()
        wall = time.perf_counter() - wall0
        return self._result(wall, time.process_time() - cpu0, events)

    def _result(self, wall: float, cpu: float, events: list[str]) -> RunResult:
        sc, recorder, ego = self.sc, self.recorder, self.ego
        trace = recorder.trace(self.stop.last_row)
        ego.finish_trace(trace)
        done = self.policy.summary(trace["t_s"], trace["d_m"])  # d: across the road
        metrics = MetricsRow(self.road, sc.vehicle.length, recorder.tracks,
                             self.world.route_road).row(
            sc, trace, done, recorder, self.stop, plant=ego.plant,
            tracks_reference=ego.tracks_reference, events=len(events),
            vehicles=(len(self.world.placed), self.world.inserted),
            curve_speed=self.curve_speed)
        timing = {
            "scenario": sc.name,
            "wall_time_s": wall,
            "wall_sumo_s": self.world.wall,
            "wall_planning_s": self.policy.wall,
            "wall_control_s": ego.wall,
            "wall_realtime_factor": float(trace["t_s"][-1]) / wall if wall > 0 else float("nan"),
            "cpu_time_s": cpu,
        }
        detectors = self.world.measures.detector_table(self.world.t_warmup)
        if detectors is not None:  # the traffic's flow, density, speed and waves
            from cosim.traffic.traffic_measures import traffic_columns

            metrics.update(traffic_columns(detectors, sc.detectors.measure_from))
        fleet = None if self.fleet is None else self.fleet.result(self.stop.last_row)
        if fleet is not None:  # the fleet's aggregates (cosim.run.fleet)
            metrics.update(fleet.metrics())
        conflicts = self.world.measures.conflict_table(self.world.t_warmup)
        if conflicts is not None:  # SUMO's surrogate safety measures ([ssm] enabled)
            from cosim.traffic.ssm import conflict_counts

            metrics.update(conflict_counts(conflicts))
            if self.world.measures.distance is not None:
                metrics.update(self.world.measures.distance.columns())
        return RunResult(sc, self.road, trace, done.plans, done.lane_changes,
                         recorder.tracks.result(), metrics, timing, events,
                         records=ego.records, first_plan=done.first_plan,
                         edges=tuple(recorder.edges), route_road=self.world.route_road,
                         detectors=detectors, conflicts=conflicts,
                         fleet_conflicts=None if self.encounters is None
                         else self.encounters.table(),
                         t_warmup=self.world.t_warmup, fleet=fleet)


def road_curve(route_road: Road, sc: Scenario) -> RoadCurve | None:
    """The planner's bound on the road frame's bending (None: a straight road)."""
    from cosim.planning.planner import RoadCurve
    from cosim.traffic.sumo import TV_LENGTH, TV_WIDTH

    if not route_road.curved:
        return None
    kappa, d_abs = route_road.curvature_bound()
    top = max(max(hi for _, hi in sc.road.speed_bands), sc.sv.speed, sc.sv.desired_speed or 0.0)
    return RoadCurve(kappa, d_abs, top, 0.5 * math.hypot(TV_LENGTH, TV_WIDTH))


def run_scenario(
    scenario: Scenario,
    out_dir: Path | None,
    *,
    write_trace: bool = True,
    write_figures: bool = True,
    progress: bool = False,
    gui: bool | GuiSettings = False,
    fcd: bool = False,
    figure_format: str | None = None,
) -> dict[str, Any]:
    """Run one scenario (one libsumo simulation in this process); write its outputs
    into `out_dir` (None: write nothing); return the metrics row merged with the
    wall-time columns (names starting `wall_`). `fcd`: SUMO's floating-car data of the
    run goes into `out_dir` as fcd.xml, written by SUMO into a temporary folder and
    moved in with the other outputs (an interrupted or failed run leaves none); so do
    the outputs of SUMO's detectors (`[detectors] enabled`), read into detectors.csv.
    `figure_format`: png (default), svg or pdf."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="cosim-fcd-") as tmp:
        fcd_path = Path(tmp) / "fcd.xml" if fcd and out_dir is not None else None
        # (the detectors also without `out_dir`: their measures are metrics columns)
        result = simulate(scenario, progress=progress, gui=gui, fcd_output=fcd_path,
                          detector_output=Path(tmp))
        if out_dir is not None:
            from cosim.run.outputs import write_outputs

            write_outputs(result, Path(out_dir), write_trace=write_trace,
                          write_figures=write_figures, figure_format=figure_format,
                          extra_files=() if fcd_path is None else (fcd_path,))
    return {**result.metrics, **{k: v for k, v in result.timing.items() if k != "scenario"}}


def simulate(scenario: Scenario, *, progress: bool = False, gui: bool | GuiSettings = False,
             decision: DecisionConfig | None = None, fcd_output: Path | None = None,
             detector_output: Path | None = None) -> RunResult:
    """Run one scenario and return everything it produced (nothing written but SUMO's
    `fcd_output` and, with `[detectors] enabled`, its detectors' outputs into the folder
    `detector_output`, when given: RunResult.detectors their table)."""
    sim = CoSimulation(scenario, gui=gui, decision=decision, fcd_output=fcd_output,
                       detector_output=detector_output)
    if not progress:
        return sim.run()
    import contextlib

    from cosim.progress import Bar

    with contextlib.ExitStack() as bars:
        def warmup_bar(steps: int) -> ProgressFn:
            """The warm-up's own bar (the run's stays at 0 meanwhile), gone when it ends."""
            bar = bars.enter_context(Bar(steps, desc=f"{scenario.name} warm-up",
                                         unit="step", file=sys.stderr, leave=False))

            def count(n: int) -> None:
                bar.update(n)
                if bar.n >= steps:
                    bar.close()
            return count

        sim.world.warmup_progress = warmup_bar
        # ETA from the rate after the first 5 % of the steps (SUMO's start, the first plan)
        bar = bars.enter_context(Bar(sim.n_steps, desc=scenario.name, unit="step",
                                     file=sys.stderr, leave=False))
        return sim.run(bar.update)
