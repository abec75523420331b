"""The result tables of README.md and docs/, computed from the code (`cosim docs`).

A table in a Markdown file is marked

    <!-- cosim docs: NAME (commit abc1234) -->
    | ... |
    <!-- end cosim docs: NAME -->

and `cosim docs` replaces what lies between the markers with `TABLES[NAME]`'s
output and the commit it ran on; `cosim docs --check --quick` recomputes the quick
tables and says which differ (the test suite runs it). Prose around a table is
not generated: a sentence quoting a number belongs in the table or must be
checked by hand when the table changes.
"""

from __future__ import annotations

import functools
import math
import re
import subprocess
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from cosim.scenario import load_scenario, project_root, with_overrides

ROOT = project_root()
PAPER_CASES = ("paper_case1_overtaking", "paper_case2_tv_lane_change",
               "paper_case3_lane_exchange")
CASE_LABELS = {"paper_case1_overtaking": "5.1 overtaking",
               "paper_case2_tv_lane_change": "5.2 TV changing lanes",
               "paper_case3_lane_exchange": "5.3 lane exchange"}
# The paper's own figures (Section 5, Fig. 10-12): tau_min, collision-free set, tau_opt, tau.
PAPER_PLANNING = {
    "paper_case1_overtaking": ("2.75", "[2.75, 6.75]", "6.25", "6.25"),
    "paper_case2_tv_lane_change": ("2.56", "[2.56, 8.56]", "5.56", "5.56"),
    "paper_case3_lane_exchange": ("2.23", "[6.98, 9.98]", "7.35 (eq. 13 gives 7.29)", "7.35"),
}
TRAFFIC = ("traffic_low", "traffic_medium", "traffic_high")
TRAFFIC_SEEDS = (1, 2, 3)
# a driver: our controller with the scenario's policy, or SUMO's own models for both
DRIVER_LABELS = {"mimo": "MIMO", "siso": "SISO", "sumo": "SUMO-native"}


@dataclass(frozen=True)
class Table:
    """One generated table: its Markdown, and whether it is quick (seconds) to make."""

    make: Callable[[], str]
    quick: bool
    command: str  # the cosim command whose figures the table holds


def _row(cells: list[Any]) -> str:
    return "|" + "|".join(f" {c} " if str(c) else " " for c in cells) + "|"


def _num(value: float, digits: int) -> str:
    return "inf" if math.isinf(value) else f"{value:.{digits}f}"


def _intervals(intervals: list[tuple[float, float]]) -> str:
    return " and ".join(f"[{lo:.2f}, {hi:.2f}]" for lo, hi in intervals) or "none"


def planning_table(tests: tuple[tuple[str, str], ...] = (("exact", "ours"), (
        "col", "ours, paper's CoL test"))) -> str:
    """docs/results.md: the tau sets of the three paper cases (`cosim plan`), both
    collision tests; docs/run_results.md: the exact test's (the co-simulation's first plan)."""
    from cosim.planning.planner import LaneChangePlanner
    from cosim.planning.situation import situation

    lines = [_row(["case", "", "tau_min (s)", "collision-free set (s)", "tau_opt, eq. 13 (s)",
                   "chosen tau (s)"]), "|---|---|---|---|---|---|"]
    for name in PAPER_CASES:
        sc = load_scenario(ROOT / "scenarios" / f"{name}.toml")
        lines.append(_row([CASE_LABELS[name], "paper", *PAPER_PLANNING[name]]))
        for test, label in tests:
            si = situation(sc)
            cfg = replace(sc.planner, collision_test=test)
            plan = LaneChangePlanner(sc.vehicle, si.road, cfg).plan(
                si.t, si.sv, si.target_lane, si.messages, si.occupant)
            tau = "-" if plan.tau is None else f"{plan.tau:.2f}"
            lines.append(_row(["", label, f"{plan.tau_min:.2f}",
                               _intervals(plan.collision_free_intervals),
                               f"{plan.tau_opt:.2f}", tau]))
    return "\n".join(lines)


def table2() -> str:
    """docs/results.md: Table 2's IAE, case 5.1 with the paper's tau
    (`cosim track --source paper`)."""
    from cosim.commands.track import CASES, HEADERS, case_reference
    from cosim.control.closed_loop import YAW_MOMENT_SHARE, LoopConfig
    from cosim.control.tracking import IAE_COLUMNS, PAPER_TABLE2, run_tracking

    case = CASES["5.1"]
    ref, _ = case_reference(case, "paper", None, case.mu)
    digits = {"vx": 4, "ye": 4, "phi_e_deg": 4, "delta_f_deg": 3, "fx_kn": 3}
    lines = [_row(["IAE", *(HEADERS[c] for c in IAE_COLUMNS)]), "|---" * 6 + "|"]
    for ctrl in ("mimo", "siso"):
        lines.append(_row([f"paper {ctrl.upper()} (veDYNA)",
                           *(f"{PAPER_TABLE2[ctrl][c]:.3f}" for c in IAE_COLUMNS)]))
    for plant, plant_label in (("twotrack", "two-track plant"), ("bicycle", "2-DOF plant")):
        for ctrl in ("mimo", "siso"):
            iae = run_tracking(LoopConfig(plant, ctrl, yaw_moment_share=YAW_MOMENT_SHARE), ref,
                               mu=case.mu, duration=10.0).iae()
            lines.append(_row([f"ours {ctrl.upper()}, {plant_label}",
                               *(f"{iae[c]:.{digits[c]}f}" for c in IAE_COLUMNS)]))
    return "\n".join(lines)


@functools.cache
def _run(name: str, overrides: tuple[tuple[str, Any], ...]) -> dict[str, Any]:
    from cosim.run.loop import run_scenario

    sc = load_scenario(ROOT / "scenarios" / f"{name}.toml")
    if overrides:
        sc = with_overrides(sc, **dict(overrides))
    return run_scenario(sc, None, write_figures=False)


def _metrics(name: str, **overrides: Any) -> dict[str, Any]:
    """metrics.csv's row of one run (each run made once per process: tables share them)."""
    return _run(name, tuple(sorted(overrides.items())))


def track_cases_table() -> str:
    """docs/control_results.md: the paper's three cases tracked on the two-track plant
    with the paper's tau_opt (`cosim track --case all --plant twotrack`)."""
    from cosim.commands.track import CASES, case_reference
    from cosim.control.closed_loop import YAW_MOMENT_SHARE, LoopConfig
    from cosim.control.tracking import run_tracking

    lines = [_row(["case", "mu", "tau (s)", "ye MIMO / SISO (m s)",
                   "phi_e MIMO / SISO (deg s)", "delta_f MIMO / SISO (deg s)",
                   "Fx MIMO / SISO (kN s)"]), "|---" * 7 + "|"]
    for case in CASES.values():
        ref, _ = case_reference(case, "paper", None, case.mu)
        mimo, siso = (run_tracking(LoopConfig("twotrack", c, yaw_moment_share=YAW_MOMENT_SHARE),
                                   ref, mu=case.mu, duration=10.0).iae()
                      for c in ("mimo", "siso"))
        target = ref.vxf * 3.6
        lines.append(_row([
            f"{case.name}, {case.vx0_kmh:.0f} -> {target:.0f} km/h, lane {case.origin_lane} "
            f"-> {case.target_lane}", f"{case.mu:g}", f"{ref.tau:.2f}",
            f"{mimo['ye']:.4f} / {siso['ye']:.4f}",
            f"{mimo['phi_e_deg']:.3f} / {siso['phi_e_deg']:.3f}",
            f"{mimo['delta_f_deg']:.2f} / {siso['delta_f_deg']:.2f}",
            f"{mimo['fx_kn']:.2f} / {siso['fx_kn']:.2f}"]))
    return "\n".join(lines)


def run_iae_table() -> str:
    """docs/run_results.md: Table 2's IAE columns of the co-simulation runs (metrics.csv)."""
    from cosim.control.tracking import PAPER_TABLE2

    cols = ("vx", "ye", "phi_e_deg", "delta_f_deg", "fx_kn")
    lines = [_row(["IAE", "Vx ((m/s) s)", "ye (m s)", "phi_e (deg s)", "delta_f (deg s)",
                   "Fx (kN s)"]), "|---" * 6 + "|",
             _row(['paper MIMO (veDYNA, "the single lane change")',
                   *(f"{PAPER_TABLE2['mimo'][c]:.3f}" for c in cols)]),
             _row(["paper SISO (veDYNA)", *(f"{PAPER_TABLE2['siso'][c]:.3f}" for c in cols)])]
    for name in PAPER_CASES:
        for controller in ("mimo", "siso"):  # the same policy: the controllers compared
            m = _metrics(name, controller=controller)
            lines.append(_row([
                f"ours {DRIVER_LABELS[controller]}, case {CASE_LABELS[name].split()[0]}",
                f"{m['iae_vx_mps_s']:.4f}", f"{m['iae_ye_m_s']:.4f}",
                f"{m['iae_phie_deg_s']:.3f}", f"{m['iae_deltaf_deg_s']:.3f}",
                f"{m['iae_fx_kn_s']:.3f}"]))
    return "\n".join(lines)


def run_outcomes_table() -> str:
    """docs/run_results.md: the paper's cases in SUMO, MIMO against SUMO-native, with jerk."""
    lines = [_row(["case", "driver", "collisions (ours / SUMO)", "lane change duration (s)",
                   "min gap (m)", "min TTC (s)", "max \\|ay\\| (m/s^2)",
                   "max jerk (m/s^3)"]), "|---" * 8 + "|"]
    for name in PAPER_CASES:
        for driver in ("mimo", "sumo"):
            m = _metrics(name, controller=driver)
            lines.append(_row([
                CASE_LABELS[name].split()[0], DRIVER_LABELS[driver],
                f"{m['collisions']} / {m['sumo_collisions']}",
                _num(m["lane_change_duration_s"], 2), _num(m["min_gap_m"], 2),
                _num(m["min_ttc_s"], 2), f"{m['max_abs_lat_accel_mps2']:.2f}",
                f"{m['max_jerk_mps3']:.2g}" if m["max_jerk_mps3"] < 100
                else f"{m['max_jerk_mps3']:.0f}"]))
    return "\n".join(lines)


def paper_runs_table() -> str:
    """docs/results.md: the paper's cases in SUMO, MIMO / SISO / SUMO-native (`cosim run`)."""
    lines = [_row(["case", "driver", "tau (s)", "collisions ours / SUMO",
                   "lane-change time (s)", "min gap (m)", "min TTC (s)",
                   "max \\|ay\\| (m/s^2)", "IAE ye (m s)", "IAE phi_e (deg s)"]),
             "|---" * 10 + "|"]
    for name in PAPER_CASES:
        for driver in ("mimo", "siso", "sumo"):
            m = _metrics(name, controller=driver)
            ours = driver != "sumo"
            lines.append(_row([
                CASE_LABELS[name].split()[0], DRIVER_LABELS[driver],
                f"{m['tau_first_s']:.2f}" if ours else "-",
                f"{m['collisions']} / {m['sumo_collisions']}",
                _num(m["lane_change_duration_s"], 2), _num(m["min_gap_m"], 2),
                _num(m["min_ttc_s"], 2), f"{m['max_abs_lat_accel_mps2']:.2f}",
                f"{m['iae_ye_m_s']:.4f}" if ours else "-",
                f"{m['iae_phie_deg_s']:.3f}" if ours else "-",
            ]))
    return "\n".join(lines)


def traffic_table() -> str:
    """docs/run_results.md: the traffic scenarios, seeds 1-3, our MIMO SV and the
    SUMO-native SV (`cosim run scenarios/traffic_*.toml --seed N [--controller sumo]`)."""
    densities = []
    for name in TRAFFIC:
        sc = load_scenario(ROOT / "scenarios" / f"{name}.toml")
        densities.append(f"{sc.traffic.density:g}")
    lines = [f"Densities {' / '.join(densities)} veh/km/lane (the files' "
             "`density_veh_per_km_lane`), 60 s each:", "",
             _row(["scenario", "driver", "seed", "requests", "plans (failed)", "lane changes",
                   "collisions (ours / SUMO)", "min gap (m)", "min TTC (s)",
                   "max \\|ay\\| (m/s^2)", "final lane"]), "|---" * 11 + "|"]
    for name in TRAFFIC:
        for driver in ("mimo", "sumo"):
            for seed in TRAFFIC_SEEDS:
                m = _metrics(name, seed=seed, controller=driver)
                ours = driver != "sumo"
                lines.append(_row([
                    name, DRIVER_LABELS[driver], seed, m["lane_change_requests"],
                    f"{m['plans']} ({m['plans_failed']})" if ours else "-", m["lane_changes"],
                    f"{m['collisions']} / {m['sumo_collisions']}", _num(m["min_gap_m"], 1),
                    _num(m["min_ttc_s"], 1), f"{m['max_abs_lat_accel_mps2']:.2f}",
                    m["final_lane"],
                ]))
    return "\n".join(lines)


TABLES: dict[str, Table] = {
    "planning": Table(planning_table, True, "cosim plan scenarios/paper_case*.toml "
                      "[--collision-test col]"),
    "table2": Table(table2, True, "cosim track --source paper"),
    "run_planning": Table(lambda: planning_table((("exact", "ours"),)), True,
                          "cosim plan scenarios/paper_case*.toml"),
    "paper_runs": Table(paper_runs_table, False, "cosim run scenarios/paper_case*.toml "
                        "[--controller siso|sumo]"),
    "track_cases": Table(track_cases_table, True, "cosim track --case all --plant twotrack"),
    "run_iae": Table(run_iae_table, False, "cosim run scenarios/paper_case*.toml "
                     "[--controller siso]"),
    "run_outcomes": Table(run_outcomes_table, False, "cosim run scenarios/paper_case*.toml "
                          "[--controller sumo]"),
    "traffic": Table(traffic_table, False, "cosim run scenarios/traffic_*.toml --seed N "
                     "[--controller sumo]"),
}
# The pages that hold marked tables or quote their figures (README quotes docs/results.md's).
DOCS = ("README.md", "docs/results.md", "docs/run_results.md", "docs/planning_results.md",
        "docs/control_results.md", "docs/batch_results.md", "docs/replanning_results.md",
        "docs/roads.md", "docs/gap_policy.md", "docs/merge_study.md")
BLOCK = re.compile(r"<!-- cosim docs: (?P<name>[a-z0-9_]+) \(commit (?P<commit>[^)]*)\) -->\n"
                   r"(?P<body>.*?)\n<!-- end cosim docs: (?P=name) -->", re.S)


def commit() -> str:
    """The checkout's commit, with '+changes' when cosim/ differs from it."""
    try:
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, timeout=10, check=True)
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "cosim",
                                "scenarios", "networks"], capture_output=True, text=True,
                               timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return head.stdout.strip() + ("+changes" if dirty.stdout.strip() else "")


def blocks(text: str) -> list[tuple[str, str, str]]:
    """(name, commit, body) of every marked table in a Markdown text."""
    return [(m["name"], m["commit"], m["body"]) for m in BLOCK.finditer(text)]


# A figure in prose that comes from a marked table: `<!-- cosim value: TABLE[ROW KEY;
# ...][COLUMN] -->0.09<!-- end value -->`. ROW KEY: the row's first cells, separated by
# ";" (an empty cell repeats the one above it), COLUMN: a header cell. `cosim docs` writes the
# table's cell there, `--check` fails when they differ; so a number in the text cannot
# drift from the table it quotes.
VALUE = re.compile(r"<!-- cosim value: (?P<name>[a-z0-9_]+)\[(?P<row>[^\]]*)\]"
                   r"\[(?P<column>[^\]]*)\] -->(?P<value>.*?)<!-- end value -->")


def _cells(line: str) -> list[str]:
    """A Markdown table row's cells (an escaped \\| stays inside its cell)."""
    cells = re.split(r"(?<!\\)\|", line.strip())[1:-1]
    return [c.strip() for c in cells]


def table_cell(body: str, row: list[str], column: str) -> str | None:
    """The cell of a table's text in the first row whose first cells are `row` (empty
    cells repeat the row above) under the header `column`; None: no such cell."""
    lines = [ln for ln in body.strip().splitlines() if ln.startswith("|")]
    if len(lines) < 3:
        return None
    header = _cells(lines[0])
    if column not in header:
        return None
    j = header.index(column)
    above: list[str] = []
    for line in lines[2:]:
        cells = _cells(line)
        full = [c or (above[i] if i < len(above) else "") for i, c in enumerate(cells)]
        above = full
        if full[:len(row)] == row and j < len(cells):
            return cells[j]
    return None


def check_values(texts: dict[str, str], tables: dict[str, str], *, write: bool
                 ) -> tuple[dict[str, str], list[str]]:
    """The inline values (VALUE) of every doc against the tables' bodies: the texts with
    each value set to its cell (write) and the problems (a value that differs from its
    cell, or names a table, row or column that is not there)."""
    problems: list[str] = []
    out = {}
    for doc, text in texts.items():
        def swap(m: re.Match[str], doc: str = doc) -> str:
            row = [c.strip() for c in m["row"].split(";")]
            body = tables.get(m["name"])
            cell = None if body is None else table_cell(body, row, m["column"])
            where = f"{m['name']}[{m['row']}][{m['column']}]"
            if cell is None:
                problems.append(f"{doc}: inline value {where}: no such table cell")
                return m.group(0)
            if m["value"] != cell and not write:
                problems.append(f"{doc}: inline value {m['value']!r} is not {where} = "
                                f"{cell!r}: run `cosim docs --only {m['name']}`")
                return m.group(0)
            return f"<!-- cosim value: {m['name']}[{m['row']}][{m['column']}] -->{cell}" \
                "<!-- end value -->"
        out[doc] = VALUE.sub(swap, text)
    return out, problems


def doc_tables(texts: dict[str, str]) -> dict[str, str]:
    """Every marked table's body as the docs hold it, by name."""
    return {name: body for text in texts.values() for name, _, body in blocks(text)}


def regenerate(names: list[str], *, check: bool, root: Path = ROOT,
               log: Callable[[str], None] = print) -> list[str]:
    """Recompute the named tables; write them into their files (check=False) or
    compare. Returns the problems found (stale tables, tables marked nowhere)."""
    stamp = commit()  # before the runs: the code they ran is the code at the start
    made = {name: TABLES[name].make() for name in names}
    problems: list[str] = []
    found: set[str] = set()
    texts: dict[str, str] = {}
    originals: dict[str, str] = {}
    for doc in DOCS:
        path = root / doc
        if not path.is_file():
            continue
        text = originals[doc] = path.read_text()

        def swap(m: re.Match[str], doc: str = doc) -> str:
            name = m["name"]
            if name not in made:
                return m.group(0)
            found.add(name)
            if check:
                if m["body"].strip() != made[name].strip():
                    problems.append(f"{doc}: table {name!r} (from commit {m['commit']}) is "
                                    f"stale: run `cosim docs --only {name}`")
                return m.group(0)
            log(f"{doc}: table {name} ({TABLES[name].command})")
            return (f"<!-- cosim docs: {name} (commit {stamp}) -->\n{made[name].strip()}\n"
                    f"<!-- end cosim docs: {name} -->")

        texts[doc] = BLOCK.sub(swap, text)
    problems += [f"table {name!r} is marked in none of {', '.join(DOCS)}"
                 for name in names if name not in found]
    # the figures in prose: against the tables just made, and the others as written
    tables = doc_tables(texts) | {name: made[name] for name in made}
    valued, value_problems = check_values(texts, tables, write=not check)
    problems += [p for p in value_problems if check or "no such" in p]
    if not check:
        from cosim.output import atomic_write_text

        for doc, new in valued.items():
            if new != originals[doc]:
                atomic_write_text(root / doc, new)
    return problems
