"""What `cosim run` promises when things go wrong, checked on the real command:

- killed (SIGKILL) while it writes its outputs: every file under its final name
  is complete -- byte-identical to an uninterrupted run's -- and the rest are
  absent (at most hidden temporary files remain);
- interrupted (Ctrl-C, SIGINT) while it simulates: exit status 130, one line on
  stderr, nothing written;
- a bad scenario: exit status 2, one line, no output folder (tests/bad_inputs
  has the full suite).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.output import TEMP_MARK, stale_temp_files
from cosim.scenario import load_scenario
from cosim.sim import run_scenario

pytestmark = pytest.mark.sumo

SCENARIO = """
[scenario]
name = "guarantees"
duration_s = {duration}
seed = 5

[sv]
lane = 0
position_m = 200.0
speed_kmh = 80.0
lane_changes = [{{at_s = 0.5, target_lane = 1}}]

[traffic]
density_veh_per_km_lane = 6.0
length_m = 400.0
"""


def _cosim(args: list[str], cwd: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [sys.executable, "-m", "cosim.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=cwd,
    )


def _scenario(folder: Path, duration: float) -> Path:
    path = folder / "guarantees.toml"
    path.write_text(SCENARIO.format(duration=duration))
    return path


def _wait_for(proc: subprocess.Popen[bytes], ready: object, timeout: float = 240.0) -> bool:
    """Poll `ready()` as fast as possible until it is true or the process ends."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if ready():  # type: ignore[operator]
            return True
        if proc.poll() is not None:
            return False
    raise TimeoutError("cosim run did not reach the expected point")


def test_killed_while_writing_leaves_only_complete_files(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path, 2.0)
    reference = tmp_path / "reference"
    run_scenario(load_scenario(scenario), reference, write_figures=True)
    expected = {p.name: p.read_bytes() for p in reference.iterdir() if p.name != "timing.csv"}

    caught_mid_write = 0
    for attempt in range(3):
        out = tmp_path / f"killed{attempt}"
        proc = _cosim(["run", str(scenario), "--out", str(out)], tmp_path)

        def writing(out: Path = out) -> bool:
            try:
                return any(TEMP_MARK in e.name for e in os.scandir(out))
            except FileNotFoundError:
                return False

        if _wait_for(proc, writing):
            proc.send_signal(signal.SIGKILL)
            caught_mid_write += 1
        proc.communicate(timeout=60)
        for path in out.iterdir() if out.exists() else []:
            if path in stale_temp_files(out) or path.name == "timing.csv":
                continue
            assert path.name in expected, path
            assert path.read_bytes() == expected[path.name], f"{path.name} is incomplete"
        if caught_mid_write:
            break
    assert caught_mid_write > 0, "never caught cosim run writing: the test proved nothing"


def test_ctrl_c_while_simulating_exits_130_and_writes_nothing(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path, 60.0)
    out = tmp_path / "out"
    proc = _cosim(["run", str(scenario), "--out", str(out)], tmp_path)
    # The progress bar on stderr shows the simulation has started.
    assert proc.stderr is not None
    fd = proc.stderr.fileno()
    os.set_blocking(fd, False)
    seen = b""

    def drain() -> bytes:
        data = b""
        while True:
            try:
                chunk = os.read(fd, 65536)
            except BlockingIOError:
                return data
            if not chunk:
                return data
            data += chunk

    def simulating() -> bool:
        nonlocal seen
        seen += drain()
        return b"step" in seen

    assert _wait_for(proc, simulating), seen
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=60)
    text = (seen + drain()).decode(errors="replace")
    assert proc.returncode == 130, text
    last = text.replace("\r", "\n").strip().splitlines()[-1]
    assert last == "cosim run: interrupted"
    assert not out.exists() or not any(out.iterdir())


def test_bad_scenario_exits_2_before_writing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario = _scenario(tmp_path, 4.01)  # not a multiple of the 0.05 s step
    out = tmp_path / "out"
    assert main(["run", str(scenario), "--out", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == (
        f"cosim run: error: {scenario}: scenario.duration_s = 4.01: "
        "a whole multiple of scenario.step_s = 0.05 s\n"
    )
    assert not out.exists()
