"""A signal is never lost: SIGINT / SIGTERM are noted when they come and acted on at the
next check (each step, the warm-up, a batch's wait, a child's wait), wherever Python was
when they came; the run ends with 130 / 143, one line, and the previous output untouched.
Child processes are bounded and die with cosim; a batch leaves no temporary folder."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest

from cosim.bounded_process import run_bounded
from cosim.errors import Terminated, check_signals, signal_pending, signals_as_interrupts

HERE = Path(__file__).resolve().parent
BASE = HERE / "bad_inputs" / "base.toml"

# Runs `cosim` with a hook right after SUMO's start: the signal comes to this process from
# inside a weakref callback (where the import machinery's module locks run theirs, and an
# exception is printed and dropped), or while a module is imported.
DRIVER = textwrap.dedent("""
    import os, signal, sys, weakref
    from cosim import cli
    from cosim.run import loop

    moment, signum, modules = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    real_start = loop.CoSimulation._start

    class Token:
        pass

    def in_callback(ref):
        os.kill(os.getpid(), signum)
        for _ in range(10000):  # Python runs the handler here, inside the callback
            pass

    def start(self):
        real_start(self)
        if moment == "callback":
            token = Token()
            ref = weakref.ref(token, in_callback)
            del token
        else:
            sys.path.insert(0, modules)
            import slow_module  # tells the test through stdout, which signals it
        print("after the hook", flush=True)

    loop.CoSimulation._start = start
    sys.exit(cli.main(sys.argv[4:]))
""")

# A module whose import lasts until the signal has come (it says so on stdout first).
SLOW_MODULE = textwrap.dedent("""
    import sys
    from cosim import errors
    print("importing", flush=True)
    while errors.interrupted_status() is None:
        pass
""")


def _scenario(folder: Path, duration: float = 10.0) -> Path:
    path = folder / "s.toml"
    path.write_text(BASE.read_text().replace("duration_s = 10.0", f"duration_s = {duration}")
                    .replace("[road]\n", f'[road]\nnetwork = "{HERE.parent}/networks/'
                             'highway.net.xml"\n'))
    return path


def _previous_run(folder: Path) -> Path:
    out = folder / "out"
    out.mkdir()
    (out / "metrics.csv").write_text("previous\n")
    return out


@pytest.mark.sumo
@pytest.mark.parametrize(("moment", "sig", "status", "last"), [
    ("callback", signal.SIGINT, 130, "cosim run: interrupted"),
    ("callback", signal.SIGTERM, 143, "cosim run: terminated (SIGTERM)"),
    ("import", signal.SIGINT, 130, "cosim run: interrupted"),
    ("import", signal.SIGTERM, 143, "cosim run: terminated (SIGTERM)"),
])
def test_a_signal_wherever_python_is_ends_the_run(
        tmp_path: Path, moment: str, sig: signal.Signals, status: int, last: str) -> None:
    """Inside a callback whose exceptions Python drops, the raising handler's
    KeyboardInterrupt was lost and the run went on to exit 0; noted, the signal ends the
    run at the next step, and the previous output stays as it was."""
    out = _previous_run(tmp_path)
    (tmp_path / "slow_module.py").write_text(SLOW_MODULE)
    proc = subprocess.Popen(
        [sys.executable, "-c", DRIVER, moment, str(int(sig)), str(tmp_path), "run",
         str(_scenario(tmp_path)), "--out", str(out), "--no-figures"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    if moment == "import":
        line = proc.stdout.readline()  # blocks until the import has begun
        assert line == "importing\n", line
        proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == status, stderr
    assert "after the hook" in stdout  # the signal came before the loop ...
    assert "Exception ignored" not in stderr and "Traceback" not in stderr, stderr
    assert stderr.strip().splitlines()[-1] == last  # ... which acted on it
    assert sorted(p.name for p in out.iterdir()) == ["metrics.csv"]
    assert (out / "metrics.csv").read_text() == "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "s.toml", "slow_module.py"]


def test_a_noted_signal_is_raised_at_the_check_and_only_once() -> None:
    previous = signals_as_interrupts()
    try:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):  # the handler runs here: noted, nothing raised
            pass
        assert signal_pending()
        with pytest.raises(Terminated):
            check_signals()
        check_signals()  # spent
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def test_a_signal_while_waiting_for_a_child_kills_it_and_unwinds(tmp_path: Path) -> None:
    """The child itself signals cosim (as a user would, while cosim waits on it): the wait
    ends, the child is killed, and the signal unwinds."""
    pid_file = tmp_path / "child.pid"
    previous = signals_as_interrupts()
    try:
        with pytest.raises(Terminated):
            run_bounded(["sh", "-c", f"echo $$ > {pid_file}; kill -TERM $PPID; exec sleep 600"],
                        timeout=600)
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    child = int(pid_file.read_text())
    assert not Path(f"/proc/{child}").exists()  # killed and reaped by run_bounded


def test_a_child_over_its_time_or_memory_is_stopped() -> None:
    slow = run_bounded(["sleep", "600"], timeout=0.5)
    assert slow.timed_out and slow.returncode == -signal.SIGKILL
    greedy = run_bounded([sys.executable, "-c", "b = bytearray(2**30)"], timeout=120,
                         memory_bytes=256 * 2**20)
    assert not greedy.timed_out and greedy.returncode == 1 and "MemoryError" in greedy.stderr


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG: Linux")
def test_a_child_dies_with_its_killed_parent() -> None:
    """cosim SIGKILLed while its validating SUMO runs: the kernel kills the child too."""
    parent = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent("""
            from cosim.bounded_process import run_bounded
            run_bounded(["sh", "-c", "exec sleep 600"], timeout=600)
        """)])
    child = _wait_for_child(parent.pid)
    parent.kill()
    parent.wait(timeout=60)
    assert _ends(child), f"the child {child} outlived its killed parent"


def _wait_for_child(pid: int, timeout: float = 120.0) -> int:
    """The pid of the `sleep` below `pid` once it runs (Linux /proc)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
                cmd = (stat.parent / "cmdline").read_bytes()
            except OSError:
                continue
            if int(fields[1]) == pid and cmd.startswith(b"sleep"):
                return int(stat.parent.name)
        time.sleep(0.02)  # polled: the event is the child's start
    raise TimeoutError("the child never started")


def _ends(pid: int, timeout: float = 60.0) -> bool:
    """True once `pid` is gone or a zombie (its death seen by the kernel)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            return True
        if state == "Z":
            return True
        time.sleep(0.02)  # polled: the event is the child's end
    return False


@pytest.mark.sumo
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize(("sig", "status"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signalled_batch_leaves_no_temporary_folder(
        tmp_path: Path, sig: signal.Signals, status: int) -> None:
    """SIGINT or SIGTERM while the workers run: their SUMO and fcd folders go with the
    batch's own temporary folder, the parent's to remove."""
    # a short TMPDIR: the pool's fork server binds a Unix socket under it (at most 107 bytes)
    tmp = Path(tempfile.mkdtemp(prefix="cosim-signal-test-", dir="/tmp"))
    try:
        _signal_a_batch(tmp_path, tmp, sig, status)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _signal_a_batch(tmp_path: Path, tmp: Path, sig: signal.Signals, status: int) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "cosim.cli", "batch", "--scenario",
         str(_scenario(tmp_path, 60.0)), "--densities", "0", "--seeds", "1-4", "--workers", "2",
         "--no-progress", "--no-plots", "-o", str(tmp_path / "study")],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        env={**os.environ, "TMPDIR": str(tmp)})
    end = time.monotonic() + 240
    while time.monotonic() < end and proc.poll() is None:
        # a worker's run is under way: its fcd and SUMO folders exist
        if all(list(tmp.glob(f"cosim-batch-*/cosim-{what}-*")) for what in ("fcd", "sumo")):
            break
        time.sleep(0.02)  # polled: the event is the folders' appearance
    if proc.poll() is not None:
        _, err = proc.communicate()
        pytest.fail("the batch ended before the signal (the test proved nothing): "
                    + err.decode()[-2000:])
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == status, err.decode()
    assert list(tmp.iterdir()) == []
