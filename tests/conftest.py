"""Tests write only into temporary folders, never into the checkout.

Every test process runs in a temporary working directory, so a command's default
output folder (`results/...` under the current directory) lands there; and the
session fails, naming the files, if the checkout's `results/` gained, lost or
changed a file while the tests ran, or if an output file (CSV, figure, JSON)
appeared anywhere else in the checkout. (Sources edited while the tests run are
the developer's doing, not the tests'.)
"""

from __future__ import annotations

import os
import signal
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# What tools write beside the sources (caches, build metadata): not the tests' doing.
IGNORED = {".git", "__pycache__", ".pytest_cache", ".hypothesis", ".ruff_cache", "build",
           "dist"}

Snapshot = dict[str, tuple[int, int]]


def snapshot(root: Path) -> Snapshot:
    """Every file under root (caches left out) -> (size, modification time in ns)."""
    files: Snapshot = {}
    for folder, dirs, names in os.walk(root):
        dirs[:] = [d for d in dirs if d not in IGNORED and not d.endswith(".egg-info")]
        for name in names:
            path = Path(folder) / name
            try:
                stat = path.stat()
            except OSError:  # removed while we looked
                continue
            files[str(path.relative_to(root))] = (stat.st_size, stat.st_mtime_ns)
    return files


OUTPUTS = (".csv", ".png", ".svg", ".pdf", ".json")  # what the commands write


def changes(before: Snapshot, after: Snapshot) -> list[str]:
    """The files of results/ created, removed or changed between two snapshots, and
    the output files created elsewhere, sorted."""
    def watched(path: str) -> bool:
        return Path(path).parts[0] == "results"

    created = [f"created {p}" for p in after.keys() - before.keys()
               if watched(p) or p.endswith(OUTPUTS)]
    removed = [f"removed {p}" for p in before.keys() - after.keys() if watched(p)]
    changed = [f"changed {p}" for p in before.keys() & after.keys()
               if watched(p) and before[p] != after[p]]
    return sorted(created + removed + changed)


@pytest.fixture(scope="session")
def checkout_guard() -> tuple[Callable[[Path], Snapshot],
                              Callable[[Snapshot, Snapshot], list[str]]]:
    """(snapshot, changes), for the test of this guard itself."""
    return snapshot, changes


@pytest.fixture(scope="session", autouse=True)
def _checkout_untouched(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    before = snapshot(ROOT)
    previous = Path.cwd()
    os.chdir(tmp_path_factory.mktemp("cwd"))  # default output folders land here
    try:
        yield
    finally:
        os.chdir(previous)
    touched = changes(before, snapshot(ROOT))
    assert not touched, ("the tests wrote into the checkout (they must use tmp_path): "
                         + "; ".join(touched[:20]))


_HANDLED = tuple(s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None))
                 if s is not None)


@pytest.fixture(autouse=True)
def _process_state_restored() -> Iterator[None]:
    """A test leaves this process's signal handlers and temporary folder as it found them:
    tests share their process (pytest-xdist), and a leaked SIG_IGN or a handler that only
    notes signals would change what a later test's Ctrl-C does."""
    handlers = {s: signal.getsignal(s) for s in _HANDLED}
    tmp = (tempfile.tempdir, os.environ.get("TMPDIR"))
    yield
    leaked = [f"{signal.Signals(s).name}: {handlers[s]} -> {signal.getsignal(s)}"
              for s in _HANDLED if signal.getsignal(s) != handlers[s]]
    for s in _HANDLED:
        signal.signal(s, handlers[s])
    if (tempfile.tempdir, os.environ.get("TMPDIR")) != tmp:
        leaked.append(f"temporary folder: {tmp} -> {(tempfile.tempdir, os.environ.get('TMPDIR'))}")
    assert not leaked, "the test changed the process's state: " + "; ".join(leaked)


def pytest_sessionstart(session: pytest.Session) -> None:
    """Compile the numba functions once, before xdist's workers start: on a cold cache
    each worker, and each command a test starts before the cache is written, would
    otherwise compile them all again (about 75 s of the suite's wall time on 2 cores,
    against about 40 s for one compile here). Workers and commands then load the cache."""
    if hasattr(session.config, "workerinput"):  # an xdist worker: its controller did it
        return
    import cosim.control.warm  # noqa: F401  (compiles or loads every compiled function)
