"""Messages say what happened in the user's terms: the paths searched as the user wrote
them (~ expanded), the scenario's own keys, what is wrong rather than what was allowed,
help as plain text, and `cosim track` planning case 5.1 as `cosim plan` does."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from cosim.cli import build_parser, main
from cosim.errors import InputError
from cosim.scenario import scenario_from_dict

sys.path.insert(0, str(Path(__file__).parent / "road"))
from handdrawn import curved_route, netconvert  # noqa: E402

HERE = Path(__file__).resolve().parent
BASE = HERE / "bad_inputs" / "base.toml"


def _error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def test_a_home_relative_network_names_the_path_searched(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    scenario = tmp_path / "s.toml"
    scenario.write_text(BASE.read_text().replace("[road]\n",
                                                 '[road]\nnetwork = "~/nets/x.net.xml"\n'))
    line = _error(["run", str(scenario), "--no-figures"], capsys)
    assert line.endswith(f"(not found: {tmp_path / 'home' / 'nets' / 'x.net.xml'})"), line


def test_a_missing_file_is_not_found(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "nowhere.toml"
    assert _error(["run", str(missing)], capsys) == (
        f"cosim run: error: {missing}: file = '{missing}': not found (a scenario file, .toml)")
    line = _error(["batch", "--scenario", str(missing), "--densities", "0", "--seeds", "1",
                   "--no-progress"], capsys)
    assert line.endswith(f"--scenario = '{missing}': not found (a scenario file, .toml)")


def test_a_batch_without_a_study_says_it_is_missing(capsys: pytest.CaptureFixture[str]) -> None:
    line = _error(["batch", "--no-progress"], capsys)
    assert line.startswith("cosim batch: error: command line: STUDY = <missing>: "
                           "the study file is missing"), line
    assert "None" not in line


def test_a_route_that_cannot_be_smoothed_is_told_under_road_route(tmp_path: Path) -> None:
    net = curved_route(tmp_path, 400.0)  # 11.5 degree kinks
    doc = {"scenario": {"name": "coarse", "duration_s": 5.0},
           "road": {"network": str(net), "route": ["AB", "BC"], "mu": 0.8},
           "sv": {"edge": "AB", "lane": 1, "position_m": 500.0, "speed_kmh": 100.0}}
    with pytest.raises(InputError) as err:
        scenario_from_dict(doc, path=tmp_path / "s.toml")
    assert err.value.key == "road.route" and err.value.value == ["AB", "BC"]
    assert str(err.value).startswith(f"{tmp_path / 's.toml'}: road.route = ['AB', 'BC']: ")
    assert "(reference line radius: " in str(err.value)


def test_an_edge_too_short_for_the_sv_says_so(tmp_path: Path) -> None:
    net = netconvert(
        tmp_path,
        '<nodes><node id="A" x="0" y="0"/><node id="B" x="1" y="0"/>'
        '<node id="C" x="1000" y="0"/></nodes>',
        '<edges><edge id="AB" from="A" to="B" numLanes="2" speed="30"/>'
        '<edge id="BC" from="B" to="C" numLanes="2" speed="30"/></edges>')
    doc = {"scenario": {"name": "short", "duration_s": 5.0},
           "road": {"network": str(net), "route": ["AB", "BC"], "mu": 0.8},
           "sv": {"edge": "AB", "lane": 0, "position_m": 0.5, "speed_kmh": 50.0}}
    with pytest.raises(InputError) as err:
        scenario_from_dict(doc, path=tmp_path / "s.toml")
    text = str(err.value)
    assert err.value.key == "sv.edge" and "the SV does not fit on it" in text, text
    assert "[2.16, -1.16]" not in text


def test_a_network_under_a_folder_not_named_in_utf8_says_what_is_wrong(tmp_path: Path) -> None:
    folder = os.fsencode(tmp_path) + b"/caf\xe9"
    os.mkdir(folder)
    network = (HERE.parent / "networks" / "highway.net.xml").read_bytes()
    with open(folder + b"/highway.net.xml", "wb") as f:
        f.write(network)
    with open(folder + b"/s.toml", "w", encoding="utf-8") as f:  # the network beside it
        f.write(BASE.read_text().replace("[road]\n", '[road]\nnetwork = "highway.net.xml"\n'))
    done = subprocess.run([sys.executable, "-m", "cosim.cli", "run", folder + b"/s.toml",
                           "--no-figures"], cwd=tmp_path, capture_output=True, timeout=300)
    assert done.returncode == 2, done.stderr
    line = done.stderr.decode("utf-8", "replace").strip()
    assert len(line.splitlines()) == 1, line
    assert "UnicodeEncodeError" not in line and "unreadable" not in line, line
    assert "holds bytes that are not UTF-8" in line and "rename the file or its folder" in line


def test_help_is_plain_text(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "80")  # argparse fills to the terminal's width
    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    for name, sub in commands.items():
        text = sub.format_help()
        assert "`" not in text, name
        description = text.split("\n\n", 1)[1]
        for line in description.splitlines():
            assert len(line) <= 80, (name, line)  # re-filled, not the source's breaks


@pytest.mark.sumo
def test_track_plans_case_5_1_as_plan_does(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    assert main(["plan", str(HERE.parent / "scenarios" / "paper_case1_overtaking.toml"),
                 "--json", "--no-plot"]) == 0
    planned = json.loads(capsys.readouterr().out)["tau"]
    assert main(["track", "--plant", "bicycle", "--duration-s", "1", "--json",
                 "--no-plot"]) == 0
    reference = json.loads(capsys.readouterr().out)["cases"][0]["reference"]
    assert reference["tau_s"] == pytest.approx(planned)
    assert "paper_case1_overtaking.toml" in reference["origin"]
