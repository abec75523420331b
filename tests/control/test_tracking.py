"""Tests of cosim.control.tracking and `cosim track`: Table 2's IAE, MIMO beats
SISO on heading error (as in the paper), the command's output."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from cosim.commands import track
from cosim.control.closed_loop import LoopConfig
from cosim.control.tracking import IAE_COLUMNS, PAPER_TABLE2, run_tracking
from cosim.errors import InputError
from cosim.planning.trajectory import LaneChangeTrajectory


def main(argv: list[str]) -> int:
    """`cosim <argv>` through the track command's own parser (the full CLI imports
    every command; tests/test_cli.py covers the dispatch)."""
    parser = argparse.ArgumentParser(prog="cosim")
    track.add_parser(parser.add_subparsers())
    args = parser.parse_args(argv)
    return int(args.func(args))


REF = LaneChangeTrajectory(
    t0=0.0, tau=6.25, x0=0.0, y0=1.875, vx0=80 / 3.6, vxf=90 / 3.6, width=3.75
)


@pytest.fixture(scope="module")
def runs():
    return {
        c: run_tracking(LoopConfig("twotrack", c), REF, mu=0.4, duration=8.0)
        for c in ("mimo", "siso")
    }


def test_mimo_beats_siso_on_heading_error_and_both_track(runs) -> None:
    mimo, siso = runs["mimo"].iae(), runs["siso"].iae()
    assert mimo["phi_e_deg"] < 0.5 * siso["phi_e_deg"]
    for r in runs.values():
        assert np.max(np.abs(r.array("ye"))) < 0.02
        assert r.array("y")[-1] == pytest.approx(1.875 + 3.75, abs=0.02)
    # the paper's ordering of the inputs: MIMO steers more and drives the wheels harder
    assert mimo["delta_f_deg"] > siso["delta_f_deg"]
    assert mimo["fx_kn"] > siso["fx_kn"]


def test_iae_is_the_time_integral_of_the_absolute_values(runs) -> None:
    r = runs["siso"]
    t, ye = r.array("t"), r.array("ye")
    assert r.iae()["ye"] == pytest.approx(np.sum(0.5 * (np.abs(ye[1:]) + np.abs(ye[:-1]))
                                                 * np.diff(t)))
    assert set(r.iae()) == set(IAE_COLUMNS) == set(PAPER_TABLE2["mimo"])
    assert r.records[0].t == 0.0 and r.records[-1].t == pytest.approx(8.0)
    assert r.array("fx").shape == (len(r.records), 4)


def test_track_command_json(tmp_path, capsys) -> None:
    status = main(["track", "--plant", "bicycle", "--source", "paper", "--duration-s", "7",
                   "--json", "--out", str(tmp_path), "--no-plot"])
    assert status == 0
    out = json.loads(capsys.readouterr().out)
    (case,) = out["cases"]
    assert case["case"] == "5.1" and case["reference"]["tau_s"] == 6.25
    assert case["reference"]["mu"] == 0.4
    assert case["mimo_beats_siso_on_heading"] == {"bicycle": True}
    assert [(r["plant"], r["controller"]) for r in case["runs"]] == [
        ("bicycle", "mimo"), ("bicycle", "siso")]
    assert not any(tmp_path.iterdir())


def test_track_command_runs_the_three_paper_cases(capsys) -> None:
    status = main(["track", "--case", "all", "--plant", "bicycle", "--duration-s", "3",
                   "--json", "--no-plot", "--source", "paper"])
    assert status == 0
    cases = json.loads(capsys.readouterr().out)["cases"]
    assert [c["case"] for c in cases] == ["5.1", "5.2", "5.3"]
    assert [c["reference"]["mu"] for c in cases] == [0.4, 0.6, 0.8]
    assert cases[1]["reference"]["width_m"] == -3.75  # 5.2 goes to the slower lane


def test_track_command_table_and_figures(tmp_path, capsys) -> None:
    status = main(["track", "--plant", "bicycle", "--tau-s", "5", "--duration-s", "6",
                   "--out", str(tmp_path)])
    text = capsys.readouterr().out
    assert status == 0
    assert "paper MIMO (veDYNA)" in text and "ours SISO, bicycle" in text
    assert "tau = 5 s" in text
    assert (tmp_path / "tracking_states.png").stat().st_size > 10_000


@pytest.mark.parametrize("mu", ["0", "5", "1.25", "nan", "x"])
def test_track_command_mu_range_is_the_scenario_files(
        mu: str, capsys: pytest.CaptureFixture[str]) -> None:
    """--mu allows what a scenario file's [road] mu allows (read from its declaration)."""
    from cosim.cli import main as cosim
    from cosim.scenario import ROAD_FIELDS

    field = next(f for f in ROAD_FIELDS if f.key == "mu")
    with pytest.raises(SystemExit) as exc:
        cosim(["track", "--mu", mu, "--no-plot"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--mu" in err
    assert f"[{field.lo:g}, {field.hi:g}]" in err


def test_track_case_all_takes_one_source(capsys: pytest.CaptureFixture[str]) -> None:
    """--case all: every case's tau from the paper (the planner plans 5.1 only)."""
    with pytest.raises(InputError, match="source"):
        main(["track", "--case", "all", "--source", "planner", "--no-plot"])
    assert track.source_of("all", None) == "paper"
    assert track.source_of("5.1", None) == "planner"
    assert main(["track", "--case", "all", "--plant", "bicycle", "--duration-s", "1",
                 "--no-plot", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["source"] == "paper"
    assert [c["reference"]["tau_s"] for c in out["cases"]] == [6.25, 5.56, 7.35]
