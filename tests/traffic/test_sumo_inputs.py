"""The user's SUMO files as SUMO gets them (cosim.traffic.own_demand): every file read
gzipped or not through one reader, and SUMO given copies holding their demand only, so
that nothing their files ask SUMO to write lands outside the run's own folders. Real
SUMO runs."""

from __future__ import annotations

import csv
import gzip
import os
import subprocess
from pathlib import Path

import pytest

from cosim.errors import InputError
from cosim.run.loop import run_scenario
from cosim.scenario import load_scenario, project_root, scenario_from_dict, scenario_to_dict

ROOT = project_root()
NETWORK = ROOT / "networks" / "highway.net.xml"
ROUTES = ROOT / "scenarios" / "own_demand_routes.toml"
OUTPUTS = ("trace.csv", "plans.csv", "metrics.csv")

TYPES = ('<additional>\n'
         '  <vType id="lorry" length="12" vClass="truck" maxSpeed="25"/>\n'
         '  <vType id="van" length="6" maxSpeed="30"/>\n'
         '</additional>\n')
FLOWS = ('<routes>\n'
         '  <flow id="lorries" type="lorry" from="highway" to="highway" begin="0" end="3600" '
         'vehsPerHour="600" departLane="0" departSpeed="max"/>\n'
         '  <flow id="vans" type="van" from="highway" to="highway" begin="0" end="3600" '
         'vehsPerHour="1800" departLane="random" departSpeed="max"/>\n'
         '</routes>\n')


def _scenario(tmp: Path, *, sumocfg: Path | None = None, routes: list[str] | None = None,
              name: str = "mine") -> object:
    """The shipped own-demand scenario, 4 s after a 40 s warm-up, on `sumocfg` or with
    `routes` (one name: the metrics' first column)."""
    doc = scenario_to_dict(load_scenario(ROUTES))
    doc["scenario"].update(duration_s=4.0, name=name)
    doc["traffic"]["warmup_s"] = 40.0
    del doc["traffic"]["routes"]
    if sumocfg is not None:
        del doc["road"]["network"]
        doc["road"]["sumocfg"] = str(sumocfg)
    if routes is not None:
        doc["traffic"]["routes"] = routes
    return scenario_from_dict(doc, path=tmp / f"{name}.toml")


def _run(scenario: object, out: Path) -> dict[str, bytes]:
    run_scenario(scenario, out, write_figures=False, progress=False)
    return {name: (out / name).read_bytes() for name in OUTPUTS}


def _sumocfg(folder: Path, additional: str) -> Path:
    cfg = folder / "mine.sumocfg"
    cfg.write_text(f'<configuration><input><net-file value="{NETWORK}"/>'
                   '<route-files value="flows.rou.xml"/>'
                   f'<additional-files value="{additional}"/></input></configuration>\n')
    return cfg


def test_a_gzipped_additional_file_in_a_sumocfg_is_read_as_sumo_reads_it(
        tmp_path: Path) -> None:
    """The vTypes of a .sumocfg's additional file, plain, gzipped (.add.xml.gz) and
    gzipped under a plain name (SUMO tells gzip by its first bytes): the same run, byte
    for byte; a gzipped route file beside them too."""
    (tmp_path / "flows.rou.xml").write_text(FLOWS)
    (tmp_path / "types.add.xml").write_text(TYPES)
    (tmp_path / "types.add.xml.gz").write_bytes(gzip.compress(TYPES.encode()))
    (tmp_path / "packed.xml").write_bytes(gzip.compress(TYPES.encode()))
    runs = {}
    for additional in ("types.add.xml", "types.add.xml.gz", "packed.xml"):
        folder = tmp_path / additional.replace(".", "_")
        folder.mkdir()
        for name in ("flows.rou.xml", additional):
            (folder / name).write_bytes((tmp_path / name).read_bytes())
        runs[additional] = _run(_scenario(folder, sumocfg=_sumocfg(folder, additional)),
                                folder / "out")
    assert runs["types.add.xml"] == runs["types.add.xml.gz"] == runs["packed.xml"]
    rows = list(csv.DictReader((tmp_path / "types_add_xml_gz" / "out" / "trace.csv").open()))
    assert min(int(r["n_tvs"]) for r in rows) >= 1  # their lorries and vans

    (tmp_path / "flows.rou.xml.gz").write_bytes(gzip.compress(FLOWS.encode()))
    both = _scenario(tmp_path, routes=[str(tmp_path / "packed.xml"),
                                       str(tmp_path / "flows.rou.xml.gz")])
    assert _run(both, tmp_path / "both") == runs["types.add.xml"]


def test_a_file_that_includes_another_is_refused(tmp_path: Path) -> None:
    (tmp_path / "types.add.xml").write_text(TYPES)
    (tmp_path / "flows.rou.xml").write_text(FLOWS.replace(
        "<routes>\n", '<routes>\n  <include href="types.add.xml"/>\n'))
    with pytest.raises(InputError) as info:
        _scenario(tmp_path, routes=[str(tmp_path / "flows.rou.xml")])
    line = str(info.value)
    assert "traffic.routes[0]" in line and "include" in line and "\n" not in line


# What a SUMO user's files may ask SUMO to write: SSM devices on vTypes (one with a file
# of its own, one writing SUMO's default ssm_<id>.xml into the working folder), and, in
# an <additional> file given as a route file or through a .sumocfg, edge data and
# induction loops writing to absolute paths and beside the file.
SSM_ROUTES = '''<routes>
  <vType id="watched" length="4.5" maxSpeed="33">
    <param key="has.ssm.device" value="true"/>
    <param key="device.ssm.file" value="{outside}/ssm_watched.xml"/>
  </vType>
  <vType id="watched_default" length="4.5" maxSpeed="33">
    <param key="has.ssm.device" value="true"/>
    <param key="device.ssm.measures" value="TTC"/>
  </vType>
  <flow id="cars" type="watched" from="highway" to="highway" begin="0" end="3600"
        vehsPerHour="1200" departLane="random" departSpeed="max"/>
  <flow id="others" type="watched_default" from="highway" to="highway" begin="0"
        end="3600" vehsPerHour="900" departLane="random" departSpeed="max"/>
</routes>
'''
DETECTORS = '''<additional>
  <vType id="lorry_{tag}" length="12" vClass="truck" maxSpeed="25"/>
  <edgeData id="edges" file="{outside}/edgedata_{tag}.xml" period="5"/>
  <laneData id="lanes" file="{outside}/lanedata_{tag}.xml" period="5"/>
  <e1Detector id="loop_{tag}" lane="highway_0" pos="200" period="5"
              file="{outside}/e1_{tag}.xml"/>
  <inductionLoop id="near_{tag}" lane="highway_1" pos="300" period="5"
                 file="e1_beside_{tag}.xml"/>
  <flow id="lorries_{tag}" type="lorry_{tag}" from="highway" to="highway" begin="0" end="3600"
        vehsPerHour="300" departLane="0" departSpeed="max"/>
</additional>
'''


def _files(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()}


def test_nothing_their_files_ask_sumo_to_write_lands_outside(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """SSM devices with a file of their own or SUMO's default file, and detectors and
    edge / lane data in an <additional> file given as a route file and through a
    .sumocfg: SUMO run on the files as they are writes them (the control); cosim's load
    (SUMO's dry load of the demand) and run write nothing but the run's own folder, and
    their vehicles still drive (the demand is kept)."""
    outside = tmp_path / "outside"
    project = tmp_path / "project"
    work = tmp_path / "work"  # the working folder: SSM's default files would land here
    for folder in (outside, project, work):
        folder.mkdir()
    (project / "ssm.rou.xml").write_text(SSM_ROUTES.format(outside=outside))
    (project / "detectors.xml").write_text(DETECTORS.format(outside=outside, tag="route"))
    (project / "cfg.add.xml").write_text(DETECTORS.format(outside=outside, tag="cfg"))
    cfg = project / "mine.sumocfg"
    cfg.write_text(f'<configuration><input><net-file value="{NETWORK}"/>'
                   '<route-files value="ssm.rou.xml"/>'
                   '<additional-files value="cfg.add.xml"/></input></configuration>\n')

    # the control: SUMO on their files as they are writes outside and in the working folder
    import sumolib

    control = tmp_path / "control"
    control.mkdir()
    subprocess.run([sumolib.checkBinary("sumo"), "-c", str(cfg), "-r",
                    f"{project / 'ssm.rou.xml'},{project / 'detectors.xml'}",
                    "--end", "30", "--route-steps", "0", "--no-step-log", "true",
                    "--no-warnings", "true"], cwd=control, check=True, capture_output=True)
    written = _files(outside) | {f"control/{n}" for n in _files(control)} | {
        f"project/{n}" for n in _files(project) if n.startswith("e1_beside")}
    assert {"ssm_watched.xml", "edgedata_route.xml", "e1_cfg.xml", "lanedata_cfg.xml",
            "project/e1_beside_route.xml", "project/e1_beside_cfg.xml"} <= written
    assert any(n.startswith("control/ssm_others.") for n in written), written
    for folder in (outside, control):
        for name in _files(folder):
            (folder / name).unlink()
    for name in _files(project):
        if name.startswith("e1_beside"):
            (project / name).unlink()

    monkeypatch.chdir(work)
    before = _files(tmp_path)
    scenario = _scenario(project, sumocfg=cfg, routes=[str(project / "detectors.xml")])
    out = tmp_path / "out"
    run_scenario(scenario, out, write_figures=False, progress=False)
    rows = list(csv.DictReader((out / "trace.csv").open()))
    assert min(int(r["n_tvs"]) for r in rows) >= 1  # their vehicles are on the road
    new = _files(tmp_path) - before
    assert new and all(n.startswith("out/") for n in new), sorted(new)
    assert _files(outside) == set() and _files(work) == set()


def test_device_outputs_go_into_the_runs_temporary_folder(tmp_path: Path) -> None:
    """The copy SUMO gets: the demand kept, detectors and data left out, device output
    files (any device's *.file / *.output param) pointing into the temporary folder, the
    files a vType reads still the user's."""
    import xml.etree.ElementTree as ET

    from cosim.traffic.own_demand import sumo_file_options

    user = tmp_path / "user"
    run = tmp_path / "run"
    user.mkdir()
    run.mkdir()
    (user / "ssm.rou.xml").write_text(SSM_ROUTES.format(outside="/nowhere").replace(
        '<vType id="watched_default"', '<vType id="watched_default" imgFile="car.png"')
        .replace('<param key="device.ssm.measures" value="TTC"/>',
                 '<param key="device.ssm.measures" value="TTC"/>\n'
                 '    <param key="device.toc.file" value="toc.xml"/>'))
    (user / "detectors.xml").write_text(DETECTORS.format(outside="/nowhere", tag="x"))
    options = dict(sumo_file_options([user / "ssm.rou.xml", user / "detectors.xml"], [],
                                     run))
    assert options["--device.ssm.file"] == str(run / "device_ssm.xml")
    routes = [Path(p) for p in options["--route-files"].split(",")]
    assert [p.parent for p in routes] == [run, run]
    first, second = (ET.parse(p).getroot() for p in routes)
    assert [e.tag for e in second] == ["vType", "flow"]
    params = {p.get("key"): p.get("value") for p in first.iter("param")}
    assert Path(params["device.ssm.file"]).parent == run
    assert Path(params["device.toc.file"]).parent == run
    assert params["device.ssm.measures"] == "TTC" and params["has.ssm.device"] == "true"
    assert first.find("vType[@id='watched_default']").get("imgFile") == str(user / "car.png")
    assert sorted(os.listdir(user)) == ["detectors.xml", "ssm.rou.xml"]  # nothing added


def test_a_gzipped_network_is_read_as_the_plain_one(tmp_path: Path) -> None:
    """A network in netconvert's default 2 decimals (lane centres 1.88 / 5.62 / 9.38),
    gzipped: its decimals are read from the unpacked file, so it is the same road as the
    plain one (not refused for lanes off by the rounding)."""
    import dataclasses

    from cosim.traffic.network import NETWORK_DIR, load_highway, netconvert_binary

    plain = tmp_path / "two.net.xml"
    subprocess.run([netconvert_binary(), "-n", str(NETWORK_DIR / "highway.nod.xml"),
                    "-e", str(NETWORK_DIR / "highway.edg.xml"), "-o", str(plain),
                    "--no-turnarounds", "true", "--offset.disable-normalization", "true"],
                   check=True, capture_output=True)
    assert 'shape="0.00,1.88 ' in plain.read_text()
    packed = tmp_path / "two.net.xml.gz"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    road = load_highway(plain)
    assert dataclasses.replace(load_highway(packed), path=plain) == road
    assert road.rounding == pytest.approx(0.005, abs=1e-6)
