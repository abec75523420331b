"""Issue 25 (reliability, third round): flags that conflict or exceed the machine, output
targets that cannot take a result, full devices, interrupts at the folder swap, a batch
ended by SIGTERM, a resumed study whose base changed, and messages that say what is wrong.

Each case: exit 2 (or a clean completion where the input was good), at most one line on
stderr naming the flag / file, the value and what is allowed, no traceback, nothing
created or changed.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from cosim.cli import main

HERE = Path(__file__).resolve().parent
BASE = HERE / "base.toml"


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def _batch(out: Path, *flags: str) -> list[str]:
    return ["batch", "--scenario", str(BASE), "--densities", "0", "--seeds", "1",
            "--no-progress", "--no-plots", "-o", str(out), *flags]


# ------------------------------------------------------------------ class 7: flags

RUN_FLAG_CASES = {
    "gui_speed_without_gui": (["--gui-speed", "-4"], "--gui-speed = -4.0", "only with --gui"),
    "gui_quit_without_gui": (["--gui-quit"], "--gui-quit = True", "only with --gui"),
    "plant_with_sumo_driver": (["--controller", "sumo", "--plant", "bicycle"],
                               "--plant = 'bicycle'", "--controller sumo"),
}


@pytest.mark.parametrize("name", sorted(RUN_FLAG_CASES))
def test_run_refuses_conflicting_flags(name: str, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    flags, shown, allowed = RUN_FLAG_CASES[name]
    out = tmp_path / "out"
    assert main(["run", str(BASE), "--out", str(out), *flags]) == 2
    line = _one_line(capsys.readouterr().err)
    assert shown in line and allowed in line, line
    assert list(tmp_path.iterdir()) == []


def test_run_refuses_a_plant_when_the_scenario_lets_sumo_drive(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scenario = tmp_path / "s.toml"
    scenario.write_text(BASE.read_text().replace('controller = "mimo"', 'controller = "sumo"')
                        .replace("[road]\n", f'[road]\nnetwork = "{HERE.parent.parent}/networks/'
                                 'highway.net.xml"\n'))
    assert main(["run", str(scenario), "--plant", "twotrack", "--out", str(tmp_path / "o")]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "--plant = 'twotrack'" in line and "sv.controller = 'sumo'" in line, line


BATCH_FLAG_CASES = {
    "workers_thousand": (["--workers", "1000"], "--workers = 1000", "--allow-many-workers"),
    "workers_with_remote_dask": (["--dask", "tcp://127.0.0.1:1", "--workers", "2"],
                                 "--workers = 2", "--dask tcp://127.0.0.1:1"),
    "plants_with_sumo_only": (["--drivers", "sumo", "--plants", "bicycle"],
                              "--plants = 'bicycle'", "every driver is sumo"),
}


@pytest.mark.parametrize("name", sorted(BATCH_FLAG_CASES))
def test_batch_refuses_flags_beyond_the_machine_or_in_conflict(
        name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    flags, shown, allowed = BATCH_FLAG_CASES[name]
    assert main(_batch(tmp_path / "out", *flags)) == 2
    line = _one_line(capsys.readouterr().err)
    assert line.startswith("cosim batch: error: command line: ")
    assert shown in line and allowed in line, line
    assert list(tmp_path.iterdir()) == []


def test_many_workers_need_the_override_and_follow_the_cores() -> None:
    from cosim.cli import build_parser
    from cosim.commands.batch import WORKERS_PER_CORE, check_workers

    limit = WORKERS_PER_CORE * (os.cpu_count() or 1)
    parse = build_parser().parse_args
    base = ["batch", "--scenario", str(BASE)]
    check_workers(parse([*base, "--workers", str(limit)]))  # at the bound: fine
    check_workers(parse([*base, "--workers", str(limit + 1), "--allow-many-workers"]))
    check_workers(parse([*base, "--workers", "2", "--dask", "local"]))  # sizes the cluster
