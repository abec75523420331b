"""The local pool's temporary folder: one whose path leaves no room for the fork server's
socket is refused in one line before the batch writes anything; the longest one allowed
takes the socket the kernel binds."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from cosim.errors import InputError
from cosim.study.pool import SOCKET_NAME, SOCKET_PATH_MAX, check_socket_room

ROOT = Path(__file__).resolve().parents[2]
ROOM = SOCKET_PATH_MAX - SOCKET_NAME  # bytes, the longest TMPDIR allowed


def _folder(tmp_path: Path, length: int) -> Path:
    """A folder under `tmp_path` whose path is `length` bytes long."""
    pad = length - len(os.fsencode(tmp_path)) - 1
    assert pad > 0, tmp_path
    folder = tmp_path / ("d" * pad)
    folder.mkdir(parents=True)
    return folder


def test_the_longest_folder_allowed_takes_the_fork_servers_socket(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    folder = _folder(tmp_path, ROOM)
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    check_socket_room()
    # the socket path multiprocessing makes there, as long as its names make it
    server = folder / ("pymp-" + "x" * 8)
    server.mkdir()
    address = server / ("listener-" + "x" * 8)
    assert len(os.fsencode(address)) == SOCKET_PATH_MAX
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(address))
    monkeypatch.setattr(tempfile, "tempdir", str(_folder(tmp_path / "b", ROOM + 1)))
    with pytest.raises(InputError, match="TMPDIR"):
        check_socket_room()


def test_a_batch_under_a_too_long_temporary_folder_is_refused_and_writes_nothing(
        tmp_path: Path) -> None:
    folder = _folder(tmp_path, ROOM + 1)
    out = tmp_path / "batch"
    study = ROOT / "scenarios" / "study_gap_sample.toml"
    done = subprocess.run(
        [sys.executable, "-m", "cosim.cli", "batch", str(study),
         "--seeds", "1", "--duration", "4", "-o", str(out), "--no-plots", "--no-progress"],
        env={**os.environ, "TMPDIR": str(folder)}, capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and f"TMPDIR = '{folder}'" in lines[0], done.stderr
    assert f"at most {ROOM} bytes" in lines[0] and "--dask" in lines[0]
    assert not out.exists()
