"""Reading a scenario: the file (bounded in size), its tables, its network (read once,
through cosim.traffic.network), then the cross-field rules (cosim.scenario.rules)."""

from __future__ import annotations

import codecs
import copy
import dataclasses
import re
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from cosim.errors import InputError
from cosim.params import ControllerGains, PlannerConfig, RoadParams, vehicle_from_table
from cosim.road.driving_side import left_hand, left_hand_refusal
from cosim.road.road import Road
from cosim.road.route import read_network as read_sumo_network
from cosim.scenario.keys import REQUIRED_TABLES, TABLES, TV_FIELDS, VEHICLE_FIELDS
from cosim.scenario.model import (
    NAME_PATTERN,
    DetectorSpec,
    FleetSpec,
    Scenario,
    SsmSpec,
    SVSpec,
    TrafficSpec,
    TVSpec,
    V2VSpec,
)
from cosim.traffic.departures import check_departures
from cosim.traffic.network import SUPPORTED, Highway, load_highway, network_precision
from cosim.traffic.own_demand import (
    OwnDemand,
    SumoConfig,
    check_demand,
    dry_load,
    read_sumocfg,
)
from cosim.traffic.route_lanes import (
    RouteLanes,
    check_lanes,
    lane_width,
    load_route_road,
    road_params,
    sv_start,
    sv_tracks,
    through_tracks,
)
from cosim.validation import (
    MISSING,
    check_known_tables,
    check_table,
    not_a_file,
    validate_table,
)

MAX_FILE_BYTES = 1 * 2**20  # a scenario or study file is a few kB: refuse bigger ones unread
MAX_TVS = 100  # [[tv]] tables
# s, continuous TV lane changes (SUMO_NOTES: the default instant change is a 3.5 m jump)
DEFAULT_LANECHANGE_DURATION = 3.0


def project_root() -> Path:
    """The directory holding pyproject.toml above the package (else the working directory)."""
    here = Path(__file__).resolve().parent
    for candidate in (here, *here.parents):
        if (candidate / "pyproject.toml").is_file():
            return candidate
    return Path.cwd()


def exists(p: Path, want_file: bool = False) -> bool:
    """Path.exists / is_file that say False for names the OS refuses (too long, ...)."""
    try:
        return p.is_file() if want_file else p.exists()
    except (OSError, ValueError):
        return False


def _resolve(base_dir: Path, name: str) -> Path:
    """A path from a scenario file: absolute, else relative to the file's directory,
    else relative to the project root."""
    p = Path(name).expanduser()
    if p.is_absolute():
        return p
    first = base_dir / p
    if exists(first):
        return first.resolve()
    second = project_root() / p
    return second.resolve() if exists(second) else first


def read_toml(path: str | Path, what: str = "scenario") -> dict[str, Any]:
    """A TOML file as a document; InputError (one line) if it is missing, bigger than
    MAX_FILE_BYTES (checked before reading), not UTF-8, not TOML or nested too deep."""
    p = Path(path)
    source = str(p)
    problem = not_a_file(p)
    if problem is not None:
        raise InputError(source, "file", source, f"not found (a {what} file, .toml)"
                         if problem == "not found" else f"a {what} file (.toml); this is "
                         f"{problem}")
    try:
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise InputError(source, "file", f"{size} bytes",
                             f"a {what} file of at most {MAX_FILE_BYTES // 2**20} MiB")
        data = p.read_bytes()
    except OSError as exc:
        raise InputError(source, "file", source, f"a readable file ({exc.strerror})") from None
    if data.startswith(codecs.BOM_UTF8):  # what some editors put first: not TOML, harmless
        data = data[len(codecs.BOM_UTF8):]
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(source, "file", f"byte {exc.start}", "UTF-8 text (TOML)") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        where = re.fullmatch(r"(.*?) \(at (line \d+, column \d+|end of document)\)", str(exc))
        if where is None:
            raise InputError(source, "file", str(exc), "valid TOML") from None
        raise InputError(source, "file", where.group(2),
                         f"valid TOML ({where.group(1).rstrip('.').lower()} there)") from None
    except (RecursionError, ValueError) as exc:  # pathological nesting
        what_ = "nesting too deep" if isinstance(exc, RecursionError) else str(exc)
        raise InputError(source, "file", what_, "valid TOML") from None


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file; raise InputError (one line) if anything is wrong."""
    p = Path(path)
    return scenario_from_dict(read_toml(p), path=p.resolve(), source=str(p))


def _network_file(source: str, key: str, written: str, path: Path, base_dir: Path) -> None:
    """InputError naming the scenario unless `path` is a file of a network for
    right-hand traffic (cosim.road.driving_side)."""
    problem = not_a_file(path)
    if problem == "not found":
        looked = path if Path(written).expanduser().is_absolute() else (
            f"{base_dir / written} or {project_root() / written}")
        raise InputError(source, key, written,
                         f"an existing SUMO .net.xml file (not found: {looked})")
    if problem is not None:
        raise InputError(source, key, written,
                         f"a SUMO .net.xml file ({path} is {problem})")
    if left_hand(path):
        raise InputError(source, key, written, left_hand_refusal(path))


def read_network(source: str, key: str, written: str, path: Path,
                 base_dir: Path, route: tuple[str, ...] | None = None) -> Highway | None:
    """The scenario's network as a one-edge straight road, None for a `route` (already
    checked against the network) that is not one (the road is then `route_view`'s), or
    InputError naming the scenario."""
    _network_file(source, key, written, path, base_dir)
    try:
        return load_highway(path)
    except InputError as exc:
        if route is not None and exc.allowed.startswith(SUPPORTED):
            return None
        if exc.key in ("network", "size") or exc.key.endswith(" speed"):  # say what it is
            raise InputError(source, key, str(path),
                             f"{exc.allowed} ({exc.key} = {exc.value})") from None
        raise InputError(source, key, str(path), exc.allowed) from None


def _validated_tables(src: str, doc: Mapping[str, Any]
                      ) -> tuple[dict[str, dict[str, Any]], tuple[TVSpec, ...]]:
    """Every table of the document checked against its keys (file units in, SI out),
    and the [[tv]] tables as TVSpecs."""
    check_table(src, "", doc)
    if "study" in doc:
        raise InputError(src, "study", "[study]", "a scenario file (this is a study: cosim batch)")
    check_known_tables(src, doc, list(TABLES))
    for name in REQUIRED_TABLES:
        if name not in doc:
            raise InputError(src, f"[{name}]", MISSING, "required table")
    tables = {
        name: validate_table(src, name, doc.get(name, {}), specs)
        for name, specs in TABLES.items()
        if name != "tv"
    }
    raw_tvs = doc.get("tv", [])
    if not isinstance(raw_tvs, list) or len(raw_tvs) > MAX_TVS:
        raise InputError(src, "tv", raw_tvs, f"an array of at most {MAX_TVS} [[tv]] tables")
    tvs = tuple(TVSpec(**validate_table(src, f"tv[{i}]", t, TV_FIELDS))
                for i, t in enumerate(raw_tvs))
    return tables, tvs


def _network_of(src: str, doc: Mapping[str, Any], rd: dict[str, Any], base_dir: Path
                ) -> tuple[Path, SumoConfig | None, str, Any]:
    """(network file, [road] sumocfg read or None, the key that names the network and
    what the file wrote there): `road.network`, or the net-file of `road.sumocfg`."""
    network = _resolve(base_dir, rd["network"])
    if rd["sumocfg"] is None:
        return network, None, "road.network", rd["network"]
    if "network" in doc.get("road", {}):
        raise InputError(src, "road.network", rd["network"],
                         "absent with road.sumocfg (the .sumocfg's net-file is the "
                         "network)")
    sumocfg = _resolve(base_dir, rd["sumocfg"])
    config = read_sumocfg(src, "road.sumocfg", rd["sumocfg"], sumocfg)
    return config.net_file, config, "road.sumocfg", rd["sumocfg"]


def _road_of(src: str, rd: dict[str, Any], road_of_route: Road, found: Any, sv: SVSpec
             ) -> tuple[RoadParams, Any, tuple[int, float] | None]:
    """(the planner's road in (s, d), the one-edge view the rules read, and for a road
    that is not the straight highway the SV's start as (track, s))."""
    base = RoadParams(speed_bands=rd["speed_bands"], mu=rd["mu"])
    road = road_params(road_of_route, base, src)
    start: tuple[int, float] | None = None
    if found is None:  # another road: the rules read it through its one-edge view
        check_lanes(road_of_route, src, sv.edge, sv.lane)
        _bands_per_through_lane(src, road_of_route, rd["speed_bands"])
        start = sv_start(road_of_route, sv.edge, sv.lane, sv.position)
        found = route_view(road_of_route, sv.edge)
    # lane geometry has one source: the network (the file may only repeat its width)
    if (rd["lane_width"] is not None
            and abs(rd["lane_width"] - road.lane_width) > max(1e-3, found.rounding)):
        raise InputError(src, "road.lane_width_m", rd["lane_width"],
                         f"the network's lane width {road.lane_width:g} m (or absent)")
    return road, found, start


def _name_of(src: str, written: str | None, p: Path) -> str:
    """The scenario's name: as written, or the file's stem, held to the same rule."""
    if written is not None:
        return written
    name = p.stem or "scenario"
    if not re.fullmatch(NAME_PATTERN, name):
        raise InputError(src, "scenario.name", MISSING,
                         f"a name matching {NAME_PATTERN} (the file's stem {name!r} is not "
                         "one: it names the output folder)")
    return name


def _check_rules(src: str, scenario: Scenario, start: tuple[int, float] | None,
                 highway: Any) -> None:
    """The scenario rules (cosim.scenario.rules), on another road in its track view."""
    from cosim.scenario.rules import check_scenario

    ruled = scenario
    if start is not None:  # the rules' lane k is track k (every lane the file names
        # shifted alike), their position the distance from the road's start
        ruled = scenario.in_tracks(start[0])
        ruled = dataclasses.replace(ruled, sv=dataclasses.replace(ruled.sv, position=start[1]))
        _lanes_run_through(src, scenario, ruled)
    check_scenario(src, ruled, highway)


def scenario_from_dict(
    doc: Mapping[str, Any], path: str | Path = "<scenario>", source: str | None = None,
) -> Scenario:
    """Validate a scenario document (the parsed TOML, file units) into a Scenario.

    Relative paths in it are resolved against `path`'s directory, then the project root.
    """
    from cosim.scenario.rules import check_route

    p = Path(path)
    src = source if source is not None else str(p)
    tables, tvs = _validated_tables(src, doc)
    sc, rd = tables["scenario"], tables["road"]
    base_dir = p.parent if p.is_absolute() else Path.cwd() / p.parent
    # [road] sumocfg: its net-file is the network (cosim.traffic.own_demand)
    network, config, net_key, net_written = _network_of(src, doc, rd, base_dir)
    sv = _lane_changes_in_lanes(src, SVSpec(**tables["sv"]))
    vehicle = vehicle_from_table(tables["vehicle"], {  # a preset, then the file's keys
        f.attr for f in VEHICLE_FIELDS if f.key in doc.get("vehicle", {})})
    if rd["route"] is not None or sv.edge is not None:
        _network_file(src, net_key, net_written, network, base_dir)
        # before the one-edge rules below
        check_route(src, network, rd["route"], sv, vehicle.length)
    found = read_network(src, net_key, net_written, network, base_dir,
                         route=rd["route"])
    # the planner's road in (s, d) from the route's road (cosim.traffic.route_lanes.road_params;
    # on the one straight edge of networks/highway.net.xml the straight road's RoadParams)
    road_of_route = load_route_road(network, rd["route"], source=src)
    traffic = _traffic(src, tables["traffic"], base_dir)
    demand = _own_demand(src, traffic, tables["traffic"]["routes"], rd["sumocfg"], config,
                         network, [tv.id for tv in tvs], sc["step"])
    road, highway, start = _road_of(src, rd, road_of_route, found, sv)
    name = _name_of(src, sc.pop("name"), p)
    fleet = _fleet(src, tables["fleet"], sv.controller, demand is not None)
    scenario = Scenario(
        name=name,
        **sc,
        path=p,
        road=road,
        network=network,
        vehicle=vehicle,
        gains=ControllerGains(**tables["controller"]),
        planner=PlannerConfig(**tables["planner"]),
        sv=sv,
        tvs=tvs,
        traffic=traffic,
        v2v=V2VSpec(**tables["v2v"]),
        document=copy.deepcopy(dict(doc)),
        route=rd["route"],
        sumocfg=None if config is None else config.path,
        demand=demand,
        detectors=_detectors(src, tables["detectors"], road_of_route, sc["step"]),
        fleet=fleet,
        ssm=_ssm(src, tables["ssm"], fleet),
    )
    _check_rules(src, scenario, start, highway)
    if start is not None:
        _traffic_fits(src, traffic, road_of_route)
    return scenario


def _traffic_fits(src: str, traffic: TrafficSpec, road: Road) -> None:
    """Random traffic is placed over `traffic.length_m` of s where every lane that runs
    through the route lies (cosim.traffic.demand.populate): refuse a longer stretch (on a
    route over an off-ramp the lanes that run through begin at the deceleration lane)."""
    if traffic.density <= 0:
        return
    lanes = RouteLanes(road)
    begin = max(t.begin for t in lanes.through)
    end = min(t.end for t in lanes.through)
    if traffic.length > end - begin:
        raise InputError(src, "traffic.length_m", traffic.length,
                         f"at most the {end - begin:.0f} m of the route where every lane "
                         f"that runs through it lies (s = {begin:.0f} to {end:.0f} m), "
                         "which random traffic fills")


def _bands_per_through_lane(src: str, road: Road, bands: tuple[tuple[float, float], ...]
                            ) -> None:
    """InputError unless `[road] lane_speeds_kmh` has one band per lane that runs through
    the route (or one per SV lane, the lanes that end included)."""
    n_through, n_lanes = len(through_tracks(road)), len(sv_tracks(road))
    if len(bands) not in (n_through, n_lanes):
        ends = n_lanes - n_through
        raise InputError(src, "road.lane_speeds_kmh", [[round(v * 3.6, 6) for v in b]
                                                       for b in bands],
                         f"{n_through} [min, max] pairs in km/h, one per lane that runs "
                         f"through the route {list(road.route.edges)}"
                         + (f" (its {ends} lane(s) that end take their neighbour's band)"
                            if ends else ""))


def _lanes_run_through(src: str, written: Scenario, ruled: Scenario) -> None:
    """InputError for a lane the file names (SUMO's index on [sv] edge) that is not one of
    the route's through lanes (below them: a lane the route adds)."""
    names = [(f"sv.lane_changes[{i}].target_lane", w.target_lane, r.target_lane)
             for i, (w, r) in enumerate(zip(written.sv.lane_changes, ruled.sv.lane_changes,
                                            strict=True))]
    for i, (w, r) in enumerate(zip(written.tvs, ruled.tvs, strict=True)):
        names.append((f"tv[{i}].lane", w.lane, r.lane))
        if w.lane_change is not None and r.lane_change is not None:
            names.append((f"tv[{i}].lane_change.target_lane", w.lane_change.target_lane,
                          r.lane_change.target_lane))
    lowest = written.sv.lane - ruled.sv.lane
    for key, value, track in names:
        if track < 0:
            raise InputError(src, key, value,
                             f"a lane that runs through the route (on edge "
                             f"{written.sv.edge}: index {lowest} or above; lower ones are "
                             "added on the route, not driven yet)")


def _lane_changes_in_lanes(src: str, sv: SVSpec) -> SVSpec:
    """The SV with each lane change's `direction` turned into its target lane (the lane
    left (+1) or right (-1) of the one the SV is in by then); exactly one of the two."""
    lane, out = sv.lane, []
    for i, cmd in enumerate(sv.lane_changes):
        if (cmd.target_lane is None) == (cmd.direction is None):
            raise InputError(src, f"sv.lane_changes[{i}]", MISSING if cmd.direction is None
                             else cmd.target_lane, "either target_lane or direction")
        if cmd.direction is not None:
            # (the direction is dropped: the scenario says target lanes from here on)
            cmd = dataclasses.replace(cmd, target_lane=lane + (1 if cmd.direction == "left"
                                                               else -1), direction=None)
            if cmd.target_lane < 0:
                raise InputError(src, f"sv.lane_changes[{i}].direction", "right",
                                 "a side with a lane (the SV is in lane 0 by then)")
        lane = cmd.target_lane
        out.append(cmd)
    return dataclasses.replace(sv, lane_changes=tuple(out))


def route_view(road: Road, sv_edge: str | None) -> Highway:
    """The one-edge view of a route's road that the scenario rules check against
    (cosim.scenario.rules reads positions along one edge from its start): x is s, from 0
    to where the through tracks end, a lane's speed limit is its track's on the SV's start
    edge, every lane is open to cars (tracks are the lanes cars may use). The rules then
    read the SV's s as its sv.position_m (a message about it names that s). Its lanes are
    the SV lanes (cosim.traffic.route_lanes.sv_tracks: through or ending on the route)."""
    lanes = RouteLanes(road)
    edge = sv_edge if sv_edge is not None else road.route.edges[0]
    speeds = []
    for table in lanes.sv:
        piece = table.track.piece_on(edge) or table.track.pieces[0]
        speeds.append(piece.speed)
    end = min(t.end for t in lanes.through)
    return Highway(
        path=road.route.path, edge_id=edge, x_start=0.0, length=float(end),
        lane_width=lane_width(road),
        y_right=0.0, lane_speeds=tuple(speeds), lane_open=(True,) * len(speeds),
        rounding=0.5 * 10.0 ** -network_precision(str(road.route.path)) + 1e-9,
    )


def _own_demand(src: str, traffic: TrafficSpec, written_routes: tuple[str, ...] | None,
                written_cfg: str | None, config: SumoConfig | None, network: Path,
                scripted: list[str], step: float) -> OwnDemand | None:
    """The user's demand ([road] sumocfg's route and additional files, then [traffic]
    routes: `traffic.routes` resolved, `written_*` as the file wrote them), every file read
    and checked before SUMO starts (cosim.traffic.own_demand); None without any. Their
    demand is the traffic: cosim's random traffic is refused with it, and a warm-up
    without it."""
    files: list[tuple[str, str, Path]] = []
    if config is not None:
        files += [("road.sumocfg", str(written_cfg), f)
                  for f in (*config.route_files, *config.additional_files)]
    resolved = traffic.routes or ()
    files += [(f"traffic.routes[{i}]", w, Path(r)) for i, (w, r) in
              enumerate(zip(written_routes or (), resolved, strict=True))]
    warmup = traffic.warmup or 0.0
    if not files:
        if warmup > 0:
            raise InputError(src, "traffic.warmup_s", warmup,
                             "0 or absent without route files (traffic.routes, or a "
                             "road.sumocfg's route-files: the warm-up runs the user's own "
                             "demand)")
        return None
    from cosim.scenario.rules import STEP_TOLERANCE

    ratio = warmup / step
    if abs(ratio - round(ratio)) > STEP_TOLERANCE * max(1.0, ratio):
        raise InputError(src, "traffic.warmup_s", warmup,
                         f"a whole multiple of scenario.step_s = {step:g} s")
    if traffic.density > 0:
        raise InputError(src, "traffic.density_veh_per_km_lane", traffic.density,
                         "0 with traffic.routes or road.sumocfg (their demand is the "
                         "traffic; cosim's random traffic would be placed on top of it)")
    net = read_sumo_network(network)
    read = check_demand(src, files, {e.getID() for e in net.getEdges(withInternal=False)},
                        network.name, scripted)
    check_departures(src, read, net)  # every vehicle as it departs, however late
    demand = OwnDemand(
        route_files=(*(config.route_files if config else ()), *(Path(r) for r in resolved)),
        additional_files=config.additional_files if config else (), warmup=warmup)
    # what only SUMO knows (attribute values, ...): it loads them once, before the run
    key, value = ("road.sumocfg", written_cfg) if not resolved else (
        "traffic.routes", list(written_routes or ())) if config is None else (
        "road.sumocfg and traffic.routes", [written_cfg, *(written_routes or ())])
    dry_load(src, key, value, network, demand.route_files, demand.additional_files)
    return demand


def _traffic(src: str, values: dict[str, Any], base_dir: Path) -> TrafficSpec:
    """SUMO cannot combine --lanechange.duration with the sublane model. Route files are
    resolved like the network (absolute, else the file's directory, else the project
    root)."""
    if values["routes"] is not None:
        values = {**values, "routes": tuple(str(_resolve(base_dir, r)) for r in
                                            values["routes"])}
    duration = values["lanechange_duration"]
    if values["sublane"] and duration not in (None, 0.0):
        raise InputError(
            src,
            "traffic.lanechange_duration_s",
            duration,
            "0 or absent with traffic.sublane = true (SUMO uses one or the other)",
        )
    if duration is None:
        duration = 0.0 if values["sublane"] else DEFAULT_LANECHANGE_DURATION
    return TrafficSpec(**{**values, "lanechange_duration": duration})


def _detectors(src: str, values: dict[str, Any], road: Road, step: float) -> DetectorSpec:
    """[detectors]: the period whole steps (SUMO aggregates over steps), the user's
    positions on the route (within the SV lanes' extent along s)."""
    from cosim.scenario.rules import STEP_TOLERANCE

    spec = DetectorSpec(**values)
    ratio = spec.period / step
    if round(ratio) < 1 or abs(ratio - round(ratio)) > STEP_TOLERANCE * max(1.0, ratio):
        raise InputError(src, "detectors.period_s", spec.period,
                         f"a whole multiple of scenario.step_s = {step:g} s")
    lanes = sv_tracks(road)
    lo, hi = min(t.begin for t in lanes), max(t.end for t in lanes)
    for i, s in enumerate(spec.positions):
        if not lo - 1e-6 <= s <= hi + 1e-6:
            raise InputError(src, f"detectors.positions_m[{i}]", s,
                             f"a position along the route in [{max(lo, 0.0):g}, {hi:g}] m "
                             "(where its SV lanes run)")
    return spec


def _ssm(src: str, values: dict[str, Any], fleet: FleetSpec) -> SsmSpec:
    """[ssm]: the device on the fleet needs vTypes to put it on (SUMO builds a vehicle's
    devices with the vehicle, before the fleet's `share` draws it at its insertion)."""
    spec = SsmSpec(**values)
    if spec.vehicles == "fleet" and not fleet.vtypes:
        raise InputError(src, "ssm.vehicles", spec.vehicles,
                         "all or sv without fleet.vtypes (the device goes on the SV and "
                         "the vehicles of those vTypes)")
    return spec


def _fleet(src: str, values: dict[str, Any], controller: str, own_demand: bool) -> FleetSpec:
    """[fleet]: vtypes name vehicles of the user's own demand; the automated vehicles are
    driven by the scenario's planner and controller, not by SUMO."""
    spec = FleetSpec(**values)
    if spec.vtypes and not own_demand:
        raise InputError(src, "fleet.vtypes", list(spec.vtypes),
                         "[] without the user's own demand (traffic.routes or road.sumocfg)")
    if spec.enabled and controller == "sumo" and spec.driver == "cosim":
        raise InputError(src, "sv.controller", controller,
                         "mimo or siso with a [fleet] whose driver is cosim (its automated "
                         "vehicles are driven by the scenario's planner and controller)")
    return spec
