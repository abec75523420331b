"""`cosim batch [STUDY.toml] [flags]`: a grid of runs, resumable, on local
processes (default) or a Dask cluster (`--dask ADDRESS` or `--dask local`).

Writes DIR/runs/<run_id>.json (one per finished run), DIR/runs.csv,
DIR/summary.csv, DIR/summary.md, DIR/plots/density.png and, over --shares, fleet.md and
DIR/plots/share.png. Running the same command again
skips the runs already recorded. Everything the user gives is checked before
anything is written. DIR is results/batch/<study name>; a study file run with
grid flags (a subset, or more) and no --out / --name gets its own folder named
after the flags, so that it never replaces the whole study's summary.

Exit status: 0 when every run of the grid finished, 1 when any failed (the summaries
are written all the same; --retry-failed runs those again), 2 for bad input.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from cosim.commands import (
    WORKERS_PER_CORE,
    PlainHelp,
    add_figure_format,
    compile_first,
    count,
    max_workers,
)
from cosim.errors import InputError
from cosim.output import check_output_dir
from cosim.study.dask_cluster import LOCAL_CLUSTER
from cosim.study.grid import GridValues, RunSpec, expand
from cosim.study.run_table import Driver
from cosim.study.runner import StudyOptions, run_study
from cosim.study.spec import (
    DENSITY,
    DRIVER,
    FLEET_DRIVER,
    MU,
    OCCUPANT,
    PLANT,
    SEED,
    SHARE,
    Study,
    check_seed_count,
    load_study,
)
from cosim.study.store import check_same_base
from cosim.validation import MISSING, Field, not_a_file

SOURCE = "command line"
EXIT_RUNS_FAILED = 1  # a study with failed runs, as `cosim run` when its run fails


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "batch",
        help="a study: runs over density x seed x p x mu x share x driver x plant, resumable",
        description=__doc__,
        formatter_class=PlainHelp,
    )
    p.add_argument("study", nargs="?", type=Path, help="study file (TOML, [study] table)")
    p.add_argument("--scenario", type=Path, metavar="FILE",
                   help="base scenario (replaces the study's)")
    p.add_argument("-o", "--out", type=Path, metavar="DIR",
                   help="output folder (default: results/batch/<study name>)")
    p.add_argument("--name", help="study name (default: the study file's, or 'study')")
    p.add_argument("--densities", metavar="LIST", help="veh/km/lane, comma-separated, e.g. 5,10,20")
    p.add_argument("--seeds", metavar="LIST",
                   help="comma-separated seeds or a range A-B, e.g. 1-10")
    p.add_argument("--occupants", metavar="LIST", help="occupant types p, comma-separated")
    p.add_argument("--mu", metavar="LIST", help="road friction values, comma-separated")
    p.add_argument("--shares", metavar="LIST",
                   help="automated vehicles' shares ([fleet] share, 0-1), comma-separated, "
                   "e.g. 0,0.1,0.2,0.4")
    p.add_argument("--fleet-drivers", metavar="LIST",
                   help="who drives the automated vehicles ([fleet] driver): cosim, sumo, acc, "
                   "cacc (comma-separated)")
    p.add_argument("--drivers", metavar="LIST",
                   help="SV drivers: mimo, siso, sumo (comma-separated)")
    p.add_argument("--plants", metavar="LIST",
                   help="SV plants: twotrack, bicycle (comma-separated)")
    p.add_argument("--duration", type=float, metavar="S", help="simulated time of each run (s)")
    p.add_argument("--traces", action="store_true", default=None,
                   help="keep each run's trace files in DIR/traces/<run_id>/")
    p.add_argument("--workers", type=count("--workers"), metavar="N",
                   help="processes (default: the machine's cores)")
    p.add_argument("--allow-many-workers", action="store_true",
                   help=f"allow --workers above {WORKERS_PER_CORE} x the cores")
    p.add_argument("--dask", metavar="ADDRESS",
                   help="run on a Dask cluster: a scheduler address, or 'local' (LocalCluster "
                   "of --workers processes)")
    p.add_argument("--retry-failed", action="store_true", help="run failed runs again")
    p.add_argument("--restart", action="store_true",
                   help="replace the runs DIR holds (needed when the base scenario, "
                   "--duration or the network changed since they were made)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--no-plots", action="store_true", help="no figures")
    add_figure_format(p)
    p.set_defaults(func=run)


def parse_list(text: str | None, flag: str, element: Field) -> tuple[Any, ...] | None:
    """A comma-separated flag value, each element checked like the study file's."""
    if text is None:
        return None
    if isinstance(text, list):  # argparse turns a value of "--" ("--seeds=--") into []
        text = ",".join(text)
    items = [s.strip() for s in text.split(",")]
    if not all(items):
        raise InputError(SOURCE, flag, text, f"a comma-separated list, each {element.allowed()}")
    values: list[Any] = []
    for item in items:
        if element is SEED and "-" in item.lstrip("-"):
            lo, _, hi = item.partition("-")
            try:
                a, b = int(lo), int(hi)
            except ValueError:
                raise InputError(SOURCE, flag, text, "integers or ranges A-B") from None
            if b < a:
                raise InputError(SOURCE, flag, text, "ranges A-B with A <= B")
            check_seed_count(SOURCE, flag, text, b - a + 1 + len(values))
            values += [element.convert(SOURCE, flag, v) for v in range(a, b + 1)]
            continue
        raw: Any = item
        if element.kind in (int, float):
            try:
                raw = int(item) if element.kind is int else float(item)
            except ValueError:
                raise InputError(SOURCE, flag, item, element.allowed()) from None
        values.append(element.convert(SOURCE, flag, raw))
    if len(set(values)) != len(values):
        raise InputError(SOURCE, flag, text, "distinct values")
    return tuple(values)


def study_from_args(args: argparse.Namespace) -> Study:
    """The study file (if any) with the flags applied; validated."""
    if args.study is not None:
        study = load_study(args.study)
    elif args.scenario is not None:
        study = Study(
            path=None, name="study", description="", scenario=args.scenario, densities=(),
            seeds=(), occupants=None, mus=None, drivers=None, plants=None, duration=None,
            traces=False,
        )
    else:
        raise InputError(SOURCE, "STUDY", MISSING, "the study file is missing: give one "
                         "(cosim batch STUDY.toml), or --scenario FILE with --densities and "
                         "--seeds")
    if args.duration is not None and not 0 < args.duration <= 3600:
        raise InputError(SOURCE, "--duration", args.duration, "a number of seconds in (0, 3600]")
    study = study.with_flags(
        scenario=args.scenario,
        name=args.name,
        densities=parse_list(args.densities, "--densities", DENSITY),
        seeds=parse_list(args.seeds, "--seeds", SEED),
        occupants=parse_list(args.occupants, "--occupants", OCCUPANT),
        mus=parse_list(args.mu, "--mu", MU),
        shares=parse_list(args.shares, "--shares", SHARE),
        fleet_drivers=parse_list(args.fleet_drivers, "--fleet-drivers", FLEET_DRIVER),
        drivers=parse_list(args.drivers, "--drivers", DRIVER),
        plants=parse_list(args.plants, "--plants", PLANT),
        duration=args.duration,
        traces=args.traces,
    )
    problem = not_a_file(study.scenario)
    if problem is not None:
        raise InputError(SOURCE, "--scenario", str(study.scenario),
                         "not found (a scenario file, .toml)" if problem == "not found"
                         else f"a scenario file (this is {problem})")
    if not study.densities:
        raise InputError(SOURCE, "--densities", None, "required without a study file")
    if not study.seeds:
        raise InputError(SOURCE, "--seeds", None, "required without a study file")
    check_workers(args)
    if args.restart and args.retry_failed:
        raise InputError(SOURCE, "--retry-failed", True,
                         "no --retry-failed with --restart (--restart runs every run again)")
    if (args.plants is not None and study.drivers is not None
            and set(study.drivers) == {Driver.SUMO}):
        raise InputError(SOURCE, "--plants", args.plants,
                         "no --plants when every driver is sumo (SUMO drives the SV: no plant of "
                         "ours runs)")
    return study


def check_workers(args: argparse.Namespace) -> None:
    """--workers within the machine (a small multiple of its cores, unless
    --allow-many-workers) and meaningful: with a remote --dask the cluster's workers run
    the runs, so --workers is refused there (with --dask local it sizes the LocalCluster)."""
    if args.workers is None:
        return
    if args.workers < 1:
        raise InputError(SOURCE, "--workers", args.workers, "an integer >= 1")
    if args.dask is not None and args.dask != LOCAL_CLUSTER:
        raise InputError(SOURCE, "--workers", args.workers,
                         f"no --workers with --dask {args.dask} (the cluster's own workers run "
                         "the runs; --workers sizes only --dask local)")
    limit = max_workers()  # --allow-many-workers lifts it
    if args.workers > limit and not args.allow_many_workers:
        raise InputError(SOURCE, "--workers", args.workers,
                         f"at most {limit} ({WORKERS_PER_CORE} x this machine's "
                         f"{os.cpu_count() or 1} cores), or add --allow-many-workers")


def specs_of(study: Study) -> list[RunSpec]:
    """The study's runs; grid values the study leaves open are the base scenario's.

    Every distinct grid value is applied to the base scenario once here, so a
    value the scenario rules refuse is an input error before anything runs."""
    from cosim.study.spec import check_study

    base = check_study(study)
    grid = GridValues(
        densities=study.densities, seeds=study.seeds,
        occupants=study.occupants or (base.sv.occupant,), mus=study.mus or (base.road.mu,),
        drivers=study.drivers or (base.sv.controller,), plants=study.plants or (base.sv.plant,),
        shares=study.shares or (base.fleet.share,),
        fleet_drivers=study.fleet_drivers or (base.fleet.driver,),
        zero_share_once=not base.fleet.vtypes,
        duration=study.duration, variants=study.variants,
    )
    return expand(study.scenario, grid, traces=study.traces)


# Flags that change which runs a study file's grid holds (--traces changes no result).
GRID_FLAGS = ("scenario", "densities", "seeds", "occupants", "mu", "shares", "fleet_drivers",
              "drivers", "plants", "duration")


def subset_name(args: argparse.Namespace, study: Study) -> str:
    """The folder name of a study file run with grid flags and no --out / --name:
    the study's name and the flags ("study_density--densities_10--seeds_1"), so
    that a subset never replaces the whole study's summary.csv, summary.md and plot
    (and the same subset resumes in the same folder). The study's own name without
    such flags."""
    if args.study is None or args.out is not None or args.name is not None:
        return study.name
    parts = []
    for flag in GRID_FLAGS:
        value = getattr(args, flag)
        if value is not None:
            text = value.stem if isinstance(value, Path) else str(value)
            parts.append(f"{flag}_{re.sub(r'[^A-Za-z0-9.]+', '.', text).strip('.')}")
    if not parts:
        return study.name
    name = "--".join([study.name, *parts])
    if len(name) > 80:  # a long list of values: the flags' digest instead
        digest = hashlib.sha1("--".join(parts).encode()).hexdigest()[:10]
        name = f"{study.name}--subset-{digest}"
    return name


def run(args: argparse.Namespace) -> int:
    study = study_from_args(args)
    specs = specs_of(study)
    name = subset_name(args, study)
    if name != study.name:
        study = replace(study, name=name)
    out = args.out or Path("results") / "batch" / study.name
    check_output_dir(out)  # a bad --out is an input error now, not after the runs
    workers = args.workers or os.cpu_count() or 1
    where = f"Dask {args.dask}" if args.dask else f"{workers} local processes"

    def announce(todo: int) -> None:
        print(f"cosim batch: {study.name}: {len(specs)} runs ({len(specs) - todo} done before) "
              f"on {where} -> {out}", file=sys.stderr)

    if not args.restart:
        check_same_base(out, specs)  # a resumed study on another base: refused now
    if args.dask is None and any(d != Driver.SUMO for d in {s.driver for s in specs}):
        compile_first()  # before the progress bar, which then counts runs only
    options = StudyOptions(
        workers=workers, dask=args.dask, retry_failed=args.retry_failed, restart=args.restart,
        progress=not args.no_progress, plots=not args.no_plots,
        figure_format=args.figure_format, title=study.name,
    )
    result = run_study(specs, out, options, on_start=announce)
    print(
        f"{len(result.runs)} runs ({result.ran} run now, {result.skipped} already done), "
        f"{result.failed} failed, {result.wall_time:.1f} s\n"
        f"  {out / 'runs.csv'}\n  {out / 'summary.csv'}\n  {out / 'summary.md'}"
        + "".join(f"\n  {p}" for p in result.plots)
    )
    runs = result.runs
    if "vehicles_asked" in runs:
        short = runs[runs["vehicles_inserted"] < runs["vehicles_asked"]]
        if len(short):
            print(f"cosim batch: in {len(short)} of {len(runs)} runs SUMO inserted fewer vehicles "
                  f"at t = 0 than the density asked for (densities "
                  f"{', '.join(f'{d:g}' for d in sorted(set(short['density'])))} veh/km/lane; "
                  f"columns vehicles_asked, vehicles_inserted of {out / 'runs.csv'})",
                  file=sys.stderr)
    if result.failed:
        print(f"cosim batch: {result.failed} of {len(result.runs)} runs failed (their errors "
              f"in the column error of {out / 'runs.csv'}; --retry-failed runs them again)",
              file=sys.stderr)
        return EXIT_RUNS_FAILED
    return 0
