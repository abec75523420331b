"""The user's demand is bounded before SUMO builds it (a flow of 10^9 vehicles is one line,
not gigabytes), and its warm-up shows its own progress and ends at a signal."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.errors import Terminated, signals_as_interrupts
from cosim.run.loop import CoSimulation, simulate
from cosim.scenario import load_scenario, project_root, with_overrides
from cosim.traffic.own_demand import MAX_FLOW_VEHICLES, flow_size

ROOT = project_root()
ROUTES = ROOT / "scenarios" / "own_demand_routes.toml"

FLOWS = """<routes>
    <vType id="car"/>
    <route id="r" edges="highway"/>
    <flow id="{ident}" type="car" route="r" begin="0" {size}/>
</routes>
"""


def _scenario(folder: Path, flow: str) -> Path:
    (folder / "flows.rou.xml").write_text(flow)
    path = folder / "s.toml"
    path.write_text(ROUTES.read_text()
                    .replace('"own_demand/flows.rou.xml"', '"flows.rou.xml"')
                    .replace('"networks/highway.net.xml"',
                             f'"{ROOT / "networks" / "highway.net.xml"}"'))
    return path


@pytest.mark.parametrize(("size", "shown"), [
    ('number="1000000000"', "number=1000000000"),
    ('end="86400" vehsPerHour="100000"',
     "vehsPerHour=100000 from begin=0 to end=86400 s"),
    ('period="0.01"', "period=0.01 from begin=0 to end=86400 s"),  # SUMO's default end
])
def test_a_flow_too_large_to_build_is_one_line_naming_file_flow_and_number(
        tmp_path: Path, size: str, shown: str, capsys: pytest.CaptureFixture[str]) -> None:
    scenario = _scenario(tmp_path, FLOWS.format(ident="huge", size=size))
    assert main(["run", str(scenario), "--out", str(tmp_path / "out"), "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"traffic.routes[0] = \"flows.rou.xml: flow 'huge' {shown}\"" in err, err
    assert f"a flow of at most {MAX_FLOW_VEHICLES} vehicles" in err, err
    assert not (tmp_path / "out").exists()


def test_flow_sizes() -> None:
    assert flow_size({"number": "12"}) == (12.0, "number=12")
    assert flow_size({"begin": "0", "end": "3600", "vehsPerHour": "2700"})[0] == 2700.0
    assert flow_size({"begin": "100", "end": "200", "period": "exp(0.5)"})[0] == 50.0
    assert flow_size({"probability": "0.5", "end": "10"})[0] == 5.0
    assert flow_size({"vehsPerHour": "many"}) is None  # SUMO's own load judges it


@pytest.mark.sumo
def test_the_warm_up_shows_its_own_progress(capsys: pytest.CaptureFixture[str]) -> None:
    scenario = with_overrides(load_scenario(ROUTES), duration=0.5,
                              **{"traffic.warmup_s": 10.0})
    simulate(scenario, progress=True)
    lines = capsys.readouterr().err.splitlines()
    assert f"{scenario.name} warm-up: 0/200 step [00:00, ? step/s, ETA --:--]" in lines
    assert f"{scenario.name}: 0/10 step [00:00, ? step/s, ETA --:--]" in lines


@pytest.mark.sumo
def test_a_signal_during_the_warm_up_ends_it_at_the_next_step() -> None:
    scenario = with_overrides(load_scenario(ROUTES), duration=0.5,
                              **{"traffic.warmup_s": 10.0})
    sim = CoSimulation(scenario)
    counted: list[int] = []

    def progress(steps: int):  # type: ignore[no-untyped-def]
        assert steps == 200

        def count(n: int) -> None:
            counted.append(n)
            if len(counted) == 10:
                os.kill(os.getpid(), signal.SIGTERM)
        return count

    sim.world.warmup_progress = progress
    previous = signals_as_interrupts()
    try:
        with pytest.raises(Terminated):
            sim.run()
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    assert len(counted) == 10
    assert sim.world.sumo.process.api is None  # SUMO closed on the way out
