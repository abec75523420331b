"""Cross-field rules of a scenario: everything the files say that SUMO would otherwise find
(or silently get wrong) is checked here, before anything starts, for `cosim run`, `plan`
and `batch` alike (each loads its scenarios through `scenario_from_dict`).

Positions: `sv.position_m` is the distance of the SV's centre from the start of the road
(the network's one edge), so a network starting at x = -5000 m is read the same way as
one starting at 0; a TV's `gap_m` is measured from the SV.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cosim.errors import InputError
from cosim.scenario.model import KMH, Scenario, SVSpec, TVSpec
from cosim.traffic.network import Highway

STEP_TOLERANCE = 1e-9  # relative, "duration is a multiple of the step"
SPEED_TOLERANCE = 1e-4  # m/s above a lane's SUMO limit still accepted (its 6 printed digits)
SV_ID = "sv"  # the SV's SUMO id (cosim.run.loop.SV_ID; a test checks they agree)


def check_scenario(src: str, s: Scenario, net: Highway) -> None:
    """Raise InputError on the first rule `s` breaks (one line: file, key, value, allowed)."""
    n = s.road.n_lanes
    if n != net.n_lanes:
        raise InputError(
            src, "road.network", str(s.network),
            f"a network with a {n}-lane edge to match road.lane_speeds_kmh "
            f"(its edge has {net.n_lanes} lanes)",
        )
    _check_time_and_planner(src, s)
    _check_vehicle(src, s)
    _check_sv(src, s, net)
    _check_tvs(src, s, net)
    _check_lanes_open(src, s, net)
    _check_no_overlap(src, s, net)
    _check_positions(src, s, net)


def check_route(src: str, network: Path, route: tuple[str, ...] | None, sv: SVSpec,
                sv_length: float) -> None:
    """`road.route` on `network` (edges that exist, each connected to the next by a lane a
    car may use: cosim.road.route.make_route) and the SV's start on it: `sv.edge` one of
    its edges, `sv.lane` a lane of that edge open to cars, `sv.position_m` on that lane.
    Raise InputError (one line) on the first fault; run before SUMO or the frame."""
    from cosim.road.route import VCLASS, make_route

    r = make_route(network, route, source=src, key="road.route")
    edge_id = sv.edge if sv.edge is not None else r.edges[0]
    if edge_id not in r.edges:
        raise InputError(src, "sv.edge", edge_id,
                         f"an edge of road.route ({', '.join(r.edges[:8])}"
                         f"{', ...' if len(r.edges) > 8 else ''})")
    edge = r.net.getEdge(edge_id)
    lanes = sorted(edge.getLanes(), key=lambda lane: lane.getIndex())
    if sv.lane >= len(lanes):
        raise InputError(src, "sv.lane", sv.lane,
                         f"a lane index 0..{len(lanes) - 1} (edge {edge_id!r} has "
                         f"{len(lanes)} lanes)")
    lane = lanes[sv.lane]
    if not lane.allows(VCLASS):
        raise InputError(src, "sv.lane", sv.lane,
                         f"a lane open to passenger cars (lane {lane.getID()!r} is closed to "
                         "them by its allow / disallow)")
    half = 0.5 * sv_length
    length = float(lane.getLength())
    if length < sv_length:
        raise InputError(src, "sv.edge", edge_id,
                         f"an edge at least as long as the SV ({sv_length:g} m; lane "
                         f"{lane.getID()!r} is {length:g} m long): the SV does not fit on it")
    if not half <= sv.position <= length - half:
        raise InputError(src, "sv.position_m", sv.position,
                         f"on lane {lane.getID()!r}: in [{half:g}, {length - half:g}] m from "
                         f"its start (it is {length:g} m long)")


def _check_time_and_planner(src: str, s: Scenario) -> None:
    if s.duration < s.step:
        raise InputError(src, "scenario.duration_s", s.duration,
                         f"at least one step, scenario.step_s = {s.step:g} s")
    lane_change = s.traffic.lanechange_duration
    if 0.0 < lane_change < s.step:
        raise InputError(src, "traffic.lanechange_duration_s", lane_change,
                         f"0 (instant) or at least one step, scenario.step_s = {s.step:g} s")
    ratio = s.duration / s.step
    if abs(ratio - round(ratio)) > STEP_TOLERANCE * max(1.0, ratio):
        raise InputError(src, "scenario.duration_s", s.duration,
                         f"a whole multiple of scenario.step_s = {s.step:g} s")
    if s.planner.tau_step >= s.planner.tau_max:
        raise InputError(src, "planner.tau_step_s", s.planner.tau_step,
                         f"smaller than planner.tau_max_s = {s.planner.tau_max:g} s")
    if s.planner.tau_min_floor > s.planner.tau_max:
        raise InputError(src, "planner.tau_min_floor_s", s.planner.tau_min_floor,
                         f"at most planner.tau_max_s = {s.planner.tau_max:g} s")


def _check_vehicle(src: str, s: Scenario) -> None:
    """The body (centred on the CG) holds both axles and both tracks; gains meet eq. 25."""
    from cosim.control.triple_step import check_gains  # eq. 25 is checked there, once

    v = s.vehicle
    if v.length < v.lf + v.lr:
        raise InputError(src, "vehicle.length_m", v.length,
                         f"at least the wheelbase lf_m + lr_m = {v.lf + v.lr:g} m")
    if v.width < 2.0 * v.half_track:
        raise InputError(src, "vehicle.width_m", v.width,
                         f"at least the track 2 half_track_m = {2 * v.half_track:g} m")
    try:
        check_gains(s.gains)
    except InputError as exc:
        raise InputError(src, f"controller.{exc.key}", exc.value, exc.allowed) from None


def _lanes_allowed(n: int) -> str:
    return f"a lane index 0..{n - 1} (road.lane_speeds_kmh has {n} lanes)"


def _check_speed_limit(src: str, key: str, speed: float, lane: int, net: Highway) -> None:
    """SUMO refuses to insert a vehicle faster than its lane's limit ("Departure speed ...
    too high"): say so now."""
    limit = net.lane_speeds[lane]
    # within the network's rounding: netconvert's default 2 decimals write 120 km/h as 33.33
    if speed > limit + max(SPEED_TOLERANCE, net.rounding):
        raise InputError(src, key, round(speed * KMH, 6),
                         f"at most lane {lane}'s speed limit in the network, "
                         f"{limit * KMH:.6g} km/h (SUMO inserts no faster vehicle)")


def _check_sv(src: str, s: Scenario, net: Highway) -> None:
    """Lane, speed band and limit, scripted lane changes one lane at a time."""
    n = s.road.n_lanes
    sv = s.sv
    if sv.lane >= n:
        raise InputError(src, "sv.lane", sv.lane, _lanes_allowed(n))
    lo, hi = s.road.speed_bands[sv.lane]
    eps = 1e-9
    if not sv.decision and not lo - eps <= sv.speed <= hi + eps:
        raise InputError(
            src, "sv.speed_kmh", round(sv.speed * KMH, 6),
            f"within lane {sv.lane}'s band [{lo * KMH:g}, {hi * KMH:g}] km/h "
            "(the method's assumption; set sv.decision = true for free traffic)",
        )
    _check_speed_limit(src, "sv.speed_kmh", sv.speed, sv.lane, net)
    lane, last_at = sv.lane, -1.0
    for i, cmd in enumerate(sv.lane_changes):
        key = f"sv.lane_changes[{i}]"
        if cmd.at >= s.duration:
            raise InputError(src, f"{key}.at_s", cmd.at,
                             f"a time before the run ends (scenario.duration_s = {s.duration:g} s)")
        if cmd.at <= last_at:
            raise InputError(src, f"{key}.at_s", cmd.at,
                             f"after the previous request's at_s = {last_at:g} s")
        if cmd.target_lane >= n:
            raise InputError(src, f"{key}.target_lane", cmd.target_lane, _lanes_allowed(n))
        if abs(cmd.target_lane - lane) != 1:
            raise InputError(src, f"{key}.target_lane", cmd.target_lane,
                             f"a lane next to lane {lane} (one lane at a time)")
        lane, last_at = cmd.target_lane, cmd.at


def _check_tvs(src: str, s: Scenario, net: Highway) -> None:
    """Ids unique and free (not the SV's, not the random traffic's), lanes that exist,
    lane changes to an adjacent lane, start speeds SUMO accepts."""
    from cosim.traffic.demand import RANDOM_ID  # the random traffic's ids

    n = s.road.n_lanes
    seen: dict[str, int] = {}
    for i, tv in enumerate(s.tvs):
        key = f"tv[{i}]"
        if tv.id in seen:
            raise InputError(src, f"{key}.id", tv.id, f"unique (tv[{seen[tv.id]}] has it)")
        seen[tv.id] = i
        if tv.id == SV_ID:
            raise InputError(src, f"{key}.id", tv.id, f"an id other than the SV's {SV_ID!r}")
        if s.traffic.density > 0 and RANDOM_ID.fullmatch(tv.id):
            raise InputError(src, f"{key}.id", tv.id,
                             f"an id not of the random traffic's form {RANDOM_ID.pattern} "
                             "(traffic.density_veh_per_km_lane > 0)")
        if tv.lane >= n:
            raise InputError(src, f"{key}.lane", tv.lane, _lanes_allowed(n))
        lc = tv.lane_change
        if tv.brake is not None and lc is not None:
            raise InputError(src, f"{key}.brake", "[tv.brake]",
                             "a TV without [tv.lane_change] (braking is scripted in its lane)")
        if lc is not None:
            if lc.target_lane >= n:
                raise InputError(src, f"{key}.lane_change.target_lane", lc.target_lane,
                                 _lanes_allowed(n))
            if abs(lc.target_lane - tv.lane) != 1:
                raise InputError(src, f"{key}.lane_change.target_lane", lc.target_lane,
                                 f"a lane next to the TV's lane {tv.lane}")
            if lc.start <= -lc.tau:
                raise InputError(src, f"{key}.lane_change.start_s", lc.start,
                                 f"after -tau_s = {-lc.tau:g} s (a finished change: put the TV "
                                 "in its target lane)")
            if lc.start >= s.duration:
                raise InputError(
                    src, f"{key}.lane_change.start_s", lc.start,
                    f"a time before the run ends (scenario.duration_s = {s.duration:g} s)")
        _check_speed_limit(src, f"{key}.speed_kmh", _start_pose(tv, s, net)[3], tv.lane, net)


def _check_lanes_open(src: str, s: Scenario, net: Highway) -> None:
    """Every lane a vehicle is put into or sent to allows passenger cars (the class of
    every vehicle type cosim makes): SUMO refuses the insertion otherwise ("Invalid
    departLane definition") or never changes into the lane."""
    closed = set(net.closed_lanes())
    if not closed:
        return

    def refuse(key: str, value: object, lane: int, allowed: str) -> None:
        raise InputError(src, key, value,
                         f"{allowed} (lane {lane} of the network {s.network.name} is closed to "
                         "passenger cars by its allow / disallow; every vehicle cosim adds is "
                         "one)")

    open_lane = "a lane open to passenger cars"
    if s.traffic.density > 0:
        refuse("traffic.density_veh_per_km_lane", s.traffic.density, min(closed),
               "0 on this network (random traffic enters every lane)")
    sv = s.sv
    if sv.lane in closed:
        refuse("sv.lane", sv.lane, sv.lane, open_lane)
    for i, cmd in enumerate(sv.lane_changes):
        if cmd.target_lane in closed:
            refuse(f"sv.lane_changes[{i}].target_lane", cmd.target_lane, cmd.target_lane,
                   open_lane)
    if sv.decision:
        refuse("sv.decision", True, min(closed),
               "false on this network (by the traffic rule the SV may change to any lane)")
    for i, tv in enumerate(s.tvs):
        if tv.lane in closed:
            refuse(f"tv[{i}].lane", tv.lane, tv.lane, open_lane)
        if tv.lane_change is not None and tv.lane_change.target_lane in closed:
            refuse(f"tv[{i}].lane_change.target_lane", tv.lane_change.target_lane,
                   tv.lane_change.target_lane, open_lane)


def _start_pose(tv: TVSpec, s: Scenario, net: Highway) -> tuple[float, float, float, float]:
    """x, y, heading and speed of a TV at t = 0, as its script puts it in SUMO."""
    from cosim.traffic.scripted import kinematics

    k = kinematics(tv, np.zeros(1), s.road, net.x_start + s.sv.position)
    return float(k.x[0]), float(k.y[0]), float(k.heading[0]), float(k.speed[0])


def _check_no_overlap(src: str, s: Scenario, net: Highway) -> None:
    """No two bodies overlap at t = 0: a TV mid-lane-change on the SV, two TVs on each
    other, wide vehicles side by side in adjacent lanes (rectangles, separating axes)."""
    from cosim.planning.collision import Box, overlap_sat

    x_sv = net.x_start + s.sv.position
    bodies = [("the SV", x_sv, s.road.lane_center(s.sv.lane), 0.0, s.vehicle.length,
               s.vehicle.width)]
    for tv in s.tvs:
        x, y, h, _ = _start_pose(tv, s, net)
        bodies.append((f"TV {tv.id!r}", x, y, h, tv.length, tv.width))
    for i in range(1, len(bodies)):
        _, x, y, h, length, width = bodies[i]
        for other, ox, oy, oh, olength, owidth in bodies[:i]:
            if bool(overlap_sat(Box(x, y, h, length, width), Box(ox, oy, oh, olength, owidth))):
                tv = s.tvs[i - 1]
                raise InputError(
                    src, f"tv[{i - 1}].gap_m", tv.gap,
                    f"a start clear of {other} at t = 0 (their bodies overlap: centres "
                    f"{x - ox:+.3g} m along and {y - oy:+.3g} m across the road, "
                    f"widths {width:g} and {owidth:g} m)",
                )


def _check_density(src: str, s: Scenario) -> None:
    """Random traffic no denser than its lanes hold at standstill, bumper to bumper at
    SUMO's minGap: SUMO would insert only what fits and leave the rest waiting."""
    from cosim.traffic.demand import TV_MIN_GAP
    from cosim.traffic.traffic_vehicles import TV_LENGTH

    capacity = 1000.0 / (TV_LENGTH + TV_MIN_GAP)  # veh/km/lane
    if s.traffic.density > capacity:
        raise InputError(src, "traffic.density_veh_per_km_lane", s.traffic.density,
                         f"at most {capacity:.1f} veh/km/lane, what a lane holds at "
                         f"standstill: 1000 m / (TV length {TV_LENGTH:g} m + minGap "
                         f"{TV_MIN_GAP:g} m)")


def _check_positions(src: str, s: Scenario, net: Highway) -> None:
    """Every vehicle starts on the road, the random traffic fits on it, and the SV cannot
    run off its end in `duration` (SUMO would drop it silently)."""
    length = net.length
    half = 0.5 * s.vehicle.length
    if length < s.vehicle.length:
        raise InputError(
            src, "road.network", str(net.path),
            f"a road at least as long as the SV ({s.vehicle.length:g} m; the network's "
            f"edge is {length:g} m long): the SV does not fit on it")
    if not half <= s.sv.position <= length - half:
        raise InputError(
            src, "sv.position_m", s.sv.position,
            f"on the road: in [{half:g}, {length - half:g}] m from its start "
            f"(the network's edge is {length:g} m long)",
        )
    for i, tv in enumerate(s.tvs):
        x = s.sv.position + tv.gap
        if not 0.5 * tv.length <= x <= length - 0.5 * tv.length:
            raise InputError(
                src, f"tv[{i}].gap_m", tv.gap,
                f"a gap that puts the TV on the road (x = {x:g} m from the road's start is "
                f"outside [0, {length:g}] m)",
            )
    _check_density(src, s)
    if s.traffic.density > 0 and s.traffic.length > length:
        raise InputError(src, "traffic.length_m", s.traffic.length,
                         f"at most the network's length {length:g} m")
    lanes = {s.sv.lane} | {c.target_lane for c in s.sv.lane_changes}
    if s.sv.decision:
        lanes = set(range(s.road.n_lanes))
    fastest = max(
        [s.sv.speed, s.sv.desired_speed or 0.0] + [s.road.speed_bands[k][1] for k in lanes]
    )
    end = s.sv.position + fastest * s.duration + half
    if end > length:
        raise InputError(
            src, "scenario.duration_s", s.duration,
            f"short enough for the SV to stay on the {length:g} m road "
            f"(at {fastest * KMH:g} km/h from {s.sv.position:g} m it reaches {end:g} m)",
        )
    # a scripted TV moves forward only: where it is at the end is the farthest it gets
    t_end = s.duration + 2.0 * s.step  # the simulation evaluates scripts a step past the end
    from cosim.traffic.scripted import kinematics

    for i, tv in enumerate(s.tvs):
        k = kinematics(tv, np.array([t_end]), s.road, net.x_start + s.sv.position)
        front = float(k.x[0]) - net.x_start + 0.5 * tv.length
        if front > length:
            raise InputError(
                src, f"tv[{i}].gap_m", tv.gap,
                f"a gap that keeps the TV on the {length:g} m road until scenario.duration_s = "
                f"{s.duration:g} s (its script takes its front to {front:.6g} m; SUMO would "
                "drop it)",
            )
