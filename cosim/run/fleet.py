"""The fleet: automated vehicles (AVs) besides the SV, each a full SV of its own.

`[fleet]` (cosim.scenario.model.FleetSpec) says which vehicles SUMO inserts during the
run are automated: each with probability `share`, drawn from a generator of the run's
seed in SUMO's insertion order, and every vehicle of the vTypes `vtypes`. An AV whose
route runs to the end of the scenario's route (the route's road and frame are then its
own) is taken over (`World.take_over`: out of SUMO's control, moved by moveToXY) once it
has driven TAKEOVER_CLEARANCE from where SUMO inserted it, and gets the scenario's
driver: a closed loop of the scenario's plant and controller (`cosim.run.ego.PlannedEgo`),
the scenario's policy and planner with the SV's settings (but no scripted requests: it
decides its lane changes by the decision rule, wanting its lane's limit), a V2V channel
of its own and a recorder of its own (the trace columns, our exact overlap check, SUMO's
collisions). Near the route's end (HANDBACK_DISTANCE), never during a lane change, SUMO
drives it again to its arrival (`World.hand_back`).

Per step the loop calls `observe` (one read of the whole road; each AV's scene is a
selection of it; its trace row), `decide` (the policies; one keeping its lane holds its
last decision until its cadence or an event asks for a new one: cosim.driving.cadence),
`advance` (the closed loops, the poses to SUMO) and, after SUMO's step, `stepped`
(SUMO's collisions, the takeovers).
`result` gives the fleet's trace and plans rows (with the SV's: trace.csv's and
plans.csv's `vehicle_id`), fleet.csv's rows, one per AV, and metrics.csv's fleet columns.

`[fleet] driver` other than `cosim` is a baseline (cosim.run.fleet_watch): the same
drawn vehicles, at the same takeover, left to SUMO (marked; with `acc` / `cacc` their
vType switched to SUMO's ACC / CACC model) and measured alike: no trace rows, fleet.csv's
rows and the metrics from SUMO's snapshot.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np

from cosim.driving.base import DrivingContext, LaneChangePolicy, PolicyStatus, WorldPorts
from cosim.driving.cadence import CadenceConfig
from cosim.driving.following import lane_keeping_reference
from cosim.driving.rule import DecisionConfig
from cosim.run.announcements import Announcements, GapRequests, joining, notice
from cosim.run.ego import PlannedEgo
from cosim.run.fleet_watch import COSIM, FleetWatch
from cosim.run.metrics import longitudinal_comfort
from cosim.run.recorder import Recorder
from cosim.scenario import Scenario
from cosim.traffic.road_view import stretch
from cosim.traffic.sumo import TrafficSnapshot
from cosim.traffic.takeover import Takeovers
from cosim.traffic.world import SV_ID, Scene, World

if TYPE_CHECKING:
    from cosim.params import RoadParams
    from cosim.run.observer import Observer
    from cosim.traffic.cooperation import CooperationChannel
    from cosim.traffic.v2v import Shared, V2VChannel

FLEET_STREAM = 18  # -, second seed word of the fleet's draws (world.COURTESY_STREAM + 1)
V2V_STREAM = 19  # -, the same for the AVs' V2V channels (third word: the AV's number)
REQUEST_STREAM = 20  # -, the same for the loss of gap requests between automated vehicles
# m an automated vehicle drives from where SUMO inserted it before it is taken over: SUMO
# inserts only by the lane a vehicle is on, so one may appear in the lane a vehicle just
# inserted beside it is moving into, unseen when that change was planned; past this the
# inflow's next vehicles appear behind, in sight (V2V, the planner's scene)
TAKEOVER_CLEARANCE = 100.0
HANDBACK_DISTANCE = 150.0  # m before the route's end: an AV keeping its lane goes to SUMO
HANDBACK_LAST = 40.0  # m before it: handed back whatever it does (moveToXY past the
# route's end would take it off the network)

FLEET_COLUMNS: dict[str, str] = {
    "vehicle_id": "SUMO id of the automated vehicle",
    "vtype": "its SUMO vType",
    "inserted_t_s": "time SUMO inserted it (after the step that did) (s)",
    "taken_over_t_s": "time it was taken over, TAKEOVER_CLEARANCE m on (its first trace "
                      "row) (s)",
    "end_t_s": "time of its last trace row (s)",
    "end": "handed_back (to SUMO near the route's end) or running (at the run's end)",
    "s_start_m": "arc length s along the route at the takeover (m)",
    "s_end_m": "arc length s at its last row (m)",
    "mean_speed_mps": "mean speed over its rows (m/s)",
    "lane_changes": "lane changes it adopted (planned and flown)",
    "collisions": "collision onsets by our exact check, with anyone",
    "caused_collisions": "of them, those it caused (changing lanes, or hitting a vehicle ahead)",
    "sumo_collisions": "collision events SUMO reported involving it (onsets)",
    "gap_min_m": "smallest along-lane gap to a vehicle sharing its strip (m; inf: none)",
    "ttc_min_s": "smallest along-lane time-to-collision (s; inf: none)",
    "teleported": "1 if SUMO teleported it (never, for a vehicle under our control), else 0",
    "driver": "who drove it ([fleet] driver): cosim, or SUMO's sumo / acc / cacc (a "
              "baseline: its rows from SUMO's snapshot; collisions and caused_collisions "
              "then SUMO's, caused: SUMO's collider; lane_changes its lane changes in "
              "SUMO; gap_min_m and ttc_min_s NaN)",
    "max_long_jerk_mps3": "its peak abs(d(ax)/dt) between steps (m/s^3; cosim: the plant's ax "
                          "of its trace rows; a baseline: SUMO's acceleration)",
    "follower_max_decel_mps2": "its new followers' braking: at each of its lane changes "
                               "(the step its lane in SUMO changed) the nearest vehicle "
                               "behind it on its new lane, if SUMO drives it and it keeps "
                               "that lane (not changing lanes itself then); that vehicle's "
                               "largest deceleration (SUMO's) within 5 s while it stays the "
                               "follower and keeps its lane (m/s^2; NaN: no change, or no "
                               "such follower)",
}


FLEET_METRIC_DOCS: dict[str, str] = {
    "fleet_vehicles": "automated vehicles taken over (fleet.csv's rows)",
    "fleet_handed_back": "of them, those handed back to SUMO near the route's end",
    "fleet_lane_changes": "lane changes the automated vehicles adopted, summed",
    "fleet_collisions": "their collision onsets by our exact check, summed (one between two "
                        "automated vehicles counts twice)",
    "fleet_caused_collisions": "of them, those an automated vehicle caused",
    "fleet_sumo_collisions": "collision events SUMO reported involving an automated vehicle, "
                             "summed",
    "fleet_teleported": "automated vehicles SUMO teleported",
    "fleet_mean_speed_mps": "mean speed of the automated vehicles over all their rows (m/s)",
    "fleet_max_long_jerk_mps3": "median over the automated vehicles of each one's peak "
                                "jerk (fleet.csv's max_long_jerk_mps3; m/s^3)",
    "fleet_follower_max_decel_mps2": "the largest of fleet.csv's follower_max_decel_mps2: "
                                     "a new follower's hardest braking after an automated "
                                     "vehicle's lane change (the vehicle behind it on its "
                                     "new lane at the change, keeping that lane; m/s^2; "
                                     "NaN: none)",
}


@dataclass
class FleetResult:
    """What the fleet produced: each AV's trace rows (cosim.run.outputs writes them into
    trace.csv with the SV's) and fleet.csv's rows."""

    traces: list[tuple[str, dict[str, Any], tuple[str, ...]]]  # (id, trace, its edges)
    rows: list[dict[str, Any]]
    plans: list[dict[str, Any]]  # every AV's plans.csv rows, each with its vehicle_id
    # the baselines' rows of SUMO's snapshot (no trace rows): (sum of speeds m/s, rows)
    baseline_speed: tuple[float, int] = (0.0, 0)

    def metrics(self) -> dict[str, Any]:
        """metrics.csv's fleet columns (FLEET_METRIC_DOCS)."""
        rows = self.rows
        steps = sum(len(trace["t_s"]) for _, trace, _ in self.traces) + self.baseline_speed[1]
        speed = sum(float(trace["vx_mps"].sum()) for _, trace, _ in self.traces) \
            + self.baseline_speed[0]
        jerk = np.array([r["max_long_jerk_mps3"] for r in rows], dtype=float)
        follower = np.array([r["follower_max_decel_mps2"] for r in rows], dtype=float)
        return {
            "fleet_vehicles": len(rows),
            "fleet_handed_back": sum(r["end"] == "handed_back" for r in rows),
            "fleet_lane_changes": sum(r["lane_changes"] for r in rows),
            "fleet_collisions": sum(r["collisions"] for r in rows),
            "fleet_caused_collisions": sum(r["caused_collisions"] for r in rows),
            "fleet_sumo_collisions": sum(r["sumo_collisions"] for r in rows),
            "fleet_teleported": sum(r["teleported"] for r in rows),
            "fleet_mean_speed_mps": speed / steps if steps else float("nan"),
            "fleet_max_long_jerk_mps3": float(np.nanmedian(jerk)) if np.isfinite(jerk).any()
            else float("nan"),
            "fleet_follower_max_decel_mps2": float(np.nanmax(follower))
            if np.isfinite(follower).any() else float("nan"),
        }

def _ask_gap(channels: list[CooperationChannel], t: float, tv_id: str) -> bool:
    """An AV's ask_gap port: the request sent through its channels; whether any."""
    for channel in channels:
        channel.request(t, tv_id)
    return bool(channels)


class AutomatedEgo(PlannedEgo):
    """An AV's closed loop: PlannedEgo started where SUMO had the vehicle at its takeover."""

    keeps_records = False  # a fleet's StepRecords would be many (the trace has them)

    def __init__(self, sc: Scenario, world: World, vehicle_id: str,
                 pose: tuple[float, float, float], speed: float, t0: float,
                 reference: Any) -> None:
        from cosim.control.closed_loop import ClosedLoop, LoopConfig
        from cosim.vehicle.plant import PlantStart

        self.vehicle_id = vehicle_id
        self.plant = sc.sv.plant
        self.substeps = sc.substeps
        self.world = world
        self.wall = 0.0
        s, d, heading = pose
        cx, cy, ch, q = world.cartesian(s, d, heading)
        yaw_rate = speed * float(world.frame.curvature(s))
        self.loop = ClosedLoop(LoopConfig(sc.sv.plant, sc.sv.controller), sc.vehicle, sc.gains,
                               sc.road.mu, PlantStart(cx, cy, ch, speed * q, yaw_rate=yaw_rate),
                               frame=world.frame)
        self.loop.set_reference(reference)
        self.record = self.loop.record(t0)
        self.records: list[Any] = []

    def moved(self, record: Any) -> None:
        """Its closed loop's record at the end of a step (the fleet's LoopBatch advanced
        it): its pose to SUMO."""
        self.record = r = record
        self.world.move_xy(self.vehicle_id, r.x, r.y, r.heading, r.vx, r.ax,
                           road_pose=self.loop.road_pose)


class AVInbox:
    """An AV's V2V messages at one step (cosim.run.observer.Inbox for an AV): the
    channel's, of everyone on the road but itself (the automated vehicles' with their
    announcements, those that give way to it without their intention), and the
    scripted TVs'."""

    def __init__(self, av: AutomatedVehicle, scene: Scene, heard: Announcements,
                 shared: Shared | None = None) -> None:
        """`shared`: the messages built this step for the other AVs (v2v.messages)."""
        self.av, self.scene, self.heard, self.shared = av, scene, heard, shared
        self.received: list[Any] | None = None
        if av.every_step:
            self.received = self._exchange()

    def _exchange(self) -> list[Any]:
        av, scene = self.av, self.scene
        everyone = scene.everyone
        perceived = av.observer.v2v.mode == "perception"
        scripted = av.observer.scripted.ids
        public = everyone.select(np.array(
            [vid != av.id and (perceived or vid not in scripted) for vid in everyone.ids],
            dtype=bool))
        return av.channel.exchange(public, scene.sv.x, scene.sv.y, self.heard.overrides(),
                                   self.shared)

    def read(self) -> list[Any]:
        if self.received is None:
            self.received = self._exchange()
        return (self.heard.give_way(self.av.id, self.scene.sv.y, self.received)
                + self.av.observer.scripted_messages(self.scene.t))

    def joining(self) -> dict[str, int]:
        """The lane each automated vehicle it hears flies its lane change into, by id."""
        if not self.heard.changing_besides(self.av.id):
            return {}
        return joining(self.heard.road, self.read())


@dataclass
class AutomatedVehicle:
    """One AV: its closed loop, policy, recorder, channel, and its rows."""

    id: str
    vtype: str
    ego: AutomatedEgo
    policy: LaneChangePolicy
    recorder: Recorder
    channel: V2VChannel
    observer: Observer
    every_step: bool  # the channel runs every step (latency, loss, perception)
    k0: int  # its first trace row
    inserted: float  # s, when SUMO inserted it
    k_end: int = -1  # its last trace row (-1: still driving)
    end: str = "running"
    status: PolicyStatus | None = None
    scene: Scene | None = None
    reference: Any = None
    hold: Callable[[float, Scene], Any] | None = None  # the policy's `hold`, if it has one
    gaps: list[CooperationChannel] = field(default_factory=list)  # its gap requests


class Fleet:
    """The AVs of one run (module docstring)."""

    def __init__(self, sc: Scenario, world: World, road: RoadParams, policy_class: Any,
                 decision: DecisionConfig, observer: Observer,
                 planner: Callable[[], Any]) -> None:
        """`planner` makes a planner for one AV (the SV's kind)."""
        self.sc, self.world, self.road = sc, world, road
        self.takeovers = Takeovers(world)
        self.cls, self.decision, self.observer = policy_class, decision, observer
        self.make_planner = planner
        self.spec = sc.fleet
        self.rng = np.random.default_rng([sc.seed, FLEET_STREAM])
        rr = world.route_road
        self.last_edge = rr.route.edges[-1]
        self.edges = rr.edge_ids
        self.route_end = max(lane.end for lane in rr.lanes)  # m, s where the route ends
        self.active: list[AutomatedVehicle] = []
        from cosim.control.loop_batch import LoopBatch

        self.loops = LoopBatch()  # their closed loops, stepped in one call
        self.done: list[AutomatedVehicle] = []
        self.drawn = 0  # vehicles SUMO inserted during the run (each drawn once)
        # drawn automated, not yet TAKEOVER_CLEARANCE on: id -> (vType, s m and t s at
        # insertion)
        self.pending: dict[str, tuple[str, float, float]] = {}
        self.declined = 0  # drawn automated, but their route leaves the SV's
        v2v = sc.v2v
        self.every_step = (v2v.latency > 0 or v2v.loss > 0 or v2v.mode != "v2v") \
            and policy_class.listens
        self.everyone: TrafficSnapshot | None = None
        # what every automated vehicle (the SV too) broadcasts (cosim.run.announcements)
        self.announcements = Announcements(road)
        observer.hear(self.announcements)
        # s, how long each automated vehicle (the SV too) signals before it changes lanes
        self.notice = notice(v2v.latency, v2v.loss, sc.step) if v2v.mode == "v2v" else 0.0
        # every fleet vehicle in SUMO's snapshot (its followers: those SUMO drives)
        self.watch = FleetWatch(sc.step, (SV_ID, *observer.scripted.ids))
        # gap requests between automated vehicles, over V2V (none in the perception mode)
        self.requests = GapRequests(v2v.latency, v2v.loss,
                                    np.random.default_rng([sc.seed, REQUEST_STREAM]),
                                    enabled=v2v.mode == "v2v")

    # ------------------------------------------------------------------ the step
    def observe(self, k: int, t: float) -> None:
        """Row k of every AV; those near the route's end handed back to SUMO."""
        self.announcements.t = t  # a blinker set from now on begins at t
        self.everyone = None
        if not self.active and not self.watch.active:
            return
        everyone = self.everyone = self.world.read_all()  # once for all: each scene is a
        # selection of it
        self.watch.observe(t, everyone)
        for vid in self.watch.ending(self.route_end, HANDBACK_DISTANCE, HANDBACK_LAST):
            self.watch.finish(vid, k, "handed_back")  # a baseline: left to SUMO alone
        handed: list[AutomatedVehicle] = []
        active = self.active
        scenes = Scene.around_all(t, [av.ego.state(everyone) for av in active], everyone,
                                  [av.id for av in active])
        for av, scene in zip(active, scenes, strict=True):
            sv = scene.sv
            status = av.status = av.policy.status(sv)
            av.scene = scene
            av.ego.write_trace(av.recorder.record(k, scene, status))
            left = self.route_end - sv.x
            if left <= HANDBACK_LAST or (left <= HANDBACK_DISTANCE and not status.changing):
                handed.append(av)
        for av in handed:
            self.takeovers.hand_back(av.id)
            self._finish(av, k, "handed_back")

    def decide(self, t: float) -> None:
        """Each AV's policy: the reference it tracks from t, broadcast at once (an AV
        deciding after it in this step hears it as a zero-latency channel would); its last
        decision held while it keeps its lane and nothing changes (cosim.driving.cadence)."""
        heard = self.announcements
        self.requests.deliver(t)  # gap requests between automated vehicles due now
        # every AV's scene is a selection of one snapshot, and their channels share the
        # fleet's road: a vehicle's message is built once for all of them
        shared: Shared = {}
        for av in self.active:
            scene = av.scene
            assert scene is not None
            inbox = AVInbox(av, scene, heard, shared)  # the channel runs every step when it
            # must
            held = av.hold(t, scene) if av.hold is not None else None
            av.reference = held if held is not None else av.policy.update(t, scene, inbox)
            heard.flying(av.id, av.reference)
            if av.gaps:  # its gap requests due reach their TVs
                sv = av.scene.sv
                self.takeovers.deliver_gap_requests(av.gaps, av.id, t, av.scene.tvs, sv.x,
                                                    not av.policy.gaps_held(sv))

    def advance(self, t: float, dt: float) -> None:
        """The AVs' closed loops from t to t + dt in one compiled call (LoopBatch), their
        poses to SUMO."""
        active = self.active
        records = self.loops.advance(t, dt, self.sc.substeps,
                                     [(av.ego.loop, av.reference) for av in active])
        for av, record in zip(active, records, strict=True):
            av.ego.moved(record)

    def stepped(self, k: int) -> None:
        """After SUMO's step to row k: its collisions of the AVs; the vehicles it
        inserted in that step drawn; those drawn automated taken over (their first row:
        k) once TAKEOVER_CLEARANCE m past where they were inserted."""
        if self.active or self.watch.active:
            events = self.takeovers.collision_events()
            self.watch.collided(events)
            pairs = {tuple(sorted(p)) for p in events}
            for av in self.active:
                av.recorder.sumo_collisions({p for p in pairs if av.id in p})
        departed = self.takeovers.departed()
        if departed:
            self._draw(departed, k * self.sc.step)
        if self.pending:
            self._take_over_clear(k)

    def _draw(self, departed: tuple[str, ...], t: float) -> None:
        """Which of the vehicles SUMO just inserted are automated (one draw each, in its
        insertion order); those whose route runs to the route's end on its road wait
        for their takeover in `pending`."""
        draws = self.rng.random(len(departed))
        self.drawn += len(departed)
        vtypes = self.spec.vtypes
        world, takeovers = self.world, self.takeovers
        for vid, u in zip(departed, draws.tolist(), strict=True):
            vtype = takeovers.vtype_of(vid)
            if not (u < self.spec.share or vtype in vtypes) or self._full():
                continue
            route = takeovers.route_of(vid)
            if not route or route[-1] != self.last_edge or not set(route) <= self.edges:
                self.declined += 1
                continue
            snap = world.read_again((vid,))
            self.pending[vid] = (vtype, float(snap.x[0]), t)

    def _full(self) -> bool:
        """As many AVs drive or wait for their takeover as `[fleet] max_vehicles`."""
        cap = self.spec.max_vehicles
        if cap is None:
            return False
        # a baseline's vehicles (SUMO drives them) count as its AVs
        baselines = sum(w.baseline for w in self.watch.active.values())
        return len(self.active) + baselines + len(self.pending) >= cap

    def _take_over_clear(self, k: int) -> None:
        """The pending vehicles TAKEOVER_CLEARANCE m past their insertion, on one of the
        route's tracks, taken over."""
        everyone = self.world.read_all()
        index = {vid: i for i, vid in enumerate(everyone.ids)}
        for vid, (vtype, s0, t_in) in list(self.pending.items()):
            i = index.get(vid)
            if i is None:  # gone (its route ended, or SUMO took it off)
                del self.pending[vid]
                self.declined += 1
                continue
            if everyone.x[i] - s0 < TAKEOVER_CLEARANCE or everyone.lane[i] < 0 \
                    or everyone.lateral_speed[i] != 0.0:  # not during SUMO's lane change
                continue
            del self.pending[vid]
            self._take_over(vid, vtype, k, t_in, everyone.select(np.arange(len(everyone)) == i))

    def _take_over(self, vid: str, vtype: str, k: int, t_in: float,
                   snap: TrafficSnapshot) -> None:
        """The vehicle `vid` (its row of the road's snapshot `snap`) as an AV from row k."""
        world, sc = self.world, self.sc
        baseline = self.spec.driver != COSIM
        self.watch.add(vid, vtype, k, t_in, baseline=baseline)
        if baseline:  # SUMO drives it on, marked (with its ACC / CACC model)
            self.takeovers.drive_as(vid, self.spec.driver)
            return
        track = int(snap.lane[0])
        t = k * sc.step
        speed = self.takeovers.take_over(vid, (sc.vehicle.length, sc.vehicle.width))
        s, d, rel = float(snap.x[0]), float(snap.y[0]), float(snap.heading[0])
        q = float(stretch(world.frame, s, d))
        v = speed / q  # m/s along s
        y0 = self.road.lane_center(track)
        ego = AutomatedEgo(sc, world, vid, (s, d, rel), v, t,
                           lane_keeping_reference(t, s, y0, v, 0.0))
        self.loops.add(ego.loop)
        av_sc = driver_scenario(sc, track, v)
        number = len(self.active) + len(self.done)
        # its gap requests to SUMO's drivers: the traffic's courtesy and cooperative V2V,
        # as the SV's (SUMO's own lane changers get that courtesy from SUMO; a vehicle
        # moved by moveToXY does not)
        gaps = self.takeovers.gap_requests(number) if self.cls.asks_for_gaps else []
        policy = self.cls(DrivingContext.of(
            av_sc, self.road, decision=self.decision, planner=self.make_planner(),
            ports=WorldPorts(blinker=self.announcements.blinker(
                vid, partial(self.takeovers.set_blinker, vid)),
                ask_gap=self.requests.port(vid, partial(_ask_gap, gaps))), notice=self.notice,
            cadence=CadenceConfig()))
        from cosim.traffic.v2v import V2VChannel

        channel = V2VChannel.from_spec(sc.v2v, self.road, 0)
        channel.rng = np.random.default_rng([sc.seed, V2V_STREAM, number])
        recorder = Recorder(sc.n_steps, sc.vehicle.length, sc.vehicle.width, self.road,
                            route_road=world.route_road, keep_tracks=False)
        self.requests.policies[vid] = policy
        self.active.append(AutomatedVehicle(vid, vtype, ego, policy, recorder, channel,
                                            self.observer, self.every_step, k, t_in,
                                            hold=getattr(policy, "hold", None), gaps=gaps))

    def _finish(self, av: AutomatedVehicle, k: int, end: str) -> None:
        av.k_end, av.end = k, end
        self.announcements.forget(av.id)
        self.requests.policies.pop(av.id, None)
        self.active.remove(av)
        self.loops.remove(av.ego.loop)
        self.watch.finish(av.id, k, end)
        self.done.append(av)

    def automated(self) -> tuple[str, ...]:
        """The ids of the SV and of every fleet vehicle watched now (ours, a baseline's)."""
        return (SV_ID, *self.watch.active)

    # ------------------------------------------------------------------ the end
    def result(self, last_row: int) -> FleetResult:
        """Every AV's rows up to the run's last row, and fleet.csv's rows (by id)."""
        teleported = self.takeovers.teleported()
        for av in list(self.active):
            self._finish(av, last_row, "running")
        watched = self.watch.close(last_row)
        traces, rows, plans = [], [], []
        for av in sorted(self.done, key=lambda a: a.id):
            full = av.recorder.trace(av.k_end)
            trace = {name: column[av.k0:] for name, column in full.items()}
            traces.append((av.id, trace, tuple(av.recorder.edges)))
            done = av.policy.summary(trace["t_s"], trace["d_m"])
            plans += [{"vehicle_id": av.id, **row} for row in done.plans]
            rec = av.recorder
            rows.append({
                "vehicle_id": av.id, "vtype": av.vtype, "inserted_t_s": av.inserted,
                "taken_over_t_s": float(trace["t_s"][0]), "end_t_s": float(trace["t_s"][-1]),
                "end": av.end,
                "s_start_m": float(trace["s_m"][0]), "s_end_m": float(trace["s_m"][-1]),
                "mean_speed_mps": float(np.mean(trace["vx_mps"])),
                "lane_changes": len(done.lane_changes),
                "collisions": rec.collisions, "caused_collisions": rec.sv_fault,
                "sumo_collisions": rec.sumo_new,
                "gap_min_m": float(np.min(trace["gap_min_m"])),
                "ttc_min_s": float(np.min(trace["ttc_min_s"])),
                "teleported": int(av.id in teleported), "driver": COSIM,
                "max_long_jerk_mps3": longitudinal_comfort(
                    trace["t_s"], trace["ax_mps2"])["max_long_jerk_mps3"],
                "follower_max_decel_mps2": watched[av.id].new_follower_decel(self.sc.step),
            })
        speed = (0.0, 0)
        for w in watched.values():
            if w.baseline:
                rows.append({**self.watch.baseline_row(w, self.spec.driver),
                             "teleported": int(w.id in teleported)})
                speed = (speed[0] + float(np.sum(w.speed)), speed[1] + len(w.speed))
        rows.sort(key=lambda r: r["vehicle_id"])
        return FleetResult(traces, rows, plans, speed)


def driver_scenario(sc: Scenario, lane: int, speed: float) -> Scenario:
    """An AV's driver: the SV's without what is the SV's own (its start, its scripted
    requests, its desired speed; it decides its lane changes by the decision rule, wanting
    its lane's limit), re-checking its change under way whatever `[planner] replanning`
    says (the paper's one-shot plan is the SV's to reproduce; flown blind, an AV's change
    of up to 10 s ran into SUMO's car ahead that braked and cut into the target lane
    meanwhile). `lane`: its SUMO lane index, `speed` (m/s) its speed at the takeover."""
    return replace(sc, sv=replace(sc.sv, lane=lane, speed=speed, lane_changes=(),
                                  desired_speed=None, decision=True),
                   planner=replace(sc.planner, replanning=True))
