"""Watching a run in sumo-gui (`cosim run --gui`): checked up front, quiet, paced, zoomed.

libsumo has no GUI, so sumo-gui runs as a child process driven through traci
(cosim.traffic.sumo starts it through `start` here). What makes it watchable:

- a display is checked before anything runs: without one, `--gui` is an input
  error on one line (sumo-gui would otherwise fail after traci's 60 connection
  retries);
- traci's "Retrying in 1 seconds" and sumo-gui's own console output are
  swallowed;
- the run is paced to wall time, `speed` simulated seconds per second (1: real
  time): sumo-gui's `--delay` waits per step on top of the step's own cost,
  and under traci it is not applied at all, so the pacing is ours (`Pacer`);
- the view follows the SV, zoomed so that a car is tens of pixels long;
- at the end the window stays open until its user closes it
  (`wait_for_windows`, called once the run's files are written).
"""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from types import ModuleType
from typing import Any

from cosim.errors import InputError, check_signals

VIEW = "View #0"  # sumo-gui's main view
SV_COLOUR = (30, 110, 255, 255)  # RGBA, the followed vehicle
SCHEME = "real world"  # sumo-gui's scheme that draws cars as cars (not triangles)
SOURCE = "command line"


@dataclass(frozen=True)
class GuiSettings:
    """How sumo-gui shows a run."""

    speed: float = 1.0  # -, simulated seconds per wall-clock second (1: real time)
    zoom: float = 6000.0  # %, sumo-gui's zoom: about 12 px per m, 100 m across the view
    keep_open: bool = True  # leave the window open at the end until its user closes it
    window: tuple[int, int] = (1200, 500)  # px, width and height of the window


def display_problem(environ: dict[str, str] | None = None) -> str | None:
    """Why no window can be shown here (None: a display is there)."""
    env = os.environ if environ is None else environ
    if sys.platform in ("win32", "darwin"):
        return None
    if env.get("WAYLAND_DISPLAY"):
        return None
    display = env.get("DISPLAY")
    if display:
        if x_display_reachable(display):
            return None
        return (f"a display sumo-gui can open (no X server answers on DISPLAY {display!r}): "
                "start one, run without --gui, or under xvfb-run")
    return "a display for sumo-gui's window (neither DISPLAY nor WAYLAND_DISPLAY is set): " \
        "run without --gui, or under xvfb-run"


def x_display_reachable(display: str, timeout: float = 1.0) -> bool:
    """Whether an X server listens for DISPLAY (":N", "unix:N", "host:N", with an optional
    ".screen"): its socket /tmp/.X11-unix/XN (or Linux's abstract one), or TCP 6000 + N.
    A DISPLAY of another form is given the benefit of the doubt."""
    import re
    import socket

    found = re.fullmatch(r"(?P<host>[^:]*):(?P<n>\d+)(\.\d+)?", display)
    if not found:
        return True
    host, n = found.group("host"), int(found.group("n"))
    if host in ("", "unix"):
        for address in (f"/tmp/.X11-unix/X{n}", f"\0/tmp/.X11-unix/X{n}"):
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
                sock.settimeout(timeout)
                try:
                    sock.connect(address)
                    return True
                except OSError:
                    continue
        if host == "unix":
            return False
        host = "localhost"
    try:
        with socket.create_connection((host, 6000 + n), timeout=timeout):
            return True
    except OSError:
        return False


def check_gui(settings: GuiSettings, environ: dict[str, str] | None = None) -> None:
    """InputError (one line, exit 2) unless sumo-gui can show a window and the
    settings make sense; called before anything runs."""
    problem = display_problem(environ)
    if problem is not None:
        env = os.environ if environ is None else environ
        raise InputError(f"{SOURCE} --gui", "DISPLAY", env.get("DISPLAY", ""), problem)
    if not 0.05 <= settings.speed <= 100.0:
        raise InputError(SOURCE, "--gui-speed", settings.speed,
                         "a factor in [0.05, 100] (1: real time)")
    if binary() is None:
        raise InputError(f"{SOURCE} --gui", "sumo-gui", "not found",
                         "sumo-gui, which the eclipse-sumo package installs")


def binary() -> str | None:
    """Path of sumo-gui (None: not installed)."""
    try:
        import sumolib

        path = sumolib.checkBinary("sumo-gui")
    except (ImportError, SystemExit):  # sumolib exits if the binary is missing
        return None
    return path if os.path.isfile(path) else None


def options(settings: GuiSettings) -> list[tuple[str, str]]:
    """sumo-gui options: start at once, no delay of its own (we pace), stay open."""
    w, h = settings.window
    return [("--start", "true"), ("--quit-on-end", "false" if settings.keep_open else "true"),
            ("--delay", "0"), ("--window-size", f"{w},{h}")]


_windows: list[subprocess.Popen[bytes]] = []  # sumo-gui processes left open for their user


def start(api: ModuleType, cmd: list[str]) -> None:
    """Start sumo-gui and connect traci to it, without traci's "Retrying in 1
    seconds" (sumo-gui takes a moment to open its socket) or sumo-gui's console
    output (its warnings go to the --error-log file like the headless binary's)."""
    from sumolib.miscutils import getFreeSocketPort

    port = getFreeSocketPort()
    process = subprocess.Popen([*cmd, "--remote-port", str(port)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            api.init(port, numRetries=60, proc=process)
    except BaseException:
        process.kill()
        process.wait()
        raise


def follow(api: ModuleType, vehicle_id: str, settings: GuiSettings) -> None:
    """Keep the main view centred on a vehicle, zoomed in, with real-world colours."""
    api.gui.setSchema(VIEW, SCHEME)
    api.vehicle.setColor(vehicle_id, SV_COLOUR)  # drawing only: SUMO's TVs stay yellow
    api.gui.trackVehicle(VIEW, vehicle_id)
    api.gui.setZoom(VIEW, settings.zoom)


def close(api: ModuleType, settings: GuiSettings) -> None:
    """End the traci connection; with `keep_open` leave the window for its user."""
    process = getattr(api.getConnection(), "_process", None) if settings.keep_open else None
    api.close(wait=False)
    if process is not None and process.poll() is None:
        _windows.append(process)


def wait_for_windows(out: Any = None) -> None:
    """Block until every sumo-gui window this process left open is closed."""
    if not _windows:
        return
    print("sumo-gui: the run is over; close its window to exit", file=out or sys.stderr)
    for window in list(_windows):
        while True:
            check_signals()  # Ctrl-C ends the wait (a signal is only noted when it comes)
            try:
                window.wait(timeout=0.2)
                break
            except subprocess.TimeoutExpired:
                continue
    _windows.clear()


class Pacer:
    """A step hook that sleeps so that simulated time runs at `speed` x wall time."""

    def __init__(self, speed: float) -> None:
        self.speed = speed
        self.origin: tuple[float, float] | None = None  # (simulated s, wall s) at the start

    def __call__(self, sim: Any) -> None:
        now = time.perf_counter()
        if self.origin is None:
            self.origin = (sim.time, now)
            return
        due = self.origin[1] + (sim.time - self.origin[0]) / self.speed
        if due > now:
            time.sleep(due - now)
