"""The user's demand checked as SUMO uses it over the whole run: a vehicle, trip or flow
that departs late (after the dry load's t = 0, during the warm-up or in the run) with a
lane, position or speed SUMO cannot use, or on a route SUMO cannot drive, is refused
before anything runs: exit status 2, one line naming the file, the element, the attribute
and what is allowed, nothing written. Each fault is shown to be one real SUMO stops on
(or silently moves) when that vehicle departs."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.scenario import project_root

ROOT = project_root()
CURVED = ROOT / "networks" / "curved_motorway.net.xml"  # e1 -> e2 -> e3 -> e4, 3-4 lanes
SCENARIO = f"""[scenario]
name = "late"
duration_s = 4.0

[road]
network = "{CURVED}"
route = ["e1", "e2", "e3", "e4"]

[sv]
edge = "e1"
lane = 1
position_m = 600.0
speed_kmh = 100.0

[traffic]
routes = ["late.rou.xml"]
warmup_s = 20.0
"""
GOOD_FLOW = ('<flow id="cars" begin="0" end="3600" vehsPerHour="600" from="e1" to="e4" '
             'departLane="random" departSpeed="max"/>')

# case -> (demand elements, the attribute and value the message shows, what it allows,
#          what SUMO says when that vehicle departs at t = 10 s)
CASES: dict[str, tuple[str, str, str, str]] = {
    "vehicle_depart_lane": (
        '<vehicle id="late" depart="10" departLane="7"><route edges="e1 e2"/></vehicle>',
        "vehicle 'late' departLane='7'", "a lane of edge 'e1' (where it departs) a passenger "
        "may use: 0, 1, 2", "Error: Invalid departLane definition for vehicle 'late'"),
    "flow_depart_lane": (
        '<flow id="fl" begin="10" end="100" number="3" departLane="3" from="e1" to="e4"/>',
        "flow 'fl' departLane='3'", "may use: 0, 1, 2",
        "Error: Invalid departLane definition for vehicle 'fl.0'"),
    "route_not_connected": (
        '<vehicle id="jump" depart="10"><route edges="e1 e3"/></vehicle>',
        "vehicle 'jump' edges='e1 e3'", "consecutive edges connected for a passenger ('e1' "
        "leads to e2",
        "Error: Vehicle 'jump' has no valid route. No connection between edge 'e1' and edge 'e3'"),
    "trip_without_path_in_the_warm_up": (
        '<trip id="back" depart="10" from="e3" to="e1"/>',
        "trip 'back' to='e1'", "an edge a passenger can reach from 'e3'",
        "Error: Vehicle 'back' has no valid route"),
    "flow_without_path": (
        '<flow id="fb" begin="10" end="20" number="2" from="e4" to="e2"/>',
        "flow 'fb' to='e2'", "'e4' leads to no edge", "Error: Vehicle 'fb.0' has no valid route"),
    "depart_speed_above_max_speed": (
        '<vType id="slowcar" maxSpeed="20"/>'
        '<vehicle id="fast" type="slowcar" depart="10" departSpeed="25">'
        '<route edges="e1 e2"/></vehicle>',
        "vehicle 'fast' departSpeed='25'", "in [0, 20] m/s (its vType's maxSpeed",
        "Error: Departure speed for vehicle 'fast' is too high for the vehicle type"),
    "depart_speed_above_lane_limit_without_spread": (
        '<vType id="exact" speedDev="0"/>'
        '<flow id="fs" type="exact" begin="10" end="20" number="2" departSpeed="30" '
        'departLane="0"><route edges="e1 e2"/></flow>',
        "flow 'fs' departSpeed='30'", "lane 'e1_0''s limit times its vType's speedFactor 1",
        "Error: Departure speed for vehicle 'fs.0' is too high for the departure edge"),
    "depart_pos_past_the_edge": (
        '<vehicle id="far" depart="10" departPos="5000"><route edges="e1 e2"/></vehicle>',
        "vehicle 'far' departPos='5000'", "a position on edge 'e1' in [-1501.15, 1501.15] m",
        "Warning: Invalid departPos 5000.00 given for vehicle 'far'"),
    "arrival_lane_not_on_the_last_edge": (
        '<vehicle id="arr" depart="10" arrivalLane="5"><route edges="e1 e2"/></vehicle>',
        "vehicle 'arr' arrivalLane='5'", "a lane index 0..2 of edge 'e2'",
        "Warning: Vehicle 'arr' will not be able to arrive at the given lane"),
}


def _routes(elements: str) -> str:
    return f"<routes>\n    {GOOD_FLOW}\n    {elements}\n</routes>\n"


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_late_fault_is_refused_before_anything_runs(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    elements, shown, allowed, sumo_says = CASES[case]
    (tmp_path / "late.rou.xml").write_text(_routes(elements))
    scenario = tmp_path / "late.toml"
    scenario.write_text(SCENARIO)
    # what SUMO does with it: loading at t = 0 passes, the departure at t = 10 s fails
    done = subprocess.run(
        ["sumo", "-n", str(CURVED), "-r", str(tmp_path / "late.rou.xml"), "--end", "15",
         "--no-step-log", "true", "--duration-log.disable", "true"],
        capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert sumo_says in done.stdout + done.stderr
    assert (done.returncode != 0) == sumo_says.startswith("Error")
    before = sorted(p.name for p in tmp_path.iterdir())

    out = tmp_path / "out"
    assert main(["run", str(scenario), "--out", str(out), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err, err
    assert str(scenario) in err and "traffic.routes[0]" in err, err
    assert f"late.rou.xml: {shown}" in err and allowed in err, err
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_a_sound_late_demand_passes(tmp_path: Path) -> None:
    """The same demand without the faults loads (its late vehicles included)."""
    from cosim.scenario import load_scenario

    (tmp_path / "late.rou.xml").write_text(_routes(
        '<vType id="exact" speedDev="0"/>'
        '<vehicle id="ok" type="exact" depart="10" departLane="2" departSpeed="30" '
        'departPos="-10" arrivalLane="1" arrivalPos="-1"><route edges="e1 e2"/></vehicle>'
        '<trip id="t" depart="300" from="e2" to="e4" via="e3"/>'))
    (tmp_path / "late.toml").write_text(SCENARIO)
    s = load_scenario(tmp_path / "late.toml")
    assert s.demand is not None


def test_a_study_whose_runs_cannot_start_is_refused_before_running(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`cosim batch` on a base scenario whose demand has a late fault: refused like
    `cosim run` (exit 2, one line), no run started, nothing written."""
    elements = CASES["trip_without_path_in_the_warm_up"][0]
    (tmp_path / "late.rou.xml").write_text(_routes(elements))
    scenario = tmp_path / "late.toml"
    scenario.write_text(SCENARIO)
    out = tmp_path / "study"
    assert main(["batch", "--scenario", str(scenario), "--densities", "0", "--seeds", "1-2",
                 "-o", str(out), "--no-progress", "--no-plots", "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "trip 'back' to='e1'" in err, err
    assert not out.exists()
