"""The highway network: geometry as specified, reproducible from its plain-XML sources."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from cosim.errors import InputError
from cosim.traffic.network import (
    DEFAULT_NETWORK,
    NETWORK_DIR,
    build_network,
    load_highway,
    main,
)


def test_shipped_network_is_a_straight_three_lane_highway() -> None:
    hw = load_highway(DEFAULT_NETWORK)
    assert hw.n_lanes == 3
    assert hw.lane_width == pytest.approx(3.75)
    assert [v * 3.6 for v in hw.lane_speeds] == pytest.approx([90.0, 110.0, 120.0], abs=1e-4)
    assert hw.y_right == pytest.approx(0.0)
    assert hw.x_start == 0.0
    # 60 s at 120 km/h is 2 km: every shipped scenario ends far from the edge's end
    assert hw.length >= 5000.0
    road = hw.road()
    assert [road.lane_center(k) for k in range(3)] == pytest.approx([1.875, 5.625, 9.375])


def test_network_rebuilds_byte_for_byte(tmp_path: Path) -> None:
    for suffix in (".nod.xml", ".edg.xml"):
        shutil.copy(NETWORK_DIR / f"highway{suffix}", tmp_path)
    out = build_network(tmp_path)
    assert out.read_bytes() == DEFAULT_NETWORK.read_bytes()
    assert main(["--check"]) == 0


def test_missing_sources_and_networks_are_input_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="highway.nod.xml"):
        build_network(tmp_path)
    with pytest.raises(InputError, match="nothere.net.xml"):
        load_highway(tmp_path / "nothere.net.xml")


def _netconvert(tmp_path: Path, *options: str, length: float = 6000.0) -> Path:
    """A network built by netconvert from the shipped plain XML, with its default
    options (precision 2: lane centres 1.88 / 5.62 / 9.38 m) unless told otherwise."""
    import subprocess

    from cosim.traffic.network import netconvert_binary

    nodes = (NETWORK_DIR / "highway.nod.xml").read_text().replace('"6000.0"', f'"{length}"')
    (tmp_path / "n.nod.xml").write_text(nodes)
    shutil.copy(NETWORK_DIR / "highway.edg.xml", tmp_path / "n.edg.xml")
    out = tmp_path / "n.net.xml"
    subprocess.run([netconvert_binary(), "-n", "n.nod.xml", "-e", "n.edg.xml", "-o", out.name,
                    *options], cwd=tmp_path, check=True, capture_output=True)
    return out


@pytest.mark.parametrize("options", [(), ("--offset.disable-normalization", "true"),
                                     ("--precision", "3")])
def test_a_netconvert_network_at_its_default_precision_is_read(
    tmp_path: Path, options: tuple[str, ...]
) -> None:
    """Lane centres rounded to the file's decimals are where they should be up to that
    rounding (a tolerance of 1 mm would refuse netconvert's own 2-decimal output)."""
    net = _netconvert(tmp_path, *options)
    text = net.read_text()
    if not options or options[0] != "--precision":
        assert 'shape="0.00,' in text  # really written with 2 decimals
    hw = load_highway(net)
    assert hw.n_lanes == 3 and hw.lane_width == pytest.approx(3.75)
    centres = [hw.road().lane_center(k) for k in range(3)]
    assert [c - centres[0] for c in centres] == pytest.approx([0.0, 3.75, 7.5])
    assert abs(hw.y_right - (centres[0] - 1.875)) < 1e-9
    assert abs(centres[1] - hw.y_right - 5.625) < 0.005


def test_a_lane_off_by_more_than_rounding_is_blamed_on_its_position(tmp_path: Path) -> None:
    net = _netconvert(tmp_path, "--offset.disable-normalization", "true")
    net.write_text(net.read_text().replace("0.00,5.62 6000.00,5.62", "0.00,5.70 6000.00,5.70"))
    with pytest.raises(InputError, match=r"lane 1 runs from \(0, 5.7\).*more than the rounding "
                                         r"of the file's 2 decimals"):
        load_highway(net)
    net.write_text(net.read_text().replace("0.00,5.70 6000.00,5.70", "0.00,7.00 6000.00,7.00"))
    with pytest.raises(InputError, match="not side by side"):
        load_highway(net)


def test_a_netconvert_network_runs_and_a_short_one_is_blamed_for_its_length(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from cosim.cli import main as cli

    base = Path(__file__).resolve().parents[1] / "bad_inputs" / "base.toml"
    text = base.read_text().replace("duration_s = 10.0", "duration_s = 3.0")
    net = _netconvert(tmp_path)
    scenario = tmp_path / "s.toml"
    scenario.write_text(text.replace("[road]\n", f'[road]\nnetwork = "{net.name}"\n'))
    assert cli(["run", str(scenario), "--out", str(tmp_path / "out"), "--no-figures"]) == 0
    assert (tmp_path / "out" / "metrics.csv").is_file()
    short = tmp_path / "short"
    short.mkdir()
    _netconvert(short, length=300.0)
    scenario.write_text(text.replace("[road]\n", '[road]\nnetwork = "short/n.net.xml"\n'))
    capsys.readouterr()
    assert cli(["plan", str(scenario), "--no-plot"]) == 2
    err = capsys.readouterr().err
    assert "sv.position_m = 300.0" in err and "edge is 300 m long" in err, err


def test_shipped_scenarios_validate_on_a_default_precision_network(tmp_path: Path) -> None:
    """Paper case 3's TV at 120 km/h in a lane netconvert writes as 33.33 m/s (119.988
    km/h): within the file's rounding, as SUMO takes it; 125 km/h is still refused."""
    from cosim.scenario import load_scenario

    net = _netconvert(tmp_path)
    case3 = NETWORK_DIR.parent / "scenarios" / "paper_case3_lane_exchange.toml"
    text = case3.read_text()
    assert "network" not in text
    scenario = tmp_path / "case3.toml"
    scenario.write_text(text.replace("[road]\n", f'[road]\nnetwork = "{net}"\n', 1))
    assert load_scenario(scenario).tvs[0].speed == pytest.approx(120 / 3.6)
    scenario.write_text(scenario.read_text().replace("speed_kmh = 120.0", "speed_kmh = 125.0", 1))
    with pytest.raises(InputError, match="119.988 km/h"):
        load_scenario(scenario)


def test_a_left_hand_traffic_network_is_named_as_such(tmp_path: Path) -> None:
    net = _netconvert(tmp_path, "--lefthand", "true")
    with pytest.raises(InputError, match=r"left-hand traffic \(netconvert --lefthand\) is not "
                       "supported") as err:
        load_highway(net)
    assert err.value.source == str(net) and "n.net.xml says lefthand=" in str(err.value)
