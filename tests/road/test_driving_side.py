"""A network built for left-hand traffic (netconvert --lefthand) is refused by name when
it is read, whatever reads it, never as the deviation its mirrored lanes would show."""

from __future__ import annotations

import gzip
import sys
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.errors import InputError
from cosim.road.driving_side import left_hand
from cosim.road.road import load_road
from cosim.traffic.network import NETWORK_DIR

sys.path.insert(0, str(Path(__file__).parent))
from handdrawn import netconvert  # noqa: E402

REFUSAL = "left-hand traffic (netconvert --lefthand) is not supported: "


def _two_edges(tmp: Path, *options: str) -> Path:
    return netconvert(
        tmp, '<nodes><node id="A" x="0" y="0"/><node id="B" x="1000" y="0"/>'
        '<node id="C" x="2000" y="0"/></nodes>',
        '<edges><edge id="AB" from="A" to="B" numLanes="3" speed="30"/>'
        '<edge id="BC" from="B" to="C" numLanes="3" speed="30"/></edges>',
        name="left" if options else "right", options=options)


def test_the_root_says_which_side_traffic_keeps_to(tmp_path: Path) -> None:
    left = _two_edges(tmp_path, "--lefthand", "true")
    assert left_hand(left) and not left_hand(_two_edges(tmp_path))
    packed = tmp_path / "left.net.xml.gz"
    packed.write_bytes(gzip.compress(left.read_bytes()))
    assert left_hand(packed)
    assert not left_hand(NETWORK_DIR / "highway.net.xml")
    assert not left_hand(tmp_path / "missing.net.xml")  # its readers say what is wrong


def test_reading_a_left_hand_network_refuses_it_by_name(tmp_path: Path) -> None:
    net = _two_edges(tmp_path, "--lefthand", "true")
    with pytest.raises(InputError) as err:
        load_road(net, ["AB", "BC"])
    assert err.value.source == str(net) and err.value.key == "network"
    assert REFUSAL in str(err.value) and "deviation" not in str(err.value)
    assert load_road(_two_edges(tmp_path), ["AB", "BC"]).max_deviation < 1e-6


@pytest.mark.parametrize("route", ['\nroute = ["AB", "BC"]', ""])
def test_a_scenario_on_a_left_hand_network_is_refused_in_one_line_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], route: str) -> None:
    net = _two_edges(tmp_path, "--lefthand", "true")
    scenario = tmp_path / "s.toml"
    scenario.write_text(
        f'[scenario]\nname = "left"\nduration_s = 5.0\n[road]\nnetwork = "{net}"{route}\n'
        '[sv]\nlane = 1\nposition_m = 50.0\nspeed_kmh = 100.0\n', encoding="utf-8")
    out = tmp_path / "out"
    assert main(["run", str(scenario), "--no-figures", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"cosim run: error: {scenario}: road.network = '{net}': {REFUSAL}a network "
                   'for right-hand traffic (left.net.xml says lefthand="true" on its <net>)'), err
    assert not out.exists()
