"""cosim deletes only what it made: a run's staging folders and temporary files carry a
name only cosim gives (cosim.output: `.NAME.tmp-cosim-<pid>-<random>`), so a user's own
`.x.tmp-*` / `.x.old-*` beside the output folder are never removed or moved; and
`cosim batch --restart` follows no symbolic link when it clears a study's folder."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from cosim.cli import main

HERE = Path(__file__).resolve().parent
BASE = HERE / "bad_inputs" / "base.toml"
NETWORK = HERE.parent / "networks" / "highway.net.xml"


def _scenario(folder: Path) -> Path:
    """The bad-input tests' valid scenario, 2 s long."""
    scenario = folder / "s.toml"
    scenario.write_text(BASE.read_text().replace("duration_s = 10.0", "duration_s = 2.0")
                        .replace("start_s = 2.0", "start_s = 0.5")
                        .replace("lane_changes = [{at_s = 1.0", "lane_changes = [{at_s = 0.5")
                        .replace("[road]\n", f'[road]\nnetwork = "{NETWORK}"\n'))
    return scenario


def _tree(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("previous", [False, True])
def test_a_run_leaves_the_users_look_alike_folders_alone(
        tmp_path: Path, previous: bool) -> None:
    """`cosim run --out D/x` beside the user's own `.x.tmp-mydata/`, `.x.old-mydata/`,
    and names that look like cosim's but are not (no process id, a live process's, a
    link, a file): all kept as they were, with or without a previous run in D/x; the
    run's own result in x and nothing else new."""
    scenario = _scenario(tmp_path)
    d = tmp_path / "D"
    d.mkdir()
    mine = {
        ".x.tmp-mydata/notes.txt": b"mine\n",
        ".x.old-mydata/metrics.csv": b"my own table\n",
        ".x.tmp-cosim-mydata/a.txt": b"mine too\n",
        f".x.tmp-cosim-{os.getpid()}-abcdefgh/b.txt": b"a live owner's\n",
        ".x.old-cosim-1-notrandom/c.txt": b"not tempfile's name\n",
        ".x.tmp-12345.csv": b"a file\n",
    }
    for name, data in mine.items():
        (d / name).parent.mkdir(exist_ok=True)
        (d / name).write_bytes(data)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_bytes(b"keep\n")
    (d / ".x.tmp-cosim-999999999-abcdefgh").symlink_to(elsewhere)
    if previous:
        (d / "x").mkdir()
        (d / "x" / "metrics.csv").write_text("previous\n")
    assert main(["run", str(scenario), "--out", str(d / "x"), "--no-figures"]) == 0
    after = _tree(d)
    assert {k: v for k, v in after.items() if not k.startswith("x/")} == mine
    assert (d / ".x.tmp-cosim-999999999-abcdefgh").is_symlink()
    assert _tree(elsewhere) == {"keep.txt": b"keep\n"}
    assert sorted(p.name for p in (d / "x").iterdir()) == [
        "metrics.csv", "plans.csv", "timing.csv", "trace.csv"]
    assert (d / "x" / "metrics.csv").read_text() != "previous\n"


def test_a_study_keeps_the_users_look_alike_temporary_files(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A study's runs/ cleans the temporary files a killed study left (cosim's names
    only): the user's `.notes.tmp-mine` there is kept."""
    out = tmp_path / "study"
    (out / "runs").mkdir(parents=True)
    (out / "runs" / ".notes.tmp-mine").write_text("mine\n")
    (out / "runs" / ".0123456789ab.tmp-cosim-abcd_123.json").write_text("{")  # a killed write
    argv = ["batch", "--scenario", str(_scenario(tmp_path)), "--densities", "0", "--seeds",
            "1", "--workers", "1", "--no-progress", "--no-plots", "-o", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    assert sorted(p.name for p in (out / "runs").iterdir() if p.name.startswith(".")) == [
        ".notes.tmp-mine"]


def test_restart_follows_no_symbolic_link(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`batch --restart` with runs/ a link to another folder: refused in one line (exit
    2), nothing in the link's target or the study folder deleted; a link in traces/
    (named like a run) is removed itself, its target kept."""
    out = tmp_path / "study"
    argv = ["batch", "--scenario", str(_scenario(tmp_path)), "--densities", "0", "--seeds",
            "1", "--workers", "1", "--no-progress", "--no-plots", "-o", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    target = tmp_path / "target"
    (out / "runs").rename(target)
    (target / "abcdef012345.json").write_text('{"mine": true}\n')  # a run id's shape
    (out / "runs").symlink_to(target)
    before, study = _tree(target), _tree(out)
    assert main([*argv, "--restart"]) == 2
    line = _one_line(capsys.readouterr().err)
    assert f"{out / 'runs'}: --restart = 'a symbolic link to {target}'" in line, line
    assert "follows no link" in line
    assert _tree(target) == before and _tree(out) == study

    (out / "runs").unlink()
    target.rename(out / "runs")
    (out / "runs" / "abcdef012345.json").unlink()
    kept = tmp_path / "my_traces"
    kept.mkdir()
    (kept / "trace.csv").write_text("mine\n")
    (out / "traces").mkdir()
    (out / "traces" / "abcdef012345").symlink_to(kept)
    assert main([*argv, "--restart"]) == 0
    assert "1 run now, 0 already done" in capsys.readouterr().out
    assert not (out / "traces" / "abcdef012345").exists()
    assert _tree(kept) == {"trace.csv": b"mine\n"}
