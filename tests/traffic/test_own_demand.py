"""The user's own SUMO demand: route / flow / vType files used as they are
(`[traffic] routes`) or through a `.sumocfg` (`[road] sumocfg`), with a warm-up before
the SV enters. Real SUMO runs of the shipped scenarios (scenarios/own_demand_*.toml)."""

from __future__ import annotations

import csv
import gzip
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from cosim.errors import InputError
from cosim.run.loop import run_scenario
from cosim.scenario import load_scenario, project_root, scenario_to_dict, with_overrides
from cosim.traffic.own_demand import copy_for_sumo, dry_load, read_sumocfg

ROOT = project_root()
ROUTES = ROOT / "scenarios" / "own_demand_routes.toml"
SUMOCFG = ROOT / "scenarios" / "own_demand_sumocfg.toml"
OUTPUTS = ("trace.csv", "plans.csv", "metrics.csv")
WARMUP = 60.0  # s, long enough for their flows to pass the SV's start at 1 km


def _short(path: Path, **changes: object) -> object:
    """The shipped scenario, 8 s after a 60 s warm-up, under one name (the name is the
    metrics' first column: the two twins then write the same bytes)."""
    return with_overrides(load_scenario(path), duration=8.0, name="own_demand",
                          **{"traffic.warmup_s": WARMUP}, **changes)


def _run(path: Path, out: Path, **kw: object) -> dict[str, bytes]:
    run_scenario(_short(path), out, write_figures=False, **kw)
    return {name: (out / name).read_bytes() for name in OUTPUTS}


def test_routes_and_sumocfg_give_the_same_run_and_the_seed_decides(tmp_path: Path) -> None:
    """The scenario with [road] network + [traffic] routes and its twin with [road]
    sumocfg (the same net and route file, other options of the .sumocfg ignored) write
    the same trace, plans and metrics, byte for byte; the same seed again the same
    bytes; another seed other traffic (SUMO gets the scenario's seed, not the cfg's)."""
    a = _run(ROUTES, tmp_path / "routes", fcd=True)
    b = _run(SUMOCFG, tmp_path / "sumocfg")
    again = _run(ROUTES, tmp_path / "again")
    assert a == b
    assert a == again
    run_scenario(_short(ROUTES, seed=2), tmp_path / "seed2", write_figures=False)
    assert (tmp_path / "seed2" / "trace.csv").read_bytes() != a["trace.csv"]

    rows = list(csv.DictReader((tmp_path / "routes" / "trace.csv").open()))
    metrics = next(csv.DictReader((tmp_path / "routes" / "metrics.csv").open()))
    # their traffic is around the SV from its first row on (no random or scripted TVs)
    assert int(rows[0]["n_tvs"]) >= 3
    assert min(int(r["n_tvs"]) for r in rows) >= 1
    assert float(rows[0]["t_s"]) == 0.0
    assert metrics["collisions"] == "0" and metrics["sumo_collisions"] == "0"
    assert float(metrics["min_gap_m"]) > 2.0

    # SUMO ran their demand alone for the warm-up: the SV's first sample is at SUMO's
    # time warmup_s (fcd.xml keeps SUMO's clock: the trace's t is it minus warmup_s),
    # theirs from the first seconds on
    fcd = ET.parse(tmp_path / "routes" / "fcd.xml").getroot()
    first: dict[str, float] = {}
    for step in fcd.iter("timestep"):
        for v in step.iter("vehicle"):
            first.setdefault(v.get("id", ""), float(step.get("time", "nan")))
    assert first["sv"] == pytest.approx(WARMUP)
    theirs = {vid: t for vid, t in first.items() if vid != "sv"}
    assert min(theirs.values()) < 5.0
    assert all(vid.startswith(("cars.", "trucks.")) for vid in theirs)


def test_gzipped_route_files_are_read_as_sumo_reads_them(tmp_path: Path) -> None:
    """Their flows as a .rou.xml.gz (SUMO reads gzipped XML): the same run, byte for byte;
    a .gz that is not gzip is refused in one line before SUMO starts."""
    plain = _run(ROUTES, tmp_path / "plain")
    flows = ROOT / "scenarios" / "own_demand" / "flows.rou.xml"
    packed = tmp_path / "flows.rou.xml.gz"
    packed.write_bytes(gzip.compress(flows.read_bytes()))
    sc = with_overrides(_short(ROUTES), **{"traffic.routes": [str(packed)]})
    run_scenario(sc, tmp_path / "gz", write_figures=False)
    assert {n: (tmp_path / "gz" / n).read_bytes() for n in OUTPUTS} == plain
    broken = tmp_path / "broken.rou.xml.gz"
    broken.write_bytes(flows.read_bytes())
    with pytest.raises(InputError, match=r"broken\.rou\.xml\.gz"):
        run_scenario(with_overrides(_short(ROUTES), **{"traffic.routes": [str(broken)]}),
                     tmp_path / "broken", write_figures=False)
    assert not (tmp_path / "broken").exists()


def test_the_sumo_driven_sv_joins_their_traffic(tmp_path: Path) -> None:
    """Controller "sumo": SUMO drives the SV among their vehicles, no collision."""
    run_scenario(_short(ROUTES, controller="sumo"), tmp_path, write_figures=False)
    rows = list(csv.DictReader((tmp_path / "trace.csv").open()))
    metrics = next(csv.DictReader((tmp_path / "metrics.csv").open()))
    assert len(rows) == 161 and int(rows[0]["n_tvs"]) >= 3
    assert metrics["collisions"] == "0"


def test_own_demand_scenarios_round_trip() -> None:
    """scenario_to_dict gives the same scenario back (route files and the .sumocfg as
    absolute paths, the network left out beside a .sumocfg)."""
    import json

    from cosim.scenario import scenario_from_dict

    for path in (ROUTES, SUMOCFG):
        s = load_scenario(path)
        d = json.loads(json.dumps(scenario_to_dict(s), default=str))
        assert ("network" in d["road"]) == (s.sumocfg is None)
        back = scenario_from_dict(d, path=s.path)
        assert back == s and back.demand == s.demand and s.demand is not None
        assert s.demand.warmup == 120.0


def test_a_sumocfg_gives_its_input_files_only(tmp_path: Path) -> None:
    """From a .sumocfg: net-file, route-files (comma-separated) and additional-files,
    relative to it; every other option is ignored. From additional-files SUMO gets the
    demand only (vTypes, routes, vehicles, flows): a detector, which would write a file of
    its own, is left out, so the scenario loads (SUMO's dry load passes) and runs write
    nothing else."""
    net = ROOT / "networks" / "highway.net.xml"
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "types.add.xml").write_text(
        '<additional>\n  <vType id="lorry" length="12" vClass="truck"/>\n'
        '  <inductionLoop id="d1" lane="highway_0" pos="100" period="60" file="d1.xml"/>\n'
        '</additional>\n')
    (tmp_path / "a.rou.xml").write_text(
        '<routes><flow id="lorries" type="lorry" from="highway" to="highway" begin="0" '
        'end="3600" vehsPerHour="300"/></routes>\n')
    (tmp_path / "b.rou.xml").write_text(
        '<routes><flow id="vans" from="highway" to="highway" begin="0" end="3600" '
        'vehsPerHour="300"/></routes>\n')
    cfg = tmp_path / "x.sumocfg"
    cfg.write_text(
        f'<configuration><input><net-file value="{net}"/>'
        '<route-files value="a.rou.xml, b.rou.xml"/>'
        '<additional-files value="sub/types.add.xml"/></input>'
        '<time><step-length value="1"/><end value="10"/></time>'
        '<output><fcd-output value="fcd.xml"/></output></configuration>\n')
    found = read_sumocfg("s.toml", "road.sumocfg", "x.sumocfg", cfg)
    assert found.net_file == net.resolve()
    assert found.route_files == (tmp_path / "a.rou.xml", tmp_path / "b.rou.xml")
    assert found.additional_files == (tmp_path / "sub" / "types.add.xml",)
    out = tmp_path / "out"
    out.mkdir()
    copy = ET.parse(copy_for_sumo(found.additional_files[0], out)).getroot()
    assert [e.tag for e in copy] == ["vType"]

    doc = scenario_to_dict(load_scenario(ROUTES))
    del doc["road"]["network"], doc["traffic"]["routes"]
    doc["road"]["sumocfg"] = str(cfg)
    scenario = (tmp_path / "s.toml")
    from cosim.scenario import scenario_from_dict

    s = scenario_from_dict(doc, path=scenario)
    assert s.network == net.resolve() and s.sumocfg == cfg
    assert s.demand is not None and s.demand.route_files == found.route_files
    assert s.step == 0.05  # the scenario's, not the .sumocfg's
    assert not (tmp_path / "sub" / "d1.xml").exists() and not (tmp_path / "fcd.xml").exists()


def test_their_flows_on_the_curved_motorway(tmp_path: Path) -> None:
    """Their flows over a route of four edges with a lane added and dropped (the shipped
    curved motorway), one of them entering on the second edge: after the warm-up the SV
    starts among them (their vehicles taken off its start zone), no collision, and their
    vehicles are the only traffic around it."""
    (tmp_path / "flows.rou.xml").write_text(
        '<routes>\n'
        '  <vType id="car" length="4.5" sigma="0.5" maxSpeed="36"/>\n'
        '  <flow id="cars" type="car" from="e1" to="e4" begin="0" end="3600" '
        'vehsPerHour="3300" departLane="random" departSpeed="max"/>\n'
        '  <flow id="joining" type="car" begin="0" end="3600" vehsPerHour="300" '
        'departLane="0" departSpeed="max"><route edges="e2 e3 e4"/></flow>\n'
        '</routes>\n')
    curved = load_scenario(ROOT / "scenarios" / "curved_traffic_high.toml")
    doc = scenario_to_dict(curved)
    doc["traffic"].update(density_veh_per_km_lane=0.0, routes=["flows.rou.xml"],
                          warmup_s=100.0)
    doc["scenario"].update(duration_s=6.0, name="curved_own")
    from cosim.run.loop import simulate
    from cosim.scenario import scenario_from_dict

    s = scenario_from_dict(doc, path=tmp_path / "curved_own.toml")
    result = simulate(s)
    n_tvs = result.trace["n_tvs"]
    assert n_tvs[0] >= 3 and n_tvs.min() >= 1
    assert result.metrics["collisions"] == 0 and result.metrics["sumo_events"] == 0
    assert result.metrics["min_gap_m"] > 2.0


def test_the_warm_up_leaves_the_start_zone_free() -> None:
    """After the warm-up SUMO's clock is at warmup_s and their vehicles that were inside
    the SV's start zone (its lane: room to brake at its speed ahead, for its follower
    behind; two SV lengths around it in the others) are gone; the rest of the road keeps
    theirs."""
    from cosim.traffic.demand import start_zone
    from cosim.traffic.world import SV_LENGTH_MARGIN, World

    s = _short(ROUTES)
    world = World(s)
    try:
        world.start()
        assert world.sumo.time == pytest.approx(WARMUP)
        assert world.cleared  # 3000 veh/h: some were in the zone
        # what SUMO has now (a snapshot is read at a step: it would still show them);
        # on the straight highway x is s, SUMO's position the front bumper
        vehicle = world.sumo.api.vehicle
        ids = list(vehicle.getIDList())
        hi = np.array([vehicle.getPosition(v)[0] for v in ids])
        lo = hi - np.array([vehicle.getLength(v) for v in ids])
        lanes = np.array([vehicle.getLaneIndex(v) for v in ids])
        x0, lane = world.sv_start_x, world.sv_start_track
        margin = SV_LENGTH_MARGIN * s.vehicle.length
        z_lo, z_hi = start_zone(x0, s.vehicle.length, s.sv.speed, s.road.speed_bands[lane][1])
        assert not ((hi >= x0 - margin) & (lo <= x0 + margin)).any()
        assert not ((lanes == lane) & (hi >= z_lo) & (lo <= z_hi)).any()
        assert len(ids) > 40 and not set(world.cleared) & set(ids)
        # without the clearing they were there
        snap = world.read_all()
        assert set(world.cleared) <= set(snap.ids)
        # what the policy and V2V read is timed on the run's clock (SUMO's minus the
        # warm-up): a message stamped in SUMO's would be extrapolated 60 s back
        assert snap.time == pytest.approx(0.0)
        world.sumo.step()
        assert world.read_all().time == pytest.approx(s.step)
    finally:
        world.close()


def test_a_scripted_tv_among_their_traffic() -> None:
    """A [[tv]] of the scenario starts where the file puts it among their vehicles (its
    start zone cleared like the SV's): no collision, their vehicles around both."""
    from cosim.run.loop import simulate
    from cosim.scenario import scenario_from_dict

    s = _short(ROUTES)
    doc = scenario_to_dict(s)
    doc["tv"] = [{"id": "slow", "lane": 1, "gap_m": 40.0, "speed_kmh": 80.0}]
    result = simulate(scenario_from_dict(doc, path=s.path))
    assert result.metrics["collisions"] == 0 and result.metrics["sumo_events"] == 0
    assert result.trace["n_tvs"][0] >= 4  # the scripted TV and theirs


def test_their_default_vtype_distribution_and_add_root_as_sumo_reads_them(
        tmp_path: Path) -> None:
    """SUMO's shipped scenarios redefine DEFAULT_VEHTYPE as a vTypeDistribution and give
    additional files an <add> root: both accepted; their untyped vehicles take the
    distribution's types, cosim's own vehicles keep SUMO's defaults (their length and
    width are cosim's), and the run drives on."""
    (tmp_path / "types.add.xml").write_text(
        '<add>\n  <vTypeDistribution id="DEFAULT_VEHTYPE">\n'
        '    <vType id="long" probability="0.5" length="12.0"/>\n'
        '    <vType id="short" probability="0.5" length="5.0"/>\n'
        '  </vTypeDistribution>\n</add>\n', encoding="utf-8")
    (tmp_path / "flows.rou.xml").write_text(
        '<routes>\n  <route id="through" edges="highway"/>\n'
        '  <flow id="them" route="through" begin="0" end="3600" vehsPerHour="2400" '
        'departLane="random" departSpeed="max"/>\n</routes>\n', encoding="utf-8")
    cfg = tmp_path / "theirs.sumocfg"
    cfg.write_text(
        f'<configuration><input><net-file value="{ROOT / "networks" / "highway.net.xml"}"/>'
        '<route-files value="flows.rou.xml"/><additional-files value="types.add.xml"/>'
        '</input></configuration>\n', encoding="utf-8")
    sc = with_overrides(_short(SUMOCFG), **{"road.sumocfg": str(cfg)})
    from cosim.run.loop import CoSimulation

    sim = CoSimulation(sc)
    try:
        sim._start()
        api = sim.world.sumo.api
        theirs = [v for v in api.vehicle.getIDList() if v.startswith("them.")]
        assert len(theirs) > 10
        assert {api.vehicle.getTypeID(v) for v in theirs} == {"long", "short"}
        assert api.vehicletype.getLength("long") == 12.0
        sv_type = api.vehicle.getTypeID("sv")
        assert api.vehicletype.getLength(sv_type) == pytest.approx(sc.vehicle.length)
        assert api.vehicletype.getAccel(sv_type) == api.vehicletype.getAccel("cosim_base")
    finally:
        sim.world.close()
    run_scenario(sc, tmp_path / "out", write_figures=False)
    metrics = next(csv.DictReader((tmp_path / "out" / "metrics.csv").open()))
    assert metrics["collisions"] == "0"


def test_a_flow_that_leaves_its_end_to_sumo_is_accepted_as_sumo_runs_it(
        tmp_path: Path) -> None:
    """SUMO's game/corridor: flows with a begin after 0 and no end, which SUMO ends at 24 h
    when the simulation sets no end (as cosim's run does): the check before the run loads
    them as the run does, not ending at its own 0 s. A flow ending before it begins is
    still SUMO's error."""
    net = ROOT / "networks" / "highway.net.xml"
    good = tmp_path / "late.rou.xml"
    good.write_text('<routes><route id="r" edges="highway"/>'
                    '<flow id="late" route="r" begin="3.00" period="exp(0.07)"/>'
                    '<flow id="counted" route="r" begin="5" number="4"/></routes>',
                    encoding="utf-8")
    dry_load("sc.toml", "traffic.routes", [good.name], net, [good], [])
    bad = tmp_path / "backwards.rou.xml"
    bad.write_text('<routes><route id="r" edges="highway"/>'
                   '<flow id="back" route="r" begin="30" end="10" period="2"/></routes>',
                   encoding="utf-8")
    with pytest.raises(InputError, match="SUMO says: Flow 'back' ends before its begin time"):
        dry_load("sc.toml", "traffic.routes", [bad.name], net, [bad], [])
