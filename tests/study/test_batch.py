"""Batch studies (cosim/study/: grid, store, pool, dask_cluster, runner, spec;
cosim/commands/batch.py).

The study tests run the real co-simulation (libsumo) on a short scenario
(tests/data/batch_base.toml: 5 s simulated, 400 m of traffic) over the grid of
tests/data/study_small.toml (2 densities x 2 seeds x 2 drivers). The local
study is run once and is the reference of the Dask, resume and failure tests.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from cosim.cli import main
from cosim.errors import InputError
from cosim.study.grid import GridValues, apply_spec, expand
from cosim.study.run_table import RunStatus, is_timing_column
from cosim.study.runner import StudyOptions, run_study
from cosim.study.spec import load_study
from cosim.study.store import read_record, write_record

DATA = Path(__file__).parents[1] / "data"
STUDY = DATA / "study_small.toml"
BASE = DATA / "batch_base.toml"
N_RUNS = 8  # 2 densities x 2 seeds x 2 drivers


def reproducible(path: Path) -> pd.DataFrame:
    """runs.csv without its wall-clock columns (the rest must not depend on how it ran)."""
    frame = pd.read_csv(path)
    return frame[[c for c in frame.columns if not is_timing_column(c)]]


# --------------------------------------------------------------------------- no SUMO


def test_run_ids_depend_on_parameters_and_base_scenario_only(tmp_path: Path) -> None:
    grid = GridValues(densities=[5, 20], seeds=[1, 2], occupants=[0.5], mus=[0.8],
                      drivers=["mimo", "sumo"], plants=["twotrack"])
    a = expand(BASE, grid)
    b = expand(BASE, replace(grid, densities=[5.0, 20.0]), traces=True)
    assert len({s.run_id for s in a}) == N_RUNS
    assert {s.run_id for s in a} == {s.run_id for s in b}  # 5 == 5.0; traces change nothing
    other = tmp_path / "base.toml"
    other.write_text(BASE.read_text() + "\n# edited\n")
    assert not {s.run_id for s in a} & {s.run_id for s in expand(other, grid)}
    c = expand(BASE, replace(grid, duration=3.0))
    assert not {s.run_id for s in a} & {s.run_id for s in c}


def test_records_are_written_whole(tmp_path: Path) -> None:
    record = {"run_id": "abc", "status": RunStatus.OK, "x": float("nan")}
    write_record(tmp_path, record)
    assert math.isnan(read_record(tmp_path, "abc")["x"])
    assert [p.name for p in (tmp_path / "runs").iterdir()] == ["abc.json"]  # no temp left


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("densities_veh_per_km_lane = [5, 500]", "densities_veh_per_km_lane[1]"),
        ("densities_veh_per_km_lane = []", "densities_veh_per_km_lane"),
        ("densities_veh_per_km_lane = [5, 5]", "densities_veh_per_km_lane"),
        ("drivers = ['mimo', 'sumo-native']", "drivers[1]"),
        ("occupants = [1.5]", "occupants[0]"),
        ("seeds = [1.5]", "seeds[0]"),
        ("densitys = [5]", "densitys"),
    ],
)
def test_bad_study_file_is_one_line_error_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, key: str
) -> None:
    lines = [ln for ln in STUDY.read_text().splitlines()
             if not ln.startswith(text.split(" ")[0] + " ")]
    study = tmp_path / "bad.toml"
    study.write_text("\n".join(lines + [text]).replace("batch_base.toml", str(BASE)) + "\n")
    with pytest.raises(InputError) as info:
        load_study(study)
    assert f"study.{key}" in str(info.value)
    out = tmp_path / "out"
    assert main(["batch", str(study), "-o", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cosim batch: error:")
    assert not out.exists()


def test_bad_flags_are_input_errors(tmp_path: Path) -> None:
    out = tmp_path / "out"
    for flags in (["--densities", "5,x"], ["--seeds", "3-1"], ["--drivers", "mpc"],
                  ["--mu", "0.05"], ["--workers", "0"], ["--sed", "1"]):
        try:
            status = main(["batch", str(STUDY), "-o", str(out), *flags])
        except SystemExit as exc:  # argparse's own checks (types, unknown flags)
            status = exc.code
        assert status == 2, flags
    assert main(["batch", "--scenario", str(BASE), "-o", str(out)]) == 2  # no densities
    assert not out.exists()


def test_flags_replace_study_lists() -> None:
    from cosim.cli import build_parser
    from cosim.commands.batch import study_from_args

    args = build_parser().parse_args(
        ["batch", str(STUDY), "--seeds", "3-5,9", "--mu", "0.4,0.8"])
    study = study_from_args(args)
    assert study.seeds == (3, 4, 5, 9) and study.mus == (0.4, 0.8)
    assert study.densities == (5.0, 10.0) and study.size == 2 * 4 * 2 * 2


# --------------------------------------------------------------------------- real studies


@pytest.fixture(scope="module")
def local_study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small study on the local process pool, uninterrupted: the reference."""
    out = tmp_path_factory.mktemp("batch") / "local"
    assert main(["batch", str(STUDY), "-o", str(out), "--workers", "2", "--no-progress"]) == 0
    return out


def test_local_study_records_every_run_and_summarises_each_cell(local_study: Path) -> None:
    runs = pd.read_csv(local_study / "runs.csv")
    assert len(runs) == N_RUNS and len(list((local_study / "runs").glob("*.json"))) == N_RUNS
    # Runs that raise inside the simulation are the simulation's business; here:
    # each run is either ok or failed with its error, and most of them are ok.
    failed = runs["status"] == RunStatus.FAILED
    assert runs["status"].isin([RunStatus.OK, RunStatus.FAILED]).all()
    assert runs.loc[failed, "error"].astype(str).str.len().gt(0).all()
    assert (~failed).sum() >= N_RUNS // 2, runs.loc[failed, "error"].tolist()
    grid = set(zip(runs["driver"], runs["density"], runs["seed"], strict=True))
    assert grid == {(d, k, s) for d in ("mimo", "sumo") for k in (5.0, 10.0) for s in (1, 2)}
    assert runs["run_id"].is_unique and (runs["wall_time_s"] > 0).all()
    summary = pd.read_csv(local_study / "summary.csv")
    assert len(summary) == 4 and (summary["runs"] == 2).all()
    assert summary["failed"].sum() == failed.sum()
    rates = summary[["success_rate", "collision_rate"]].dropna().to_numpy()
    assert len(rates) and ((rates >= 0) & (rates <= 1)).all()
    table = (local_study / "summary.md").read_text().splitlines()
    assert len(table) == 2 + 4 and table[0].startswith("| driver | density")
    assert (local_study / "plots" / "density.png").stat().st_size > 10_000
    # no detectors in its runs: no fundamental diagram, no traffic columns
    assert not (local_study / "fundamental.csv").exists()
    assert not [c for c in summary.columns if c.startswith(("traffic_", "speed_spread"))]
    # the comfort block: per cell, from the runs' own metrics
    comfort = (local_study / "comfort.md").read_text().splitlines()
    assert len(comfort) == 2 + 4 and "max jerk" in comfort[0]
    done = runs[~failed]
    for _, cell in summary.iterrows():
        mine = done[(done["driver"] == cell["driver"]) & (done["density"] == cell["density"])]
        assert cell["max_long_jerk_mps3_max"] == pytest.approx(mine["max_long_jerk_mps3"].max())
        assert 0.0 <= cell["long_accel_jump_share_p50"] <= 1.0
        assert cell["hard_post_change_brakes"] == (mine["post_change_max_decel_mps2"] > 3.0).sum()
        assert cell["hard_follower_brakes"] == (mine["follower_max_decel_mps2"] > 3.0).sum()
        gaps = mine["entry_follower_gap_m"][np.isfinite(mine["entry_follower_gap_m"])]
        assert cell["entry_follower_gap_m_min"] == (pytest.approx(gaps.min()) if len(gaps)
                                                    else pytest.approx(np.nan, nan_ok=True))


def test_same_command_again_runs_nothing(local_study: Path, capsys: pytest.CaptureFixture) -> None:
    before = {p.name: p.stat().st_mtime_ns for p in (local_study / "runs").iterdir()}
    summary = (local_study / "summary.csv").read_bytes()
    assert main(["batch", str(STUDY), "-o", str(local_study), "--no-progress"]) == 0
    assert "(0 run now, 8 already done)" in capsys.readouterr().out
    assert {p.name: p.stat().st_mtime_ns for p in (local_study / "runs").iterdir()} == before
    assert (local_study / "summary.csv").read_bytes() == summary


def test_dask_local_cluster_gives_the_same_runs(local_study: Path, tmp_path: Path) -> None:
    out = tmp_path / "dask"
    code = main(["batch", str(STUDY), "-o", str(out), "--dask", "local", "--workers", "2",
                 "--no-progress"])
    assert code == 0
    pd.testing.assert_frame_equal(reproducible(out / "runs.csv"),
                                  reproducible(local_study / "runs.csv"))
    for name in ("summary.csv", "summary.md"):
        assert (out / name).read_bytes() == (local_study / name).read_bytes()


def test_killed_study_resumes_to_the_same_csvs(local_study: Path, tmp_path: Path) -> None:
    out = tmp_path / "killed"
    command = [sys.executable, "-m", "cosim.cli", "batch", str(STUDY), "-o", str(out),
               "--workers", "1", "--no-progress"]
    # A session of its own: SIGKILL reaches the pool's processes too.
    proc = subprocess.Popen(command, start_new_session=True, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline and proc.poll() is None:
        if len(list((out / "runs").glob("*.json"))) >= 2:
            break
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = len(list((out / "runs").glob("*.json")))
    assert 2 <= finished < N_RUNS and not (out / "runs.csv").exists()
    assert main(["batch", str(STUDY), "-o", str(out), "--workers", "2", "--no-progress"]) == 0
    pd.testing.assert_frame_equal(reproducible(out / "runs.csv"),
                                  reproducible(local_study / "runs.csv"))
    for name in ("summary.csv", "summary.md"):
        assert (out / name).read_bytes() == (local_study / name).read_bytes()


def test_failing_run_is_recorded_and_the_others_go_on(tmp_path: Path) -> None:
    # A run that raises inside its worker: its base scenario is edited after the
    # grid was made, so execute_run refuses it (the run id names the file's bytes).
    edited = tmp_path / "edited.toml"
    edited.write_text(BASE.read_text() + "# a copy\n")  # other bytes: other run ids
    grid = GridValues(densities=[5], seeds=[1, 2], occupants=[0.5], mus=[0.8],
                      drivers=["mimo"], plants=["twotrack"])
    good = expand(BASE, grid)
    bad = expand(edited, replace(grid, seeds=[1]))
    edited.write_text(BASE.read_text().replace("speed_kmh = 80.0", "speed_kmh = 85.0"))
    assert not {s.run_id for s in good} & {s.run_id for s in bad}
    out = tmp_path / "out"
    quiet = StudyOptions(workers=2, progress=False, plots=False)
    result = run_study(bad + good, out, quiet)
    runs = result.runs.set_index("run_id")
    assert len(runs) == 3 and result.failed == 1
    assert runs.loc[bad[0].run_id, "status"] == RunStatus.FAILED
    assert "InputError" in runs.loc[bad[0].run_id, "error"]
    assert "edited" in runs.loc[bad[0].run_id, "error"]
    assert (runs.loc[[s.run_id for s in good], "status"] == RunStatus.OK).all()
    assert "traceback" in read_record(out, bad[0].run_id)
    # A second call runs nothing; asked to, it retries the failed run (which fails again).
    assert run_study(bad + good, out, quiet).ran == 0
    again = run_study(bad + good, out, replace(quiet, workers=1, retry_failed=True))
    assert again.ran == 1 and again.failed == 1


def _children(pid: int) -> list[int]:
    """Processes whose parent is `pid` (Linux /proc)."""
    kids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            kids.append(int(stat.parent.name))
    return kids


def test_a_run_whose_process_dies_is_recorded_failed(tmp_path: Path) -> None:
    # A real crash: every process the pool starts is SIGKILLed while this test
    # watches, so the run never returns; it is retried alone, dies again and is
    # recorded failed, and the study still finishes. Then, undisturbed, a retry runs.
    from multiprocessing import forkserver

    specs = expand(BASE, GridValues(densities=[5], seeds=[1], occupants=[0.5], mus=[0.8],
                                    drivers=["sumo"], plants=["twotrack"]))
    stop = threading.Event()

    def kill_workers() -> None:
        while not stop.is_set():
            server = getattr(forkserver._forkserver, "_forkserver_pid", None)
            for pid in _children(server) if server else []:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
            time.sleep(0.005)

    killer = threading.Thread(target=kill_workers, daemon=True)
    killer.start()
    try:
        result = run_study(specs, tmp_path, StudyOptions(workers=2, progress=False, plots=False))
    finally:
        stop.set()
        killer.join()
    assert result.failed == 1
    assert result.runs["error"].str.startswith("worker process died").all()
    again = run_study(specs, tmp_path,
                      StudyOptions(workers=2, progress=False, plots=False, retry_failed=True))
    assert again.ran == 1 and again.failed == 0


@pytest.fixture
def ctrl_c_raises() -> Iterator[None]:
    """Ctrl-C raises KeyboardInterrupt in this process, as in a terminal's foreground, also
    when the suite itself was started with SIGINT ignored (a script's background job)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def test_a_worker_ignores_ctrl_c_and_sighup_from_its_start(ctrl_c_raises: None) -> None:
    # The fork server sets this before it forks (cosim.study.fork_server), so no moment of a
    # worker's start-up lets a terminal's Ctrl-C, sent to the whole group, end it with a
    # traceback; the command's own process keeps its handlers.
    from cosim.study.pool import _ending_pool

    with _ending_pool(1) as pool:
        seen = pool.submit(signal.getsignal, signal.SIGINT).result()
    assert seen == signal.SIG_IGN
    assert signal.getsignal(signal.SIGINT) != signal.SIG_IGN
    if hasattr(signal, "SIGHUP"):
        with _ending_pool(1) as pool:
            assert pool.submit(signal.getsignal, signal.SIGHUP).result() == signal.SIG_IGN


def test_ctrl_c_while_a_worker_starts_is_held_until_the_pool_can_end_it(
        monkeypatch: pytest.MonkeyPatch, ctrl_c_raises: None) -> None:
    # A Ctrl-C landing between the fork server's fork and the pool's record of the new
    # worker would leave that worker to no one: it would outlive the batch and print a
    # traceback. The interrupt is sent here from inside the worker's start: held, it lands
    # once the pool has the worker, and the pool's end ends it.
    from cosim.study.pool import _ending_pool, _submit

    started: list[object] = []
    with pytest.raises(KeyboardInterrupt), _ending_pool(1) as pool:
        spawn = pool._spawn_process

        def spawn_interrupted() -> None:
            os.kill(os.getpid(), signal.SIGINT)
            spawn()
            started.extend(pool._processes.values())

        monkeypatch.setattr(pool, "_spawn_process", spawn_interrupted)
        _submit(pool, time.sleep, 30)
    assert len(started) == 1
    assert not started[0].is_alive()  # type: ignore[attr-defined]


def test_variants_are_a_grid_dimension_for_our_drivers_only(tmp_path: Path) -> None:
    grid = GridValues(densities=[10.0], seeds=[1, 2], occupants=[0.5], mus=[0.8],
                      drivers=["mimo", "sumo"], plants=["twotrack"])
    plain = expand(BASE, grid)
    variants = {"paper": {"replanning": False}, "lossy": {"replanning": True, "latency": 0.1}}
    varied = expand(BASE, replace(grid, variants=variants))
    assert len(varied) == 2 * 2 + 2  # mimo x 2 variants x 2 seeds, sumo x 2 seeds
    assert {s.variant for s in varied if s.driver == "sumo"} == {""}
    # runs without a variant keep their ids; each variant's runs get their own
    sumo_ids = {s.run_id for s in plain if s.driver == "sumo"}
    assert sumo_ids == {s.run_id for s in varied if s.driver == "sumo"}
    assert len({s.run_id for s in varied}) == len(varied)
    lossy = next(s for s in varied if s.variant == "lossy")
    scenario = apply_spec(lossy)
    assert scenario.planner.replanning and scenario.v2v.latency == 0.1
    head = f'[study]\nscenario = "{BASE}"\ndensities_veh_per_km_lane = [10]\nseeds = [1]\n'
    study = tmp_path / "study.toml"
    study.write_text(head + "[study.variants]\nreplan = { replanning = true }\n", encoding="utf-8")
    assert load_study(study).variants == {"replan": {"replanning": True}}
    study.write_text(head + "variants = { bad = 3 }\n", encoding="utf-8")
    with pytest.raises(InputError):
        load_study(study)


def test_subset_of_a_study_file_gets_its_own_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A study file with grid flags and no -o / --name writes beside the study's
    folder, never over its summary; the same subset resumes in the same folder."""
    from cosim.cli import build_parser
    from cosim.commands.batch import study_from_args, subset_name

    def name(*flags: str) -> str:
        args = build_parser().parse_args(["batch", str(STUDY), *flags])
        return subset_name(args, study_from_args(args))

    whole = load_study(STUDY).name
    assert name() == whole and name("--traces") == whole
    assert name("--densities", "10", "--seeds", "1") == f"{whole}--densities_10--seeds_1"
    assert name("--seeds", "1-3", "--name", "mine") == "mine"
    assert name("--seeds", ",".join(str(k) for k in range(1, 60))).startswith(
        f"{whole}--subset-")
    monkeypatch.chdir(tmp_path)
    flags = ["--densities", "10", "--seeds", "1", "--drivers", "sumo", "--duration", "2",
             "--no-progress", "--no-plots"]
    assert main(["batch", str(STUDY), *flags]) == 0
    folders = sorted(p.name for p in (tmp_path / "results" / "batch").iterdir())
    assert folders == [f"{whole}--densities_10--seeds_1--drivers_sumo--duration_2.0"]
    assert (tmp_path / "results" / "batch" / folders[0] / "summary.csv").is_file()


