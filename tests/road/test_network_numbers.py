"""A network whose numbers SUMO cannot use (a lane length or speed nan or inf, a shape
point nan, a subnormal width, coordinates so far out that float64 loses the centimetre)
is refused when it is read: exit status 2, one line naming the lane and the value, for
the one-edge highway and for a route's network alike; nothing written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.scenario import project_root

ROOT = project_root()
HIGHWAY = ROOT / "networks" / "highway.net.xml"
CURVED = ROOT / "networks" / "curved_motorway.net.xml"
LANE_1 = '<lane id="highway_1" index="1" speed="30.555556" length="6000.000000"'


def _far(text: str) -> str:
    """The highway moved 1e15 m along x (every x of a shape or a junction)."""
    def shift(match: re.Match[str]) -> str:
        return f"{float(match.group(1)) + 1e15:.6f},"
    text = re.sub(r'(?<=[" ])(-?\d+\.\d+),(?=-?\d)', shift, text)
    return re.sub(r' x="(-?\d+\.\d+)"', lambda m: f' x="{float(m.group(1)) + 1e15:.6f}"', text)


# case -> (how the highway's text is changed, the lane or junction and value the line shows)
HIGHWAY_CASES = {
    "lane_length_nan": (lambda t: t.replace(LANE_1, LANE_1.replace('"6000.000000"', '"nan"')),
                        "lane 'highway_1' length = nan"),
    "lane_speed_nan": (lambda t: t.replace(LANE_1, LANE_1.replace('"30.555556"', '"nan"')),
                       "lane 'highway_1' speed = nan"),
    "lane_speed_inf": (lambda t: t.replace(LANE_1, LANE_1.replace('"30.555556"', '"inf"')),
                       "lane 'highway_1' speed = inf"),
    "lane_width_subnormal": (lambda t: t.replace('width="3.750000" shape="0.000000,5.625000',
                                                 'width="1e-320" shape="0.000000,5.625000'),
                             "lane 'highway_1' width = 1e-320"),
    "shape_point_nan": (lambda t: t.replace("6000.000000,5.625000", "nan,5.625000"),
                        "lane 'highway_1' shape = nan,5.625,0"),
    "coordinates_near_1e15": (_far, "shape = 1e+15,1.875,0"),
}


def _scenario(folder: Path, network: Path, route: str = "") -> Path:
    path = folder / "s.toml"
    path.write_text(f'[scenario]\nduration_s = 2.0\n\n[road]\nnetwork = "{network}"\n{route}'
                    '\n[sv]\nlane = 1\nposition_m = 500.0\nspeed_kmh = 100.0\n'
                    + ('edge = "e1"\n' if route else ""))
    return path


@pytest.mark.parametrize("case", sorted(HIGHWAY_CASES))
def test_a_highway_with_numbers_sumo_cannot_use_is_refused(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    change, shown = HIGHWAY_CASES[case]
    network = tmp_path / "bad.net.xml"
    network.write_text(change(HIGHWAY.read_text()))
    assert network.read_text() != HIGHWAY.read_text()
    scenario = _scenario(tmp_path, network)
    out = tmp_path / "out"
    assert main(["run", str(scenario), "--out", str(out), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(scenario) in err and "road.network" in err, err
    assert shown in err and "numbers SUMO can use" in err, err
    assert not out.exists()


def test_a_route_network_with_a_nan_lane_length_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The same rule on a network of several edges (read for road.route)."""
    text = CURVED.read_text()
    found = re.search(r'<lane id="e3_2" [^>]*?length="([^"]+)"', text)
    assert found is not None
    network = tmp_path / "curved.net.xml"
    network.write_text(text[:found.start(1)] + "nan" + text[found.end(1):])
    scenario = _scenario(tmp_path, network, 'route = ["e1", "e2", "e3", "e4"]\n')
    assert main(["run", str(scenario), "--out", str(tmp_path / "out"), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "lane 'e3_2' length = nan" in err, err
    assert not (tmp_path / "out").exists()
