"""A study's identity (cosim.study.store, DIR/study.json): the contents of every file its
runs read (base scenario, network, .sumocfg, route and additional files), not their
paths. An edited input between two batches into one folder is refused, naming what
changed (--restart replaces the runs); the project moved elsewhere resumes its study.
Real `cosim batch` runs of a scenario with the user's own SUMO demand."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.scenario import project_root

ROOT = project_root()
SCENARIO = (ROOT / "scenarios" / "own_demand_routes.toml").read_text()
FLOWS = ('<routes>\n'
         '  <flow id="lorries" type="lorry" from="highway" to="highway" begin="0" end="3600" '
         'vehsPerHour="600" departLane="0" departSpeed="max"/>\n'
         '  <flow id="vans" type="van" from="highway" to="highway" begin="0" end="3600" '
         'vehsPerHour="1500" departLane="random" departSpeed="max"/>\n'
         '</routes>\n')
TYPES = ('<additional>\n'
         '  <vType id="lorry" length="12" vClass="truck" maxSpeed="25"/>\n'
         '  <vType id="van" length="6" maxSpeed="30"/>\n'
         '</additional>\n')
EXTRA = ('<routes>\n'
         '  <flow id="cars" from="highway" to="highway" begin="0" end="3600" '
         'vehsPerHour="600" departLane="2" departSpeed="max"/>\n'
         '</routes>\n')


def _project(folder: Path) -> Path:
    """A SUMO user's project: a network, a .sumocfg naming a route file and an
    additional file, one more route file, and a scenario naming them all by relative
    paths. Returns the scenario."""
    folder.mkdir()
    shutil.copy(ROOT / "networks" / "highway.net.xml", folder / "road.net.xml")
    (folder / "flows.rou.xml").write_text(FLOWS)
    (folder / "types.add.xml").write_text(TYPES)
    (folder / "extra.rou.xml").write_text(EXTRA)
    (folder / "mine.sumocfg").write_text(
        '<configuration><input><net-file value="road.net.xml"/>'
        '<route-files value="flows.rou.xml"/>'
        '<additional-files value="types.add.xml"/></input></configuration>\n')
    scenario = folder / "mine.toml"
    scenario.write_text(SCENARIO.replace('network = "networks/highway.net.xml"',
                                         'sumocfg = "mine.sumocfg"')
                        .replace('routes = ["own_demand/flows.rou.xml"]',
                                 'routes = ["extra.rou.xml"]')
                        .replace("warmup_s = 120.0", "warmup_s = 10.0"))
    return scenario


def _argv(scenario: Path, out: Path, *flags: str) -> list[str]:
    return ["batch", "--scenario", str(scenario), "--densities", "0", "--seeds", "1",
            "--duration", "2", "--workers", "1", "--no-progress", "--no-plots",
            "-o", str(out), *flags]


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def _snapshot(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*"))
            if p.is_file()}


def test_an_edited_input_file_is_refused_until_restart(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Each file the runs read, edited between two batches into one -o: exit 2, one line
    naming it, the folder untouched; --restart runs again on the edited files, which are
    the study's inputs from then on."""
    scenario = _project(tmp_path / "project")
    out = tmp_path / "study"
    assert main(_argv(scenario, out)) == 0
    assert "1 run now, 0 already done" in capsys.readouterr().out
    before = _snapshot(out)
    base = json.loads((out / "study.json").read_text())["base"]
    assert set(base["inputs"]) == {
        "network", "road.sumocfg", "road.sumocfg route-files[0]",
        "road.sumocfg additional-files[0]", "traffic.routes[0]"}
    project = scenario.parent
    for name, edit, shown in (
        ("flows.rou.xml", ('vehsPerHour="1500"', 'vehsPerHour="1200"'),
         "the contents of road.sumocfg route-files[0] (flows.rou.xml)"),
        ("types.add.xml", ('length="6"', 'length="7"'),
         "the contents of road.sumocfg additional-files[0] (types.add.xml)"),
        ("extra.rou.xml", ('departLane="2"', 'departLane="1"'),
         "the contents of traffic.routes[0] (extra.rou.xml)"),
        ("mine.sumocfg", ("</configuration>", "<!-- note --></configuration>"),
         "the contents of road.sumocfg (mine.sumocfg)"),
        ("road.net.xml", ("</net>", "<!-- note --></net>"),
         "the contents of network (road.net.xml)"),
    ):
        text = (project / name).read_text()
        (project / name).write_text(text.replace(*edit))
        assert main(_argv(scenario, out)) == 2
        line = _one_line(capsys.readouterr().err)
        assert line.startswith(f"cosim batch: error: {out / 'study.json'}: base = "), line
        assert shown in line and "--restart" in line, line
        assert _snapshot(out) == before
        (project / name).write_text(text)

    flows = project / "flows.rou.xml"
    flows.write_text(flows.read_text().replace('vehsPerHour="1500"', 'vehsPerHour="1200"'))
    assert main(_argv(scenario, out, "--restart")) == 0
    assert "1 run now, 0 already done" in capsys.readouterr().out
    assert main(_argv(scenario, out)) == 0  # the edited demand is the study's now
    assert "0 run now, 1 already done" in capsys.readouterr().out


def test_a_study_moved_with_its_project_resumes(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The project (scenario, network, .sumocfg, route and additional files) and its
    study folder copied elsewhere: the study resumes there, no run done again, and its
    identity names no path of either place."""
    first = tmp_path / "here"
    first.mkdir()
    scenario = _project(first / "project")
    assert main(_argv(scenario, first / "study")) == 0
    capsys.readouterr()
    moved = tmp_path / "elsewhere" / "clone"
    shutil.copytree(first, moved)
    shutil.rmtree(first)  # nothing of the first place is left to read
    records = _snapshot(moved / "study" / "runs")
    assert main(_argv(moved / "project" / "mine.toml", moved / "study")) == 0
    assert "0 run now, 1 already done" in capsys.readouterr().out
    assert _snapshot(moved / "study" / "runs") == records
    base = json.dumps(json.loads((moved / "study" / "study.json").read_text())["base"])
    assert str(first) not in base and str(moved) not in base
