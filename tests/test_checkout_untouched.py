"""The guard in conftest.py: the session fails when a test writes into the checkout."""

from __future__ import annotations

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_tests_run_outside_the_checkout() -> None:
    """Default output folders (results/... under the current directory) are temporary."""
    assert not Path.cwd().resolve().is_relative_to(ROOT)


def test_guard_sees_created_changed_and_removed_files(tmp_path: Path, checkout_guard) -> None:
    snapshot, changes = checkout_guard
    (tmp_path / "results" / "case").mkdir(parents=True)
    (tmp_path / "results" / "case" / "metrics.csv").write_text("a\n1\n")
    (tmp_path / "README.md").write_text("x")
    (tmp_path / "results" / "README.md").write_text("x")
    (tmp_path / "__pycache__").mkdir()
    before = snapshot(tmp_path)
    assert changes(before, snapshot(tmp_path)) == []
    (tmp_path / "results" / "batch").mkdir()
    (tmp_path / "results" / "batch" / "summary.csv").write_text("s")
    metrics = tmp_path / "results" / "case" / "metrics.csv"
    metrics.write_text("a\n2\n")
    os.utime(metrics, ns=(1, 1))
    (tmp_path / "results" / "README.md").unlink()
    (tmp_path / "README.md").write_text("edited by the developer meanwhile")
    (tmp_path / "plan.png").write_text("a figure outside results/")
    (tmp_path / "__pycache__" / "x.png").write_text("cache")  # caches are not the tests'
    assert changes(before, snapshot(tmp_path)) == [
        "changed results/case/metrics.csv", "created plan.png",
        "created results/batch/summary.csv", "removed results/README.md"]
