"""Random highway traffic by density, with the paper's lane speed bands.

At t = 0 every through track of the route (an SV lane that runs on, cosim.traffic.route_lanes) gets
`density` vehicles per km spread along its first `length` metres of arc length s
(about evenly, jittered), so the road is full from the start; then an inflow at the
start of the route inserts the next vehicle of a track once the last one has driven a
spacing of about 1000/density m, so the density holds. Where the network feeds a
through track from an edge before the route (the mainline upstream of an acceleration
lane), that edge's last UPSTREAM_LENGTH m are filled too and the inflow enters there,
out of the SV's sight. Lanes that are not through
tracks (a lane added along the route) get no traffic of their own: TVs change into
them. Each traffic vehicle (TV) draws where its desired speed sits in a band
(`quantile`); SumoSim sets its desired speed from the band of whatever track it is on
(Section 5: lanes 60-90, 90-110, 110-120 km/h). Positions and zones are arc lengths s
along the route (on the one-edge road s = x - the road's start x).

Start-up safety: TVs are inserted at SUMO's "max" depart speed, which SUMO
lowers to a speed safe behind the TV ahead (in dense traffic the queue starts
slow, ~13 m/s at 50 veh/km/lane), so TVs never start on a collision course
with each other. The SV, though, is placed at its scenario speed (e.g.
100 km/h) into that queue: `start_zone` gives the stretch of its lane kept free
so it can brake behind its leader and its follower behind it, and where its leader
at t = 0 is random traffic too slow for that, `safe_start_speed` lowers the SV's
start speed as SUMO's own insertion would (`World.start_speed`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from cosim.errors import InputError
from cosim.params import G, RoadParams
from cosim.traffic.process import SumoOptions
from cosim.traffic.sumo import TV_LENGTH, TV_TYPE, TV_WIDTH, SumoSim

QUANTILE_RANGE = (0.1, 0.95)  # -, desired speeds stay off the band's edges (drivers dawdle)
SPACING_JITTER = 0.25  # -, spacing varies by +-25 % of 1000/density
START_HEADWAY = 2.0  # s, free road ahead of the SV at t = 0 per m/s of its speed
TV_MIN_GAP = 2.5  # m, SUMO's default minGap of the TV type (front to rear, standstill)
TV_HEADWAY = 1.0  # s, SUMO's default tau of the TV type (Krauss safe headway)
# The SV's start speed behind random traffic (`safe_start_speed`)
START_DECEL = 4.5  # m/s^2, SUMO's `decel` of its passenger car, what its departSpeed rules use
START_GRIP = 0.7  # -, share of mu g the SV's car-following may brake with (policy FOLLOW_GRIP)
# s, the SV's car-following ramps its braking up (15 m/s^3) first
START_REACTION = 0.5  # tuned: docs/tuned_constants.md
# m, on a route whose first edge the mainline feeds from an edge before it, the random
# traffic also fills this much of that edge and enters there: beyond the SV's sight
# (world.NEAR_RANGE 150 m, V2V up to 300 m), so a TV never appears beside an SV that
# starts near the route's start (an SV on an acceleration lane)
UPSTREAM_LENGTH = 400.0  # tuned: docs/tuned_constants.md
RANDOM_ID_PREFIX = "tv"  # random traffic is tv1, tv2, ... (scenario TV ids may not be)
RANDOM_ID = re.compile(rf"{RANDOM_ID_PREFIX}\d+")


@dataclass
class RandomTraffic:
    """The random traffic of one run: what was placed, and the inflow that keeps it."""

    density: float  # veh per km per lane
    length: float  # m, stretch of road filled at t = 0
    rng: np.random.Generator
    placed: dict[int, list[str]] = field(default_factory=dict)  # lane -> TV ids placed at t = 0
    inflow: bool = True
    _last: dict[int, str] = field(default_factory=dict)  # lane -> last vehicle inserted
    _next_gap: dict[int, float] = field(default_factory=dict)  # lane -> m before the next one
    _count: int = 0
    _begin: dict[int, float] = field(default_factory=dict)  # track -> s where TVs enter
    _odometer: set[int] = field(default_factory=set)  # tracks entered before the route:
    # the last TV's distance driven tells when the next one enters (it changes edges)

    def new_id(self) -> str:
        self._count += 1
        return f"{RANDOM_ID_PREFIX}{self._count}"

    def spacing(self) -> float:
        """m, one random spacing around 1000/density."""
        mean = 1000.0 / self.density
        return mean * (1.0 + SPACING_JITTER * (2.0 * self.rng.random() - 1.0))

    def quantile(self) -> float:
        lo, hi = QUANTILE_RANGE
        return lo + (hi - lo) * self.rng.random()

    def __call__(self, sim: SumoSim) -> None:
        """The inflow (a SumoSim hook, after each step)."""
        if not self.inflow:
            return
        for lane, last in list(self._last.items()):
            # front position of the last one inserted; a vehicle still waiting for room
            # reads INVALID (< any gap); one that has left the road raises: insert then
            try:
                driven = (sim.api.vehicle.getDistance(last) if lane in self._odometer
                          else sim.reader.lane_position(last)) if last else 0.0
                if last and driven < self._next_gap[lane]:
                    continue
            except sim.api.TraCIException:
                pass
            vid = self.new_id()
            q = self.quantile()
            sim.add_traffic(vid, lane, self._begin[lane] + 0.5 * TV_LENGTH, q)
            self._last[lane] = vid
            self._next_gap[lane] = self.spacing()


def placement(
    rng: np.random.Generator, density: float, x_start: float, length: float
) -> np.ndarray:
    """m, centre x of one lane's vehicles at t = 0: density per km, jittered even spacing."""
    n = int(round(density * length / 1000.0))
    if n == 0:
        return np.empty(0)
    cell = length / n
    jitter = SPACING_JITTER * (2.0 * rng.random(n) - 1.0)
    x = x_start + (np.arange(n) + 0.5 + 0.5 * jitter) * cell
    return np.clip(x, x_start + 0.5 * TV_LENGTH, x_start + length - 0.5 * TV_LENGTH)


def start_zone(
    x: float, length: float, speed: float, follower_speed: float
) -> tuple[float, float]:
    """(x_lo, x_hi), m: the stretch of its lane kept free of TVs around a vehicle
    placed at t = 0 with its centre at x, its `length` (m) and `speed` (m/s).

    Ahead: minGap + START_HEADWAY * speed from its front, so a vehicle placed at
    speed behind a much slower queue can still brake (at 50 veh/km/lane the SV at
    27.8 m/s otherwise starts ~7 m behind a TV at ~13 m/s and hits it at
    t = 0.6 s, whoever drives it). Behind: minGap + the TVs' own headway at
    `follower_speed` (m/s, an upper bound of the follower's speed, e.g. its lane's
    band maximum: the follower is inserted before the vehicle exists, so SUMO's
    insertion check cannot see it), so the follower can brake when it does.
    """
    ahead = 0.5 * length + TV_MIN_GAP + START_HEADWAY * max(speed, 0.0)
    behind = 0.5 * length + TV_MIN_GAP + TV_HEADWAY * max(follower_speed, 0.0)
    return x - behind, x + ahead


def safe_start_speed(speed: float, gap: float, leader_speed: float, mu: float) -> float:
    """m/s, the highest speed up to `speed` at which a vehicle starting `gap` m (bumper to
    bumper) behind a leader at `leader_speed` (m/s) can stop TV_MIN_GAP behind it should
    the leader brake to a standstill: SUMO's insertion rule (departSpeed "max" lowers the
    speed to Krauss's safe speed v tau + v^2 / 2b <= gap - minGap + v_l^2 / 2b, leader and
    follower braking alike) with b = min(START_DECEL, START_GRIP mu g), the braking the
    SV's car-following may use on this road, and tau = START_REACTION.

    Beyond the paper: in dense traffic SUMO inserts the queue ahead slow, and an SV
    inserted at its scenario speed behind it could need more braking than its
    car-following may use on a wet road (docs/tuned_constants.md)."""
    b = min(START_DECEL, START_GRIP * mu * G)
    room = max(gap - TV_MIN_GAP, 0.0) + leader_speed**2 / (2.0 * b)
    bt = b * START_REACTION
    return min(speed, -bt + float(np.sqrt(bt * bt + 2.0 * b * room)))


def populate(
    sim: SumoSim,
    road: RoadParams,
    density: float,
    seed: int | np.random.Generator,
    length: float,
    exclude_zone: tuple[float, float] | None = None,
    inflow: bool = True,
    lane_zones: Mapping[int, tuple[float, float]] | None = None,
) -> RandomTraffic:
    """Place traffic for t = 0 (call before the first step) and keep an inflow.

    Every through track of `sim`'s route gets TVs along s from its start over `length`
    m (`road`, the RoadParams of those lanes, is not needed). `exclude_zone` (s_lo,
    s_hi), m: no TV's body may overlap this stretch in any lane at t = 0 (keep it free
    around the SV). `lane_zones`: track -> (s_lo, s_hi), m, further stretches kept free
    on that track only (e.g. `start_zone` of the SV in its own lane). Positions and
    desired speeds are drawn for every slot before the zones cut some (so a seed gives
    the same traffic outside the zones whatever their size). Returns the `Traffic`,
    already registered as a step hook of `sim`.
    """
    if density < 0 or not np.isfinite(density):
        raise InputError("traffic", "density_veh_per_km_lane", density, ">= 0 veh/km/lane")
    road_length = sim.lanes.length
    if length <= 0 or length > road_length:
        raise InputError(
            "traffic", "length_m", length, f"0 < length <= the road's {road_length:.0f} m"
        )
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    traffic = RandomTraffic(density=density, length=length, rng=rng, inflow=inflow)
    if density == 0:
        return traffic
    del road  # its lanes are the route's through tracks (sim.road() is built of them)
    for table in sim.lanes.through:
        lane = table.id
        # front to back: each one is inserted behind its leader
        xs = placement(rng, density, table.begin, length)[::-1]
        qs = QUANTILE_RANGE[0] + (QUANTILE_RANGE[1] - QUANTILE_RANGE[0]) * rng.random(len(xs))
        traffic._begin[lane] = table.begin
        up = sim.lanes.upstream_room(lane, UPSTREAM_LENGTH)
        if up > 0.0:  # the stretch before the route, filled alike: the inflow enters there
            xs_up = placement(rng, density, table.begin - up, up)[::-1]
            qs_up = QUANTILE_RANGE[0] + (QUANTILE_RANGE[1] - QUANTILE_RANGE[0]) \
                * rng.random(len(xs_up))
            xs, qs = np.concatenate((xs, xs_up)), np.concatenate((qs, qs_up))
            traffic._begin[lane] = table.begin - up
            traffic._odometer.add(lane)
        keep = np.ones(len(xs), dtype=bool)
        zones = [exclude_zone] if exclude_zone is not None else []
        if lane_zones and lane in lane_zones:
            zones.append(lane_zones[lane])
        for lo, hi in zones:
            keep &= (xs + 0.5 * TV_LENGTH < lo) | (xs - 0.5 * TV_LENGTH > hi)
        ids = []
        for x, q in zip(xs[keep], qs[keep], strict=True):
            vid = traffic.new_id()
            sim.add_traffic(vid, lane, float(x), float(q))
            ids.append(vid)
        traffic.placed[lane] = ids
        if ids:
            traffic._last[lane] = ids[-1]  # the rearmost: the inflow follows it
            traffic._next_gap[lane] = traffic.spacing()
        else:
            traffic._last[lane] = ""
            traffic._next_gap[lane] = 0.0
    sim.add_hook(traffic)
    return traffic


@dataclass(frozen=True)
class LaneSpeeds:
    """Speeds of traffic vehicles sampled per lane over a run (what the band plot shows)."""

    speeds: tuple[np.ndarray, ...]  # m/s, samples per SUMO lane index
    bands: tuple[tuple[float, float], ...]  # m/s, (min, max) per lane
    density: float  # veh per km per lane
    duration: float  # s
    lane_changes: int  # lane changes the TVs made themselves

    def inside(self, tolerance: float = 0.5 / 3.6) -> tuple[float, ...]:
        """-, fraction of each lane's samples inside its band (+- tolerance m/s)."""
        return tuple(
            float(np.mean((v >= lo - tolerance) & (v <= hi + tolerance))) if len(v) else 0.0
            for v, (lo, hi) in zip(self.speeds, self.bands, strict=True)
        )


@dataclass(frozen=True)
class SpeedSampling:
    """How `sample_lane_speeds` runs the traffic and samples it."""

    step: float = 0.05  # s, SUMO's step
    lanechange_duration: float = 3.0  # s, the traffic's lane changes take this long
    length: float = 2000.0  # m, stretch of road filled at t = 0
    window: tuple[float, float] = (300.0, 2500.0)  # m, the x range sampled
    every: int = 10  # -, one sample every this many steps


def sample_lane_speeds(network: Path, density: float, seed: int, duration: float,
                       sampling: SpeedSampling = SpeedSampling()) -> LaneSpeeds:
    """Run traffic alone for `duration` s at `density` veh/km/lane and sample TV speeds per
    lane inside `sampling.window` (m)."""
    step, window, every = sampling.step, sampling.window, sampling.every
    speeds: list[list[float]] = []
    changes = 0
    options = SumoOptions(lanechange_duration=sampling.lanechange_duration)
    with SumoSim(network, step, seed, options) as sim:
        road = sim.road()
        speeds = [[] for _ in range(road.n_lanes)]
        populate(sim, road, density, seed, sampling.length)
        lanes: dict[str, int] = {}
        for k in range(int(round(duration / step))):
            sim.step()
            snap = sim.snapshot()
            for vid, lane in zip(snap.ids, snap.lane, strict=True):
                changes += int(lanes.get(vid, lane) != lane)
                lanes[vid] = int(lane)
            if k % every:
                continue
            inside = (snap.x > window[0]) & (snap.x < window[1])
            for lane in range(road.n_lanes):
                speeds[lane].extend(snap.speed[inside & (snap.lane == lane)])
    return LaneSpeeds(
        speeds=tuple(np.array(v) for v in speeds),
        bands=road.speed_bands,
        density=density,
        duration=duration,
        lane_changes=changes,
    )


# ----------------------------------------------------------------------------- ramps
RAMP_JITTER = 0.5  # -, a ramp vehicle's headway varies by +-50 % of 3600/flow


@dataclass(frozen=True)
class Ramp:
    """An on-ramp of the route: an edge off it whose lane feeds a track that begins on
    the route edge `route_index` (an acceleration lane, a lane added by the ramp)."""

    edge: str  # SUMO id of the ramp edge (off the route)
    lane: int  # its lane index the vehicles depart on
    track: int  # the route's track it feeds (its speed band is the ramp vehicles' first)
    route_index: int  # the route edge the track begins on


def ramps(sim: SumoSim) -> tuple[Ramp, ...]:
    """The route's on-ramps (`Ramp`): for every track that begins on a route edge and does
    not run through (every lane of the route's first edge that ends, every lane that
    begins later), the edges off the route connected into its first lane."""
    route_road = sim.lanes.route_road
    through = {t.id for t in sim.lanes.through}
    on_route = set(route_road.route.edges)
    found: list[Ramp] = []
    for table in route_road.lanes:
        first = table.track.pieces[0]
        if table.id in through or first.internal:
            continue
        lane = route_road.route.net.getLane(first.lane)
        for conn in sorted(lane.getIncoming(), key=lambda ln: ln.getID()):
            edge = conn.getEdge()
            if edge.getID() in on_route or edge.getFunction() == "internal":
                continue
            found.append(Ramp(edge.getID(), conn.getIndex(), table.id, first.route_index))
    return tuple(found)


@dataclass
class RampFlow:
    """SUMO-driven traffic from the route's on-ramps (`ramps`): `flow` vehicles per hour
    from each, headways 3600/flow +-RAMP_JITTER, each on its ramp and then the rest of the
    route, its desired speed at a random place in the band of the track it joins. A SumoSim
    hook: a vehicle is added when its time has come (SUMO inserts it at the ramp's start as
    soon as there is room)."""

    flow: float  # veh/h per ramp
    rng: np.random.Generator
    traffic: RandomTraffic  # the random traffic: ids from its counter (tv1, tv2, ...)
    ramps: tuple[Ramp, ...] = ()
    _next: list[float] = field(default_factory=list)  # s, each ramp's next departure

    def headway(self) -> float:
        mean = 3600.0 / self.flow
        return mean * (1.0 + RAMP_JITTER * (2.0 * self.rng.random() - 1.0))

    def __call__(self, sim: SumoSim) -> None:
        t = sim.time
        for i, ramp in enumerate(self.ramps):
            if t < self._next[i]:
                continue
            api = sim.api
            rid = f"ramp_{ramp.edge}@{ramp.route_index}"
            if rid not in sim.lanes.extra_routes:
                edges = sim.lanes.route_road.route.edges[ramp.route_index:]
                api.route.add(rid, [ramp.edge, *edges])
                sim.lanes.extra_routes.add(rid)
            vid = self.traffic.new_id()
            lo, hi = QUANTILE_RANGE
            q = lo + (hi - lo) * self.rng.random()
            desired = sim.bands.speed(ramp.track, q)
            api.vehicle.add(vid, rid, typeID=TV_TYPE, departLane=str(ramp.lane),
                            departPos="base", departSpeed="max")
            api.vehicle.setMaxSpeed(vid, desired)
            sim.bands.add(vid, ramp.track, q)
            sim.dims[vid] = (TV_LENGTH, TV_WIDTH)
            self._next[i] = t + self.headway()


def ramp_flow(sim: SumoSim, flow: float, seed: int, traffic: RandomTraffic | None = None
              ) -> RampFlow | None:
    """Start the on-ramp traffic (`RampFlow`, `flow` veh/h per ramp; its own random stream
    of `seed`) as a step hook of `sim`; None when `flow` is 0 or the route has no ramp."""
    if flow <= 0.0:
        return None
    found = ramps(sim)
    if not found:
        return None
    rng = np.random.default_rng([seed, 24])
    if traffic is None:
        traffic = RandomTraffic(density=0.0, length=0.0, rng=rng, inflow=False)
    hook = RampFlow(flow, rng, traffic, found)
    hook._next = [float(rng.random()) * 3600.0 / flow for _ in found]
    sim.add_hook(hook)
    return hook
