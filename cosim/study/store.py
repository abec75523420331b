"""A study's folder DIR as the store of its runs: one record per finished run
(`DIR/runs/<run_id>.json`, written atomically by the parent as soon as the run
finishes), `runs.csv` assembled from the records, and `DIR/study.json`: the grid and the
base it was run with (`base_fingerprint`).

Resume and restart: runs whose record exists are skipped (a failed one is run again
with `retry_failed`); a folder whose runs were made from another base (another scenario,
or other contents of the network, .sumocfg, route or additional files) is refused
(`check_same_base`) unless `restart`, which removes what the study wrote
(`clear_study`) and runs everything. runs.csv depends only on the records, and the
records only on the parameters, except the wall-time columns (`wall_time_s` and the
run's own `wall_*` and `cpu_*` columns), which differ from one execution to the next."""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cosim.errors import InputError
from cosim.output import atomic_write_json, make_output_dir, stale_temp_files
from cosim.study.grid import RunSpec
from cosim.study.run_table import (
    NO_FLEET_DRIVER,
    NO_VARIANT,
    PARAMETERS,
    RunStatus,
    is_timing_column,
)

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
        check_clearable(out_dir)
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
        r.setdefault("share", 0.0)  # records made before the share was a grid value
        r.setdefault("fleet_driver", NO_FLEET_DRIVER)  # ... before fleet drivers
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


# The scenario keys that name files, by (table, key): the fingerprint holds those files by
# their contents (`input_hashes`), not by where they are.
FILE_KEYS = (("road", "network"), ("road", "sumocfg"), ("traffic", "routes"))


def input_hashes(scenario: Any) -> dict[str, dict[str, str]]:
    """Every file a run of `scenario` reads besides the scenario file, by what it is to the
    scenario (`network`, `road.sumocfg`, `road.sumocfg route-files[0]`,
    `road.sumocfg additional-files[0]`, `traffic.routes[0]`): the SHA-256 of its contents
    (unpacked if gzipped, as SUMO reads it) and its name, for messages only."""
    from cosim.traffic.own_demand import sumo_file_bytes
    from cosim.validation import MAX_NETWORK_BYTES

    files: list[tuple[str, Path]] = [("network", Path(scenario.network))]
    theirs = tuple(Path(r) for r in scenario.traffic.routes or ())
    if scenario.sumocfg is not None:
        files.append(("road.sumocfg", Path(scenario.sumocfg)))
        demand = scenario.demand
        cfg_routes = demand.route_files[:len(demand.route_files) - len(theirs)]
        files += [(f"road.sumocfg route-files[{i}]", f) for i, f in enumerate(cfg_routes)]
        files += [(f"road.sumocfg additional-files[{i}]", f)
                  for i, f in enumerate(demand.additional_files)]
    files += [(f"traffic.routes[{i}]", f) for i, f in enumerate(theirs)]
    return {key: {"sha256": hashlib.sha256(sumo_file_bytes(path, MAX_NETWORK_BYTES)).hexdigest(),
                  "file": path.name} for key, path in files}


def _without_files(resolved: dict[str, Any]) -> dict[str, Any]:
    """A resolved scenario without the keys that name files (FILE_KEYS)."""
    out = {table: dict(values) if isinstance(values, dict) else values
           for table, values in resolved.items()}
    for table, key in FILE_KEYS:
        if isinstance(out.get(table), dict):
            out[table].pop(key, None)
    return out


def _names_files(name: str) -> bool:
    """Whether a variant's override `name` sets a key that names files."""
    from cosim.scenario import override_target

    try:
        table, key, _ = override_target(name)
    except KeyError:
        return False
    return (table, key) in FILE_KEYS


def base_fingerprint(specs: Sequence[RunSpec]) -> dict[str, Any]:
    """What the runs of a study folder were made from besides their grid values: the base
    scenario resolved (every key, in file units, with the study's duration), its file's
    bytes, the contents of every file its runs read (`input_hashes`: network, .sumocfg,
    route and additional files, those a variant names too) and the variants' overrides.
    Files are held by their contents, not their paths: the same project moved or cloned
    elsewhere resumes its studies. Kept in DIR/study.json, so that a study resumed into
    DIR with another base is refused (`check_same_base`), not silently rerun under new
    run ids with the old rows dropped from runs.csv, nor mixed with runs of other inputs."""
    from cosim.scenario import load_scenario, scenario_to_dict, with_overrides

    if not specs:
        return {}
    spec = specs[0]
    base = load_scenario(spec.scenario)
    if spec.duration is not None:
        base = with_overrides(base, duration=spec.duration)
    resolved = json.loads(json.dumps(scenario_to_dict(base), default=str))
    inputs = input_hashes(base)
    variants = {s.variant: s.overrides for s in specs if s.variant != NO_VARIANT}
    for name, overrides in sorted(variants.items()):
        if any(_names_files(key) for key, _ in overrides):
            inputs |= {f"variant {name}: {key}": value for key, value in
                       input_hashes(with_overrides(base, **dict(overrides))).items()}
    return {
        "scenario": _without_files(resolved),
        "scenario_sha": spec.scenario_sha,
        "inputs": inputs,
        "variants": {name: [list(p) for p in overrides]
                     for name, overrides in variants.items()},
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


def _input_changes(before: Mapping[str, Any], now: Mapping[str, Any]) -> list[str]:
    """The input files whose contents differ, in words ("the contents of traffic.routes[0]
    (flows.rou.xml)"); a fingerprint from before the inputs were hashed holds the
    network's bytes only (`network_sha`), so its other files are not recorded."""
    old = before.get("inputs")
    if not isinstance(old, dict):
        old = ({"network": {"sha256": before["network_sha"]}} if "network_sha" in before
               else {})
    new = now.get("inputs", {})
    changes = []
    for key in [k for k in new if k in old] + [k for k in old if k not in new]:
        if key in new and old[key].get("sha256") == new[key]["sha256"]:
            continue
        if key not in new:
            changes.append(f"{key} {old[key].get('file', '')} -> (absent)")
        else:
            changes.append(f"the contents of {key} ({new[key]['file']})")
    changes += [f"{key} {'(not recorded)' if before.get('inputs') is None else '(absent)'}"
                f" -> {new[key]['file']}" for key in new if key not in old]
    return changes


def base_changes(before: Mapping[str, Any], now: Mapping[str, Any]) -> list[str]:
    """What differs between two fingerprints, in words ("scenario.duration_s 10.0 -> 5.0",
    "the contents of traffic.routes[0] (flows.rou.xml)")."""
    old = _flat(_without_files(dict(before.get("scenario") or {})))
    new = _flat(_without_files(dict(now.get("scenario") or {})))
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
    return changes + _input_changes(before, now)


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
            f"the base scenario and input files the runs in {out_dir} were made with: add "
            "--restart to replace them, or give another -o")
    return now


STUDY_FOLDERS = ("runs", "traces", "plots")  # the folders a study writes into DIR


def check_clearable(out_dir: Path) -> None:
    """InputError if --restart would have to follow a symbolic link to clear DIR: its
    runs/, traces/ or plots/ a link (clearing it would delete in the link's target)."""
    for name in STUDY_FOLDERS:
        folder = out_dir / name
        if folder.is_symlink():
            raise InputError(
                str(folder), "--restart", f"a symbolic link to {os.readlink(folder)}",
                f"a study folder whose {', '.join(f'{n}/' for n in STUDY_FOLDERS)} are "
                "folders (--restart removes what the study wrote and follows no link): "
                "remove the link, or give another -o")


def clear_study(out_dir: Path) -> None:
    """--restart: remove the runs a study folder holds: what a study writes (records
    `runs/<run_id>.json`, `traces/<run_id>/`, the tables, the plots), nothing else, and
    only where a study.json says it is a study's folder. No link is followed: a link
    among them is removed itself, and a linked runs/, traces/ or plots/ refused
    (`check_clearable`) before anything is removed."""
    import re
    import shutil

    if not (out_dir / STUDY_FILE).is_file():
        return
    check_clearable(out_dir)
    run_id = re.compile(r"[0-9a-f]{12}")
    for p in runs_dir(out_dir).glob("*.json"):
        if run_id.fullmatch(p.stem):
            p.unlink(missing_ok=True)
    for p in (out_dir / "traces").glob("*"):
        if p.is_symlink() and run_id.fullmatch(p.name):
            p.unlink(missing_ok=True)
        elif p.is_dir() and run_id.fullmatch(p.name):
            shutil.rmtree(p, ignore_errors=True)
    for p in (out_dir / "plots").glob("*"):
        if p.suffix in (".png", ".svg", ".pdf"):
            p.unlink(missing_ok=True)
    for name in ("runs.csv", "summary.csv", "summary.md", STUDY_FILE):
        (out_dir / name).unlink(missing_ok=True)
