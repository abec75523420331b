"""`cosim batch`'s exit status: 0 when every run of the grid finished, 1 when any
failed (said in one line on stderr; the summaries are written all the same), and 0 again
once `--retry-failed` has run them through."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosim.cli import main
from cosim.study.run_table import RunStatus
from cosim.study.store import read_record, runs_dir, write_record

STUDY = Path(__file__).parents[1] / "data" / "study_small.toml"
FLAGS = ["--densities", "5", "--seeds", "1-2", "--drivers", "sumo", "--no-progress",
         "--no-plots", "--workers", "1"]


def test_a_batch_with_failed_runs_exits_1(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "study"
    assert main(["batch", str(STUDY), "-o", str(out), *FLAGS]) == 0
    capsys.readouterr()
    # one of the two runs recorded failed (as a worker records a run that raised)
    run_id = sorted(p.stem for p in runs_dir(out).glob("*.json"))[0]
    record = read_record(out, run_id)
    assert record is not None and record["status"] == RunStatus.OK
    write_record(out, {**record, "status": RunStatus.FAILED, "error": "RuntimeError: lost"})

    assert main(["batch", str(STUDY), "-o", str(out), *FLAGS]) == 1
    captured = capsys.readouterr()
    lines = [ln for ln in captured.err.splitlines() if "runs failed" in ln]
    assert lines == [f"cosim batch: 1 of 2 runs failed (their errors in the column error of "
                     f"{out / 'runs.csv'}; --retry-failed runs them again)"], captured.err
    assert (out / "summary.csv").is_file() and "1 failed" in captured.out

    assert main(["batch", str(STUDY), "-o", str(out), "--retry-failed", *FLAGS]) == 0
