"""What the commands refuse and how they end when interrupted: flags that conflict or
exceed the machine, output targets that cannot take a result, full devices, interrupts at
the folder swap, a batch ended by SIGTERM, a resumed study whose base changed, and
messages that say what is wrong.

Each case: exit 2 (or a clean completion where the input was good), at most one line on
stderr naming the flag / file, the value and what is allowed, no traceback, nothing
created or changed.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from collections.abc import Iterator
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


# ------------------------------------------------------------------ flags

RUN_FLAG_CASES = {
    "gui_speed_without_gui": (["--gui-speed", "-4"], "--gui-speed = -4.0", "only with --gui"),
    "gui_quit_without_gui": (["--gui-quit"], "--gui-quit = True", "only with --gui"),
    "plant_with_sumo_driver": (["--controller", "sumo", "--plant", "bicycle"],
                               "--plant = 'bicycle'", "--controller sumo"),
    "figure_format_without_figures": (["--no-figures", "--figure-format", "svg"],
                                      "--figure-format = 'svg'", "--no-figures"),
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
    "retry_failed_with_restart": (["--restart", "--retry-failed"], "--retry-failed = True",
                                  "--restart"),
    "figure_format_without_plots": (["--figure-format", "pdf"], "--figure-format = 'pdf'",
                                    "--no-plots"),
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


# ------------------------------------------------------------------ output targets


def _links(tmp_path: Path) -> dict[str, Path]:
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    (tmp_path / "loop1").symlink_to(tmp_path / "loop2")
    (tmp_path / "loop2").symlink_to(tmp_path / "loop1")
    return {
        "through_a_dangling_link": tmp_path / "dangling" / "out",
        "through_a_link_loop": tmp_path / "loop1" / "out",
        "a_dangling_link": tmp_path / "dangling",
        "a_link_loop": tmp_path / "loop1",
        "a_device": Path("/dev/null"),
    }


OUT_CASES = ["through_a_dangling_link", "through_a_link_loop", "a_dangling_link", "a_link_loop",
             "a_device"]
OUT_WORDS = {"through_a_dangling_link": "dangling symbolic link",
             "through_a_link_loop": "symbolic link loop", "a_dangling_link": "dangling symbolic",
             "a_link_loop": "symbolic link loop", "a_device": "a character device"}


@pytest.mark.parametrize("command", ["run", "plan", "batch", "compare", "track"])
@pytest.mark.parametrize("case", OUT_CASES)
def test_an_output_target_that_cannot_take_a_result_is_refused_before_the_run(
        command: str, case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = _links(tmp_path)[case]
    before = sorted(p.name for p in tmp_path.iterdir())
    argv = (_batch(out) if command == "batch" else ["track", "--out", str(out)]
            if command == "track" else [command, str(BASE), "--out", str(out)])
    assert main(argv) == 2
    line = _one_line(capsys.readouterr().err)
    assert f"--out = '{out}'" in line and OUT_WORDS[case] in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_a_run_into_a_link_to_a_folder_keeps_the_link_and_leaves_no_copy(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    real = tmp_path / "real"
    real.mkdir()
    (real / "metrics.csv").write_text("previous\n")
    link = tmp_path / "link"
    link.symlink_to(real)
    scenario = _short(tmp_path)
    assert main(["run", str(scenario), "--out", str(link), "--no-figures"]) == 0
    assert link.is_symlink() and (real / "metrics.csv").read_text() != "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real", "s.toml"]


def _short(folder: Path, duration: float = 2.0) -> Path:
    scenario = folder / "s.toml"
    scenario.write_text(BASE.read_text().replace("duration_s = 10.0", f"duration_s = {duration}")
                        .replace("start_s = 2.0", "start_s = 0.5")
                        .replace("lane_changes = [{at_s = 1.0", "lane_changes = [{at_s = 0.5")
                        .replace("[road]\n", f'[road]\nnetwork = "{HERE}/../../networks/'
                                 'highway.net.xml"\n'))
    return scenario


@contextlib.contextmanager
def _tmpfs(mount: Path, options: str) -> Iterator[Path]:
    """A 64 kB tmpfs at `mount` with `options` (root only; skipped where mount is refused)."""
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"{options}size=64k", "tmpfs",
                           str(mount)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", str(mount)], check=False)


@pytest.fixture
def tiny_disk(tmp_path: Path) -> Iterator[Path]:
    """A full disk for real."""
    with _tmpfs(tmp_path / "disk", "") as mount:
        yield mount


@pytest.mark.parametrize("command", ["run", "plan", "batch"])
def test_a_read_only_file_system_is_refused_before_the_run(
        command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with _tmpfs(tmp_path / "ro", "ro,") as mount:
        for out, allowed in ((mount / "out", f"a folder we may create ({mount} is read-only)"),
                             (mount, "a folder we may write into")):
            argv = _batch(out) if command == "batch" else [command, str(BASE), "--out",
                                                           str(out)]
            assert main(argv) == 2
            line = _one_line(capsys.readouterr().err)
            assert f"--out = '{out}': {allowed}" in line, line


def test_a_full_disk_is_one_line_and_the_previous_run_stays(
        tiny_disk: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tiny_disk / "out"
    out.mkdir()
    (out / "metrics.csv").write_text("previous\n")
    (tiny_disk / "filler").write_bytes(b"\0" * 48 * 1024)  # about 12 kB left: trace.csv is more
    assert main(["run", str(_short(tmp_path)), "--out", str(out), "--no-figures"]) == 2
    line = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert "Traceback" not in line
    assert line.startswith(f"cosim run: error: cannot write {out}/"), line
    assert "No space left on device" in line and f"{out} keeps what it held" in line
    assert sorted(p.name for p in tiny_disk.iterdir()) == ["filler", "out"]  # no staging left
    assert [p.name for p in out.iterdir()] == ["metrics.csv"]
    assert (out / "metrics.csv").read_text() == "previous\n"


def test_a_full_disk_in_a_batch_is_one_line(
        tiny_disk: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tiny_disk / "study"
    argv = ["batch", "--scenario", str(_short(tmp_path)), "--densities", "0", "--seeds", "1-2",
            "--no-progress", "--traces", "--workers", "1", "-o", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith("cosim batch: error: cannot write ") and "No space left" in last


# ------------------------------------------------------------------ full streams


def _cosim(args: list[str], cwd: Path, **kwargs: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "cosim.cli", *args], cwd=cwd, text=True,
                          timeout=300, **kwargs)  # type: ignore[call-overload]


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
def test_stdout_on_a_full_device_is_one_line_and_no_figure(tmp_path: Path) -> None:
    out = tmp_path / "plan"
    with open("/dev/full", "w") as full:
        done = _cosim(["plan", str(BASE), "--json", "--out", str(out)], tmp_path, stdout=full,
                      stderr=subprocess.PIPE)
    assert done.returncode == 2, done.stderr
    line = _one_line(done.stderr)
    assert line == "cosim plan: error: cannot write standard output: No space left on device"
    assert not out.exists()  # the answer first: no figure without it


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
def test_stderr_on_a_full_device_exits_2(tmp_path: Path) -> None:
    with open("/dev/full", "w") as full:
        done = _cosim(["plan", str(HERE / "mu_too_high.toml"), "--no-plot"], tmp_path,
                      stdout=subprocess.PIPE, stderr=full)
    assert done.returncode == 2 and done.stdout == ""


# ------------------------------------------------------------------ messages


def test_a_network_that_is_a_folder_or_a_device_says_so(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "netdir").mkdir()
    for target, what in (("netdir", "is a folder"), ("/dev/zero", "is a character device")):
        scenario = tmp_path / "s.toml"
        scenario.write_text(BASE.read_text().replace("[road]\n", f'[road]\nnetwork = "{target}"\n'))
        assert main(["plan", str(scenario), "--no-plot"]) == 2
        line = _one_line(capsys.readouterr().err)
        assert f"road.network = '{target}'" in line and what in line and "not found" not in line


@pytest.mark.parametrize(("target", "what"), [("folder", "this is a folder"),
                                              ("/dev/zero", "this is a character device")])
def test_a_scenario_path_that_is_no_file_says_what_it_is(
        target: str, what: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "folder").mkdir()
    path = target if target.startswith("/") else str(tmp_path / target)
    assert main(["plan", path, "--no-plot"]) == 2
    assert what in _one_line(capsys.readouterr().err)


def test_a_utf8_bom_is_accepted(tmp_path: Path) -> None:
    from cosim.scenario import load_scenario

    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + BASE.read_bytes().replace(
        b"[road]\n", f'[road]\nnetwork = "{HERE}/../../networks/highway.net.xml"\n'.encode()))
    assert load_scenario(path).sv.lane == 1


def test_a_toml_error_reads_as_a_sentence(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", str(HERE / "not_toml.toml"), "--no-plot"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "file = 'line 10, column" in line and "valid TOML (" in line and " there)" in line
    assert "Invalid statement (at" not in line


def test_a_duration_flag_refused_by_the_base_says_what_it_breaks(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(_batch(tmp_path / "out", "--duration", "1")) == 2
    line = _one_line(capsys.readouterr().err)
    assert "--duration = 1.0: a value the base scenario" in line
    assert "sv.lane_changes[0].at_s = 1.0 is refused: a time before the run ends" in line


def test_the_numba_cache_folder_named_is_where_it_caches(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A read-only install: the cache (and the folder `compile_first` names) moves to the
    user's cache folder, where numba can write, instead of naming the package's."""
    from cosim import compiled

    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert compiled.cache_folder().is_relative_to(Path(compiled.__file__).parent)
    monkeypatch.setattr(compiled, "_writable", lambda folder: False)
    assert compiled.cache_folder().is_relative_to(tmp_path / "cosim" / "numba")
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    assert compiled.cache_folder().is_relative_to(tmp_path / "mine" / "numba")


# ------------------------------------------------------------------ the folder swap


def test_a_signal_during_the_swap_is_held_until_the_new_run_is_in_place(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """SIGTERM while the old folder is being removed: the swap and its clean-up finish
    (no hidden `.out.old-PID-*` copy is left), then the signal is delivered, and the
    folder holds the complete new result."""
    import shutil
    import signal
    import threading

    from cosim import output
    from cosim.errors import Terminated, signals_as_interrupts

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers need the main thread")
    out = tmp_path / "out"
    out.mkdir()
    (out / "metrics.csv").write_text("previous\n")
    real_rmtree = shutil.rmtree

    def rmtree_under_signal(path: object, *args: object, **kwargs: object) -> None:
        if output.OLD_MARK in str(path):
            os.kill(os.getpid(), signal.SIGTERM)  # arrives as the old copy is removed
        real_rmtree(path, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(output.shutil, "rmtree", rmtree_under_signal)
    previous = signals_as_interrupts()
    try:
        with pytest.raises(Terminated), output.staged_dir(out) as stage:
            (stage / "metrics.csv").write_text("new\n")
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    assert (out / "metrics.csv").read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no hidden copy
    assert output.COMPLETED[-1] == out


def test_cosim_run_signalled_at_the_swap_reports_the_complete_run(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import shutil
    import signal
    import threading

    from cosim import output

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers need the main thread")
    out = tmp_path / "out"
    out.mkdir()
    (out / "metrics.csv").write_text("previous\n")
    scenario = _short(tmp_path)
    real_rmtree = shutil.rmtree

    def rmtree_under_signal(path: object, *args: object, **kwargs: object) -> None:
        if output.OLD_MARK in str(path):
            os.kill(os.getpid(), signal.SIGINT)
        real_rmtree(path, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(output.shutil, "rmtree", rmtree_under_signal)
    assert main(["run", str(scenario), "--out", str(out), "--no-figures"]) == 0
    last = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert last == f"cosim run: interrupted after the run was complete: {out} holds it"
    assert (out / "metrics.csv").read_text() != "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "s.toml"]


# ------------------------------------------------------------------ batch signals


def _descendants(pid: int) -> set[int]:
    """Every process below `pid` (Linux /proc), the resource tracker aside (it ends with
    the process that started it, whoever reaps it then)."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
            cmd = (stat.parent / "cmdline").read_bytes()
        except OSError:
            continue
        if b"resource_tracker" in cmd:
            continue
        ppid = int(text.rsplit(")", 1)[1].split()[1])
        children.setdefault(ppid, []).append(int(stat.parent.name))
    found: set[int] = set()
    todo = [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.add(child)
            todo.append(child)
    return found


def _gone(pids: set[int], timeout: float = 15.0) -> set[int]:
    """The pids still there (running or defunct) after `timeout`."""
    import time

    end = time.monotonic() + timeout
    while True:
        left = {p for p in pids if Path(f"/proc/{p}").exists()}
        if not left or time.monotonic() > end:
            return left
        time.sleep(0.1)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize(("signame", "status", "what", "moment"), [
    ("SIGTERM", 143, "terminated (SIGTERM)", "starting"),
    ("SIGTERM", 143, "terminated (SIGTERM)", "running"),
    ("SIGINT", 130, "interrupted", "running"),  # to the whole group, as a terminal does
    ("SIGTERM", 143, "terminated (SIGTERM)", "dask"),  # --dask local, runs in flight
])
def test_a_signalled_batch_ends_every_worker_and_says_one_line(
        tmp_path: Path, signame: str, status: int, what: str, moment: str) -> None:
    import signal
    import time

    sig = getattr(signal, signame)
    out = tmp_path / "study"
    dask = ["--dask", "local"] if moment == "dask" else []
    proc = subprocess.Popen(
        [sys.executable, "-m", "cosim.cli", *_batch(out, "--workers", "2", "--seeds", "1-4",
                                                     "--duration", "5", *dask)],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    seen: set[int] = set()
    end = time.monotonic() + 240
    while time.monotonic() < end and proc.poll() is None:
        seen |= _descendants(proc.pid)
        workers = len(seen) - 1  # the fork server (or a nanny) and the workers
        if ((moment == "starting" and seen) or (moment == "running" and workers >= 2)
                or (moment == "dask" and (out / "study.json").exists())):
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the batch ended before the signal: the test proved nothing"
    time.sleep(0.3)
    seen |= _descendants(proc.pid)
    if sig == signal.SIGINT:
        os.killpg(proc.pid, sig)
    else:
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    text = err.decode()
    assert proc.returncode == status, text
    assert "Traceback" not in text and "Error" not in text, text
    assert text.strip().splitlines()[-1] == f"cosim batch: {what}"
    assert len(text.strip().splitlines()) <= 2, text
    assert not _gone(seen), f"left behind: {_gone(seen)} of {seen}"


# ------------------------------------------------------------------ resumed studies


def test_a_resumed_study_on_another_base_is_refused_unless_restarted(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Another --duration, an edited base scenario, an edited network: each named, exit 2,
    the folder untouched; --restart replaces the runs; the same base resumes as before."""
    import json

    scenario = _short(tmp_path, 3.0)
    out = tmp_path / "study"
    argv = ["batch", "--scenario", str(scenario), "--densities", "0", "--seeds", "1",
            "--no-progress", "--no-plots", "--workers", "1", "-o", str(out)]
    assert main(argv) == 0
    capsys.readouterr()

    def snapshot() -> dict[str, bytes]:
        return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*"))
                if p.is_file()}

    before = snapshot()
    assert "base" in json.loads((out / "study.json").read_text())
    assert main(argv) == 0  # the same base: resumed, nothing run again
    assert "0 run now, 1 already done" in capsys.readouterr().out
    for flags, edit, shown in (
        (["--duration", "2"], None, "scenario.duration_s 3.0 -> 2.0"),
        ([], ("mu = 0.6", "mu = 0.5"), "road.mu 0.6 -> 0.5"),
        ([], ("\n[road]", "\n# a comment\n[road]"), "the base scenario file's text"),
    ):
        text = scenario.read_text()
        if edit:
            scenario.write_text(text.replace(*edit))
        assert main([*argv, *flags]) == 2
        line = _one_line(capsys.readouterr().err)
        assert line.startswith(f"cosim batch: error: {out / 'study.json'}: base = "), line
        assert shown in line and "--restart" in line, line
        assert snapshot() == before
        scenario.write_text(text)
    scenario.write_text(scenario.read_text().replace("mu = 0.6", "mu = 0.5"))
    (out / "runs" / "notes.txt").write_text("mine\n")  # not a study's: --restart keeps it
    assert main([*argv, "--restart"]) == 0
    assert (out / "runs" / "notes.txt").read_text() == "mine\n"
    assert "1 run now, 0 already done" in capsys.readouterr().out
    runs = (out / "runs.csv").read_text().splitlines()
    assert len(runs) == 2 and len(list((out / "runs").glob("*.json"))) == 1


def test_a_folder_from_before_fingerprints_compares_what_its_runs_name(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import json

    scenario = _short(tmp_path, 3.0)
    out = tmp_path / "study"
    argv = ["batch", "--scenario", str(scenario), "--densities", "0", "--seeds", "1",
            "--no-progress", "--no-plots", "--workers", "1", "-o", str(out)]
    assert main(argv) == 0
    study = json.loads((out / "study.json").read_text())
    del study["base"]  # as a study.json without fingerprints
    (out / "study.json").write_text(json.dumps(study))
    capsys.readouterr()
    assert main([*argv, "--duration", "2"]) == 2
    assert "predates" in _one_line(capsys.readouterr().err)
    assert main(argv) == 0


def test_sighup_while_running_unwinds_like_sigterm(tmp_path: Path) -> None:
    """A closed terminal (SIGHUP): exit 129, one line, the previous run kept, nothing
    temporary left."""
    import signal
    import time

    out = tmp_path / "out"
    out.mkdir()
    (out / "metrics.csv").write_text("previous\n")
    scenario = _short(tmp_path, 60.0)
    text = scenario.read_text().replace("lane_changes = [{at_s = 0.5", "lane_changes = [{at_s = 5")
    scenario.write_text(text + "\n[traffic]\ndensity_veh_per_km_lane = 20.0\n")
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "run", str(scenario), "--out",
                             str(out), "--no-figures"], cwd=tmp_path, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    assert proc.stderr is not None
    os.set_blocking(proc.stderr.fileno(), False)
    seen = b""
    end = time.monotonic() + 240
    while b"step/s" not in seen and proc.poll() is None and time.monotonic() < end:
        seen += proc.stderr.read() or b""
        time.sleep(0.05)
    assert proc.poll() is None, seen
    proc.send_signal(signal.SIGHUP)
    proc.wait(timeout=60)
    seen += proc.stderr.read() or b""
    err = seen.decode(errors="replace").replace("\r", "\n")
    assert proc.returncode == 129, err
    assert err.strip().splitlines()[-1] == "cosim run: hung up (SIGHUP)"
    assert (out / "metrics.csv").read_text() == "previous\n" and len(list(out.iterdir())) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "s.toml"]


def test_a_scenario_given_as_a_study_says_so(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["batch", str(BASE), "--no-progress"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert "[study] = <missing>: a study file (this is a scenario" in line
    assert "--scenario FILE" in line


@pytest.mark.parametrize(("flags", "shown"), [
    (["--workers", "1000"], "argument --workers: 1000: an integer in [1, "),
    (["--seeds", "2000000000"], "argument --seeds: 2000000000: an integer in [1, 1000]"),
])
def test_bench_batch_bounds_its_work(flags: list[str], shown: str,
                                     capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["bench", "batch", *flags])
    assert info.value.code == 2
    assert shown in _one_line(capsys.readouterr().err)


@pytest.mark.parametrize("fd", [1, 2])
def test_a_closed_standard_stream_discards_what_goes_there(fd: int, tmp_path: Path) -> None:
    """`>&-` / `2>&-`: the user asked for nothing there; the run completes (exit 0)."""
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "cosim.cli", "run", str(_short(tmp_path)), "--out", str(out),
         "--no-figures"], cwd=tmp_path, capture_output=True, timeout=300,
        preexec_fn=lambda: os.close(fd))  # noqa: PLW1509 (no threads in this child yet)
    assert done.returncode == 0, done.stderr
    assert (out / "metrics.csv").is_file()


def test_gui_with_a_display_nobody_serves_is_one_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """DISPLAY set, no X server behind it: refused at once, in one line (not a traci
    traceback)."""
    import socket

    from cosim.traffic.gui import x_display_reachable

    number = next(n for n in range(180, 300) if not Path(f"/tmp/.X11-unix/X{n}").exists())
    monkeypatch.setenv("DISPLAY", f":{number}")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["run", str(BASE), "--gui", "--out", str(tmp_path / "out")]) == 2
    line = _one_line(capsys.readouterr().err)
    assert f"DISPLAY = ':{number}'" in line and "no X server answers" in line, line
    assert not (tmp_path / "out").exists()
    # a listening socket where X puts its own is a display
    folder = Path("/tmp/.X11-unix")
    if not os.access(folder if folder.exists() else folder.parent, os.W_OK):
        return
    folder.mkdir(exist_ok=True)
    path = folder / f"X{number}"
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as server:
        server.bind(str(path))
        server.listen(1)
        try:
            assert x_display_reachable(f":{number}") and x_display_reachable(f":{number}.0")
        finally:
            path.unlink()
    assert not x_display_reachable(f":{number}")
