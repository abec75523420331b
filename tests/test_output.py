"""Atomic output: a result file is either absent or complete, never truncated; a run's
folder is replaced whole or not at all; names and paths that escape are refused."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import matplotlib
import pandas as pd
import pytest

from cosim.errors import InputError, Terminated
from cosim.output import (
    atomic_open,
    atomic_path,
    atomic_write_csv,
    atomic_write_json,
    atomic_write_text,
    check_name,
    check_output_dir,
    make_output_dir,
    new_run_dir,
    recover_stale,
    staged_dir,
    stale_temp_files,
)

matplotlib.use("Agg")


def test_text_and_json_round_trip(tmp_path: Path) -> None:
    atomic_write_text(tmp_path / "a.txt", "héllo\nworld\n")
    atomic_write_json(tmp_path / "c.json", {"x": 1.5, "y": [1, 2]})
    assert (tmp_path / "a.txt").read_text(encoding="utf-8") == "héllo\nworld\n"
    assert (tmp_path / "c.json").read_text().startswith("{\n")
    assert pd.read_json(tmp_path / "c.json", typ="series")["x"] == 1.5
    assert stale_temp_files(tmp_path) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "c.json"]


def test_files_get_the_mode_open_would_give(tmp_path: Path) -> None:
    """Not mkstemp's private 0600: other users and tools may read the results."""
    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    path = atomic_write_text(tmp_path / "atomic.txt", "x")
    assert path.stat().st_mode & 0o777 == plain.stat().st_mode & 0o777


def test_csv_round_trip_and_replaces_old_file(tmp_path: Path) -> None:
    path = tmp_path / "runs.csv"
    path.write_text("old\n")
    frame = pd.DataFrame({"run": ["a", "b"], "iae": [0.1, 0.25]})
    atomic_write_csv(path, frame)
    back = pd.read_csv(path)
    assert list(back.columns) == ["run", "iae"]
    assert back["iae"].tolist() == [0.1, 0.25]
    assert stale_temp_files(tmp_path) == []


def test_error_while_writing_keeps_the_old_file(tmp_path: Path) -> None:
    path = tmp_path / "summary.csv"
    path.write_text("complete,old\n")
    with pytest.raises(RuntimeError), atomic_open(path) as fh:
        fh.write("half a line")
        raise RuntimeError("interrupted")
    assert path.read_text() == "complete,old\n"
    assert stale_temp_files(tmp_path) == []


def test_interrupt_while_writing_leaves_no_new_file(tmp_path: Path) -> None:
    path = tmp_path / "new.csv"
    with pytest.raises(KeyboardInterrupt), atomic_open(path) as fh:
        fh.write("a,b\n1,")
        raise KeyboardInterrupt
    assert not path.exists()


def test_killed_process_never_leaves_a_truncated_file(tmp_path: Path) -> None:
    """SIGKILL half way through a write: the final name does not appear at all."""
    path = tmp_path / "trace.csv"
    script = textwrap.dedent(
        f"""
        import os, signal
        from cosim.output import atomic_open
        with atomic_open({str(path)!r}) as fh:
            fh.write("t,x\\n" + "0.0,1.0\\n" * 10000)
            fh.flush()
            os.kill(os.getpid(), signal.SIGKILL)
        """
    )
    proc = subprocess.run([sys.executable, "-c", script], timeout=60)
    assert proc.returncode == -signal.SIGKILL
    assert not path.exists()
    leftovers = stale_temp_files(tmp_path)
    assert len(leftovers) == 1 and leftovers[0].stat().st_size > 0  # the evidence, hidden


def test_figure_through_atomic_path(tmp_path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    path = tmp_path / "fig.png"
    with atomic_path(path) as tmp:
        assert tmp.suffix == ".png" and tmp.parent == tmp_path
        fig.savefig(tmp)
    plt.close(fig)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert stale_temp_files(tmp_path) == []


def test_atomic_open_refuses_append(tmp_path: Path) -> None:
    with pytest.raises(ValueError), atomic_open(tmp_path / "x.txt", "a"):
        pass


def test_make_output_dir_and_unique_run_dirs(tmp_path: Path) -> None:
    base = make_output_dir(tmp_path / "results" / "deep")
    assert base.is_dir()
    a = new_run_dir(base, "case51")
    b = new_run_dir(base, "case51")
    assert a != b and a.is_dir() and b.is_dir()
    assert a.name.startswith("case51-") and b.name.startswith("case51-")


def test_temp_file_is_in_the_same_directory(tmp_path: Path) -> None:
    """os.replace is atomic only within one file system: the temp file sits beside the target."""
    seen: list[Path] = []
    with atomic_path(tmp_path / "x.json") as tmp:
        seen.append(tmp)
        tmp.write_text("{}")
        assert os.path.dirname(tmp) == str(tmp_path)
    assert not seen[0].exists()
    assert (tmp_path / "x.json").read_text() == "{}"


def test_check_output_dir_creates_nothing(tmp_path: Path) -> None:
    assert check_output_dir(tmp_path / "a" / "b" / "c") == tmp_path / "a" / "b" / "c"
    assert check_output_dir(tmp_path) == tmp_path
    assert list(tmp_path.iterdir()) == []


def test_check_output_dir_refuses_files(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("x")
    for bad in (tmp_path / "file", tmp_path / "file" / "sub" / "deeper"):
        with pytest.raises(InputError) as info:
            check_output_dir(bad, "command line", "--out")
        assert info.value.key == "--out" and str(bad) in str(info.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


# ------------------------------------------------------------------ run folders and names


def _tree(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_staged_dir_swaps_the_complete_folder_in(tmp_path: Path) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "old.png").write_bytes(b"old")
    with staged_dir(out) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(".run.tmp-")
        (tmp / "metrics.csv").write_text("new\n")
        assert _tree(out) == {"old.png": b"old"}  # untouched until the block completes
    assert _tree(out) == {"metrics.csv": b"new\n"}  # whole: no old PNG beside the new CSV
    assert [p.name for p in tmp_path.iterdir()] == ["run"]


@pytest.mark.parametrize("error", [KeyboardInterrupt, Terminated, RuntimeError])
def test_staged_dir_interrupted_keeps_exactly_the_old_folder(
    tmp_path: Path, error: type[BaseException]
) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "metrics.csv").write_text("old\n")
    with pytest.raises(error), staged_dir(out) as tmp:
        (tmp / "metrics.csv").write_text("new\n")
        (tmp / "trajectories.png").write_bytes(b"")
        raise error()
    assert _tree(out) == {"metrics.csv": b"old\n"}
    assert [p.name for p in tmp_path.iterdir()] == ["run"]


def _dead_pid() -> int:
    """The process id of a process that has ended."""
    return int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                              capture_output=True, text=True, check=True).stdout)


def test_a_killed_swap_is_recovered_by_the_next_run(tmp_path: Path) -> None:
    """What SIGKILL can leave: a half-built folder, or the old folder renamed aside (under
    the names staged_dir makes, its owner's process id in them)."""
    out = tmp_path / "run"
    dead = _dead_pid()
    (tmp_path / f".run.tmp-cosim-{dead}-abcd_123").mkdir()
    (tmp_path / f".run.tmp-cosim-{dead}-abcd_123" / "trace.csv").write_text("half")
    (tmp_path / f".run.old-cosim-{dead}-efgh_456").mkdir()
    (tmp_path / f".run.old-cosim-{dead}-efgh_456" / "metrics.csv").write_text("old\n")
    recover_stale(out)
    assert _tree(out) == {"metrics.csv": b"old\n"}
    assert [p.name for p in tmp_path.iterdir()] == ["run"]


def test_a_live_runs_stage_is_left_alone(tmp_path: Path) -> None:
    """Two runs into one folder: the second must not delete the first's stage (its
    owner, this process, still runs), only a dead owner's."""
    out = tmp_path / "run"
    live = tmp_path / f".run.tmp-cosim-{os.getpid()}-abcdefgh"
    live.mkdir()
    (tmp_path / f".run.tmp-cosim-{_dead_pid()}-abcdefgh").mkdir()
    with staged_dir(out) as tmp:
        (tmp / "metrics.csv").write_text("new\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["run", live.name])


@pytest.mark.parametrize("name", ["", ".", "..", "../x", "a/b", ".hidden", "x" * 81, "a\x00"])
def test_check_name_refuses_names_that_escape(name: str) -> None:
    with pytest.raises(InputError) as info:
        check_name("study.toml", "study.name", name)
    assert info.value.key == "study.name" and "\n" not in str(info.value)


@pytest.mark.parametrize("name", ["density", "paper_case1", "a.b-c", "_x", "9"])
def test_check_name_accepts_folder_names(name: str) -> None:
    assert check_name("s", "k", name) == name


@pytest.mark.parametrize("path", ["", ".", "..", "/"])
def test_check_output_dir_refuses_the_current_folder_and_its_parent(path: str) -> None:
    with pytest.raises(InputError, match="--out = "):
        check_output_dir(path)
    with pytest.raises(InputError):
        check_output_dir(Path(path))


def test_check_output_dir_whole_refuses_folders_a_run_did_not_write(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "metrics.csv").write_text("x\n")
    (out / "tracking.png").write_bytes(b"png")
    assert check_output_dir(out, whole=True) == out  # a previous run's: replaced whole
    (out / "thesis.tex").write_text("mine\n")
    with pytest.raises(InputError, match="thesis.tex"):
        check_output_dir(out, whole=True)
    assert check_output_dir(out) == out  # batch adds files beside its own: no whole rule
