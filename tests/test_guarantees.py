"""What `cosim run` promises when things go wrong, checked on the real command:

- killed (SIGKILL) while it writes its outputs: the output folder is absent or
  complete -- byte-identical to an uninterrupted run's -- (at most a hidden
  temporary sibling remains, which the next run of that folder removes);
- interrupted (Ctrl-C: exit 130; SIGTERM: exit 143; one line on stderr) while it
  simulates or while it writes its figures, into a folder holding a previous run:
  the folder holds exactly what it held before, and nothing temporary remains (SIGKILL:
  the folder is untouched too, a hidden sibling remains for the next run to remove);
- a bad scenario: exit status 2, one line, no output folder (tests/bad_inputs
  has the full suite).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.output import TEMP_MARK
from cosim.run.loop import run_scenario
from cosim.scenario import load_scenario

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


def _staging(out: Path) -> list[Path]:
    """The hidden siblings a run of `out` builds in (or leaves when killed)."""
    return [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.")]


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())} if folder.exists() else {}


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
            return any((s / "metrics.csv").exists() for s in _staging(out))

        if _wait_for(proc, writing):
            proc.send_signal(signal.SIGKILL)
            caught_mid_write += 1
        proc.communicate(timeout=60)
        if out.exists():  # the swap happened before the kill: complete
            got = {k: v for k, v in _files(out).items() if k != "timing.csv"}
            assert got == expected
        if caught_mid_write:
            assert not out.exists() and _staging(out)  # killed mid-write: a hidden sibling
            # the next run of that folder cleans it and writes the complete result
            assert main(["run", str(scenario), "--out", str(out), "--no-figures"]) == 0
            assert not _staging(out) and (out / "metrics.csv").exists()
            break
    assert caught_mid_write > 0, "never caught cosim run writing: the test proved nothing"


def _stderr_drain(proc: subprocess.Popen[bytes]) -> Callable[[], bytes]:
    """A function that returns what the process has written to stderr since its last
    call, without blocking."""
    assert proc.stderr is not None
    fd = proc.stderr.fileno()
    os.set_blocking(fd, False)

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

    return drain


def _previous_run(tmp_path: Path) -> Path:
    """An output folder holding a previous run's files (CSVs and figures, marked as old)."""
    out = tmp_path / "out"
    out.mkdir()
    for name in ("trace.csv", "plans.csv", "metrics.csv", "timing.csv"):
        (out / name).write_text(f"previous,{name}\n1,2\n")
    for name in ("trajectories.png", "tracking.png", "tau_sets.png"):
        (out / name).write_bytes(b"\x89PNG previous " + name.encode())
    return out


@pytest.mark.parametrize(
    ("sig", "status", "moment"),
    [
        (signal.SIGINT, 130, "stepping"),
        (signal.SIGTERM, 143, "stepping"),
        (signal.SIGINT, 130, "figures"),
        (signal.SIGTERM, 143, "figures"),
        (signal.SIGKILL, -9, "figures"),  # no clean-up at all: the folder is still untouched
    ],
)
def test_interrupt_leaves_the_previous_run_untouched(
    tmp_path: Path, sig: signal.Signals, status: int, moment: str
) -> None:
    """Ctrl-C or SIGTERM at two moments of a run into a folder holding a previous run."""
    scenario = _scenario(tmp_path, 30.0 if moment == "stepping" else 3.0)
    out = _previous_run(tmp_path)
    before = _files(out)
    proc = _cosim(["run", str(scenario), "--out", str(out)], tmp_path)
    drain = _stderr_drain(proc)
    seen = b""

    def ready() -> bool:
        nonlocal seen
        seen += drain()
        if moment == "stepping":
            return b"step" in seen
        # the CSVs are written and the figures are being drawn, in the staging folder
        return any((s / "timing.csv").exists() for s in _staging(out))

    assert _wait_for(proc, ready), seen
    proc.send_signal(sig)
    proc.wait(timeout=60)
    text = (seen + drain()).decode(errors="replace")
    assert proc.returncode == status, text
    assert _files(out) == before  # exactly what it held: no new CSV beside old figures
    if sig == signal.SIGKILL:
        assert _staging(out)  # the hidden half-built sibling; the next run removes it
        return
    last = text.replace("\r", "\n").strip().splitlines()[-1]
    what = "interrupted" if sig == signal.SIGINT else "terminated (SIGTERM)"
    assert last == f"cosim run: {what}"
    assert not _staging(out)  # nothing temporary remains (no 0-byte PNG, no folder)
    assert not list(tmp_path.rglob(f"*{TEMP_MARK}*"))


def test_ctrl_c_while_simulating_exits_130_and_writes_nothing(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path, 60.0)
    out = tmp_path / "out"
    proc = _cosim(["run", str(scenario), "--out", str(out)], tmp_path)
    # The progress bar on stderr shows the simulation has started.
    drain = _stderr_drain(proc)
    seen = b""

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
