"""`cosim run --gui` under a virtual display (Xvfb): quiet, paced, following the SV,
the window left open until closed. Skipped where Xvfb is not installed."""

from __future__ import annotations

import shutil
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.traffic import gui

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "paper_case1_overtaking.toml"
SIMULATED_S = 13.0  # s, case 5.1's duration

pytestmark = pytest.mark.skipif(shutil.which("Xvfb") is None or gui.binary() is None,
                                reason="needs Xvfb and sumo-gui")


@pytest.fixture()
def display(monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """A virtual X display of our own (its process ended by its id afterwards)."""
    for number in range(91, 120):
        if not Path(f"/tmp/.X11-unix/X{number}").exists():
            break
    name = f":{number}"
    server = subprocess.Popen(["Xvfb", name, "-screen", "0", "1280x720x24", "-nolisten", "tcp"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 10.0
    while not Path(f"/tmp/.X11-unix/X{number}").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    monkeypatch.setenv("DISPLAY", name)
    try:
        yield name
    finally:
        server.terminate()
        server.wait(timeout=10)


def test_gui_run_is_paced_quiet_and_stays_open(
        display: str, tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    speed = 4.0
    seen: dict[str, object] = {}

    def user() -> None:
        """Wait for the window left open, screenshot it, check it lives, close it."""
        deadline = time.monotonic() + 120.0
        while not gui._windows and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)
        if shutil.which("import"):
            subprocess.run(["import", "-display", display, "-window", "root",
                            str(tmp_path / "screen.png")], check=False, timeout=30)
        seen["open"] = [w.poll() is None for w in gui._windows]
        for window in list(gui._windows):
            window.terminate()  # as its user closing it

    closer = threading.Thread(target=user, daemon=True)
    closer.start()
    start = time.perf_counter()
    status = main(["run", str(CASE1), "--gui", "--gui-speed", str(speed), "--no-figures",
                   "--out", str(tmp_path / "run")])
    wall = time.perf_counter() - start
    closer.join(timeout=60)
    out, err = capfd.readouterr()
    assert status == 0
    assert seen["open"] == [True]  # the run was over and the window still open
    assert wall >= SIMULATED_S / speed  # paced: not faster than asked
    assert "Retrying" not in out + err and "TraCI" not in out + err
    assert out.splitlines()[0].startswith("paper_case1_overtaking: lane_changes = 1")
    assert "close its window" in err
    assert (tmp_path / "run" / "metrics.csv").is_file()
    if (tmp_path / "screen.png").exists():
        assert (tmp_path / "screen.png").stat().st_size > 5_000


def test_gui_quit_closes_at_the_end(display: str, tmp_path: Path) -> None:
    start = time.perf_counter()
    assert main(["run", str(CASE1), "--gui", "--gui-quit", "--gui-speed", "20",
                 "--no-figures", "--out", str(tmp_path)]) == 0
    assert not gui._windows
    assert time.perf_counter() - start < 60.0


def test_pacer_holds_simulated_time_to_wall_time() -> None:
    class Clock:
        time = 0.0

    pacer, sim = gui.Pacer(speed=2.0), Clock()
    start = time.perf_counter()
    for k in range(11):
        sim.time = 0.05 * k
        pacer(sim)
    assert time.perf_counter() - start >= 0.25 - 1e-3  # 0.5 s simulated at 2x


def test_display_problem_names_the_way_out() -> None:
    assert gui.display_problem({}) is not None and "xvfb-run" in gui.display_problem({})
    assert gui.display_problem({"DISPLAY": ":0"}) is None
