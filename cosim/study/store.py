"""A study's folder DIR as the store of its runs: one record per finished run
(`DIR/runs/<run_id>.json`, written atomically by the parent as soon as the run
finishes), `runs.csv` assembled from the records, and `DIR/study.json`: the grid and the
base it was run with (`base_fingerprint`).

Resume and restart: runs whose record exists are skipped (a failed one is run again
with `retry_failed`); a folder whose runs were made from another base is refused
(`check_same_base`) unless `restart`, which removes what the study wrote
(`clear_study`) and runs everything. runs.csv depends only on the records, and the
records only on the parameters, except the wall-time columns (`wall_time_s` and the
run's own `wall_*` and `cpu_*` columns), which differ from one execution to the next."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cosim.errors import InputError
from cosim.output import atomic_write_json, make_output_dir, stale_temp_files
from cosim.study.grid import RunSpec, file_sha
from cosim.study.run_table import NO_VARIANT, PARAMETERS, RunStatus, is_timing_column

if TYPE_CHECKING:  # pandas loads lazily: a worker process does not need it
    import pandas as pd

# Record keys kept in DIR/runs/<run_id>.json but not in runs.csv.
RECORD_ONLY = ("traceback", "code")
STUDY_FILE = "study.json"  # the grid and the base it was run with (`base_fingerprint`)


# --------------------------------------------------------------------------- records


def runs_dir(out_dir: Path) -> Path:
    return out_dir / "runs"


def record_path(out_dir: Path, run_id: str) -> Path:
    return runs_dir(out_dir) / f"{run_id}.json"


def write_record(out_dir: Path, record: dict[str, Any]) -> None:
    """Write a run's record atomically: a reader sees the whole file or none."""
    atomic_write_json(record_path(out_dir, record["run_id"]), record)


def read_record(out_dir: Path, run_id: str) -> dict[str, Any] | None:
    path = record_path(out_dir, run_id)
    try:
        return json.loads(path.read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return None


def pending(
    specs: Iterable[RunSpec], out_dir: Path, *, retry_failed: bool = False
) -> list[RunSpec]:
    """The runs that still have to be run: no record yet (or a failed one, if asked)."""
    todo = []
    for spec in specs:
        record = read_record(out_dir, spec.run_id)
        if record is None or (retry_failed and record.get("status") != RunStatus.OK):
            todo.append(spec)
    return todo


# --------------------------------------------------------------------------- resume


@dataclass(frozen=True)
class ResumeState:
    """What a call of a study finds in its folder."""

    fingerprint: dict[str, Any]  # the base the runs are made from (study.json's "base")
    todo: list[RunSpec]  # the runs to run now
    done: int  # runs recorded before this call (skipped)
    failed: int  # of those, the failed ones


def resume_state(specs: Sequence[RunSpec], out_dir: Path, *, restart: bool,
                 retry_failed: bool) -> ResumeState:
    """The runs still to run and those recorded already; InputError if the folder's runs
    were made from another base (`check_same_base`), unless `restart`: then every run."""
    if restart:
        return ResumeState(base_fingerprint(specs), list(specs), done=0, failed=0)
    fingerprint = check_same_base(out_dir, specs)
    todo = pending(specs, out_dir, retry_failed=retry_failed)
    todo_ids = {s.run_id for s in todo}
    failed = sum(
        1 for s in specs
        if s.run_id not in todo_ids
        and (read_record(out_dir, s.run_id) or {}).get("status") != RunStatus.OK
    )
    return ResumeState(fingerprint, todo, done=len(specs) - len(todo), failed=failed)


def prepare_folder(out_dir: Path, specs: Sequence[RunSpec], fingerprint: dict[str, Any], *,
                   title: str, restart: bool) -> None:
    """DIR ready for the runs: cleared first if `restart`, the records' folder made, the
    temporary files of a killed study removed, study.json written."""
    if restart:
        clear_study(out_dir)
    make_output_dir(runs_dir(out_dir))
    for stale in stale_temp_files(runs_dir(out_dir)):  # left by a killed study
        stale.unlink(missing_ok=True)
    atomic_write_json(
        out_dir / STUDY_FILE,
        {"title": title, "base": fingerprint,
         "runs": [asdict(s) | {"run_id": s.run_id} for s in specs]},
    )


# --------------------------------------------------------------------------- runs.csv


def assemble(specs: Iterable[RunSpec], out_dir: Path) -> pd.DataFrame:
    """runs.csv as a table: one row per run of the grid, sorted by its parameters.

    Columns: run_id, the parameters, status, error, the metrics (in the order
    the first successful run reports them), then the wall-time columns."""
    import pandas as pd

    records = [read_record(out_dir, s.run_id) for s in specs]
    records = [r for r in records if r is not None]
    for r in records:
        r.setdefault("variant", NO_VARIANT)  # records of studies without variants
    records.sort(key=lambda r: tuple(r[p] for p in PARAMETERS))
    head = ["run_id", *PARAMETERS, "status", "error"]
    metric_columns: list[str] = []
    for r in sorted(records, key=lambda r: r["status"] != RunStatus.OK):
        metric_columns += [k for k in r if k not in head and k not in metric_columns]
    metric_columns = [k for k in metric_columns if k not in RECORD_ONLY]
    timing = [c for c in metric_columns if is_timing_column(c)]
    columns = head + [c for c in metric_columns if c not in timing] + timing
    return pd.DataFrame.from_records(records, columns=columns)


# --------------------------------------------------------------------------- identity


def provenance() -> dict[str, Any]:
    """The code that ran this call of the study (run ids do not name it: after
    changing cosim, start a new output folder)."""
    import subprocess

    from cosim import __version__

    info: dict[str, Any] = {"cosim": __version__}
    root = Path(__file__).resolve().parents[2]  # the checkout holding the package
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "cosim"],
                               capture_output=True, text=True, timeout=10, check=True).stdout
        info.update(git_commit=head, cosim_files_modified=len(dirty.splitlines()))
    except (OSError, subprocess.SubprocessError):
        pass  # not a git checkout
    return info


def base_fingerprint(specs: Sequence[RunSpec]) -> dict[str, Any]:
    """What the runs of a study folder were made from besides their grid values: the base
    scenario resolved (every key, in file units, with the study's duration), its file's and
    its network's bytes, and the variants' overrides. Kept in DIR/study.json, so that a
    study resumed into DIR with another base is refused (`check_same_base`), not silently
    rerun under new run ids with the old rows dropped from runs.csv."""
    from cosim.scenario import load_scenario, scenario_to_dict, with_overrides

    if not specs:
        return {}
    spec = specs[0]
    base = load_scenario(spec.scenario)
    if spec.duration is not None:
        base = with_overrides(base, duration=spec.duration)
    resolved = json.loads(json.dumps(scenario_to_dict(base), default=str))
    return {
        "scenario": resolved,
        "scenario_sha": spec.scenario_sha,
        "network_sha": file_sha(base.network),
        "variants": {s.variant: [list(p) for p in s.overrides] for s in specs
                     if s.variant != NO_VARIANT},
    }


def _flat(tree: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(tree, dict):
        out: dict[str, Any] = {}
        for k, v in tree.items():
            out.update(_flat(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    if isinstance(tree, list) and any(isinstance(v, (dict, list)) for v in tree):
        out = {}
        for i, v in enumerate(tree):
            out.update(_flat(v, f"{prefix}[{i}]"))
        return out
    return {prefix: tree}


def base_changes(before: Mapping[str, Any], now: Mapping[str, Any]) -> list[str]:
    """What differs between two fingerprints, in words ("scenario.duration_s 10.0 -> 5.0")."""
    old, new = _flat(before.get("scenario", {})), _flat(now.get("scenario", {}))
    changes = [f"{k} {old.get(k, '(absent)')!r} -> {new.get(k, '(absent)')!r}"
               for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]
    if before.get("scenario") is None and before.get("duration") != now.get("duration"):
        changes.append(f"duration {before.get('duration')!r} -> {now.get('duration')!r}")
    for name in sorted(set(before.get("variants", {})) & set(now.get("variants", {}))):
        if before["variants"][name] != now["variants"][name]:
            changes.append(f"variant {name!r} {before['variants'][name]} -> "
                           f"{now['variants'][name]}")
    if not changes and before.get("scenario_sha") != now.get("scenario_sha"):
        changes.append("the base scenario file's text (same settings; the run ids name its "
                       "bytes)")
    if before.get("network_sha", now["network_sha"]) != now["network_sha"]:
        changes.append("the network file")
    return changes


def read_fingerprint(out_dir: Path) -> dict[str, Any] | None:
    """The fingerprint a study folder's runs were made with (None: no study there yet).
    A study.json without a `base` gives the base file's hash and duration of the runs it
    lists (and `scenario` None)."""
    try:
        data = json.loads((out_dir / STUDY_FILE).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict):
        return None
    if isinstance(data.get("base"), dict):
        return data["base"]
    runs = data.get("runs") or []
    if not runs or not isinstance(runs[0], dict):
        return None
    return {"scenario": None, "scenario_sha": runs[0].get("scenario_sha"),
            "duration": runs[0].get("duration")}


def check_same_base(out_dir: Path, specs: Sequence[RunSpec]) -> dict[str, Any]:
    """The study's fingerprint; InputError if DIR holds runs made from another base (a
    resumed study must not mix them, nor drop them silently): --restart or another -o."""
    now = base_fingerprint(specs)
    before = read_fingerprint(out_dir)
    if before is None or not now:
        return now
    if before.get("scenario") is None:  # a study.json without a base: what its runs name
        now_old = {"scenario_sha": now["scenario_sha"], "duration": specs[0].duration}
        changes = [] if now_old == {k: before.get(k) for k in now_old} else [
            "the base scenario file or --duration (this folder's study.json predates the "
            "settings kept for comparison)"]
    else:
        changes = base_changes(before, now)
    if changes:
        shown = "; ".join(changes[:3]) + (f"; and {len(changes) - 3} more"
                                            if len(changes) > 3 else "")
        raise InputError(
            str(out_dir / STUDY_FILE), "base", shown,
            f"the base scenario the runs in {out_dir} were made with: add --restart to "
            "replace them, or give another -o")
    return now


def clear_study(out_dir: Path) -> None:
    """--restart: remove the runs a study folder holds: what a study writes (records
    `runs/<run_id>.json`, `traces/<run_id>/`, the tables, the plots), nothing else, and
    only where a study.json says it is a study's folder."""
    import re
    import shutil

    if not (out_dir / STUDY_FILE).is_file():
        return
    run_id = re.compile(r"[0-9a-f]{12}")
    for p in runs_dir(out_dir).glob("*.json"):
        if run_id.fullmatch(p.stem):
            p.unlink(missing_ok=True)
    for p in (out_dir / "traces").glob("*"):
        if p.is_dir() and run_id.fullmatch(p.name):
            shutil.rmtree(p, ignore_errors=True)
    for p in (out_dir / "plots").glob("*"):
        if p.suffix in (".png", ".svg", ".pdf"):
            p.unlink(missing_ok=True)
    for name in ("runs.csv", "summary.csv", "summary.md", STUDY_FILE):
        (out_dir / name).unlink(missing_ok=True)
