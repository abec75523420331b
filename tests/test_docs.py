"""README.md and docs/ as a user reads them: every `cosim` command they show is
classified (quick, slow or a synopsis with placeholders) and the quick ones run as
written; the marked result tables that are quick to make still match the code."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

# Shown commands that take minutes (or a display): named here with the reason, so
# that a new command in the docs must be classified before the suite passes.
SLOW = {
    "cosim batch scenarios/study_density.toml": "150 runs",
    "cosim batch scenarios/study_replanning.toml": "800 runs",
    "cosim batch scenarios/study_gap.toml": "1080 runs",
    "cosim batch scenarios/study_comfort.toml": "240 runs",
    "cosim batch scenarios/study_comfort.toml -o /tmp/study_comfort --workers 2": "240 runs",
    "cosim batch scenarios/study_comfort_wet.toml -o /tmp/study_comfort_wet --workers 2":
        "240 runs",
    "cosim run scenarios/traffic_medium.toml --gui": "needs a display; waits for its window",
    "cosim bench planner": "minutes: loop transcriptions",
    "cosim bench tracking": "24 runs (tests/bench/test_tracking.py runs case 5.1's four)",
    "cosim bench cosim": "three 30 s dense runs and more",
    "cosim bench batch": "a 16-run study three times",
    "cosim bench measures": "five times six 60 s dense runs (tests/bench/test_measures_bench.py)",
    "cosim bench fleet": "five dense runs with up to 100 automated vehicles and their floors",
    "cosim batch scenarios/study_replanning.toml -o results/batch/study_replanning_fixed":
        "800 runs",
    "cosim bench cosim --repeats 5 --duration 30": "ten 30 s dense runs and more",
    "cosim bench cosim --repeats 5": "five times seven 30 s runs",
    "cosim bench cosim --repeats 5 --json": "five times seven 30 s runs",
    "cosim batch scenarios/study_curved.toml": "20 runs of 60 s",
    "cosim batch scenarios/study_merge.toml": "200 runs of 40 s",
    "cosim batch scenarios/study_fundamental.toml": "24 runs of 40 s, up to 100 veh/km/lane",
    "cosim batch scenarios/study_entry.toml --densities 15,45 --seeds 1-10 --drivers mimo "
    "--workers 1": "40 runs of 25 s",
    "cosim bench fleet --avs 20": "a dense fleet run of 20 automated vehicles and its floor",
    "cosim run scenarios/traffic_jam.toml --controller sumo --fcd":
        "60 s of traffic with its fcd.xml and figures: about 20 s",
}
# A synopsis: placeholders (FILE, N, ...), alternatives ([...], a|b) or globs.
# A bare command name that needs an argument is a mention ("`cosim run`'s outputs").
PLACEHOLDER = re.compile(r"[A-Z]{2,}|\b[A-Z]\b|\.\.\.|[\[\]{}|*<>]|\bS\.toml"
                         r"|^cosim (plan|run|batch|compare)$")


def shown_commands() -> list[tuple[str, str]]:
    """(file name, command) of every `cosim ...` in a fenced block (continuation
    lines joined, comments dropped) or an inline code span, in order, once each."""
    found: dict[str, str] = {}
    for doc in DOCS:
        text = doc.read_text()
        for block in re.findall(r"```[a-z]*\n(.*?)```", text, re.S):
            for line in block.replace("\\\n", " ").splitlines():
                line = line.split(" # ")[0].split("  #")[0].strip()
                for part in line.split("&&"):
                    part = " ".join(part.split())
                    if part.startswith("cosim "):
                        found.setdefault(part, doc.name)
        prose = re.sub(r"```.*?```", "", text, flags=re.S)
        for span in re.findall(r"`(cosim [^`]+)`", prose):
            found.setdefault(" ".join(span.split()), doc.name)
    return [(doc, cmd) for cmd, doc in found.items()]


def rewrites_docs(command: str) -> bool:
    """`cosim docs` without --check rewrites README and docs/: shown, never run here
    (test_quick_tables_match_the_code checks what it would write)."""
    return command.startswith("cosim docs") and "--check" not in command


def quick_commands() -> list[str]:
    return [cmd for _, cmd in shown_commands()
            if cmd not in SLOW and not PLACEHOLDER.search(cmd) and not rewrites_docs(cmd)]


def test_every_shown_command_is_classified() -> None:
    commands = [cmd for _, cmd in shown_commands()]
    assert len(commands) > 20  # the parser finds the docs' commands
    assert all(cmd in commands for cmd in SLOW), [c for c in SLOW if c not in commands]
    assert "cosim run scenarios/paper_case1_overtaking.toml" in quick_commands()
    assert "cosim docs --only track_cases" in commands
    assert not any(cmd.startswith("cosim docs") for cmd in quick_commands())


# Commands that start worker processes run as a process of their own; the others run in
# this test process (`cosim.cli.main`, the console script's function), which has numpy,
# SUMO and the compiled loops loaded already: 0.7-1.5 s of CPU a command instead of 3-4.
OWN_PROCESS = ("cosim batch",)


@pytest.mark.parametrize("command", quick_commands())
def test_quick_command_runs_as_written(command: str, tmp_path: Path,
                                       monkeypatch: pytest.MonkeyPatch,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    """Run exactly as the docs show it, through this checkout's package, from a
    temporary folder that holds the checkout's inputs (scenarios/, networks/, tests/
    linked), so that the outputs go where the docs say (results/... under the current
    folder) and never into the user's results/."""
    argv = shlex.split(command)[1:]
    for name in ("scenarios", "networks", "tests"):
        (tmp_path / name).symlink_to(ROOT / name)
    if command.startswith(OWN_PROCESS):
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        done = subprocess.run([sys.executable, "-m", "cosim.cli", *argv], cwd=tmp_path,
                              env=env, capture_output=True, text=True, timeout=240)
        status, stderr = done.returncode, done.stderr
    else:
        from cosim.cli import main

        monkeypatch.chdir(tmp_path)
        status, stderr = main(argv), capsys.readouterr().err
    assert status == 0, f"{command}\n{stderr[-2000:]}"
    assert "Traceback" not in stderr


def test_quick_tables_match_the_code() -> None:
    """The tables `cosim docs --quick` makes (tau sets, Table 2, the paper's cases tracked)
    are the code's."""
    from cosim.docs_tables import TABLES, regenerate

    quick = [name for name, table in TABLES.items() if table.quick]
    assert quick and regenerate(quick, check=True, log=lambda _: None) == []


def test_stale_table_is_found(tmp_path: Path) -> None:
    from cosim.docs_tables import regenerate

    (tmp_path / "README.md").write_text(
        "<!-- cosim docs: table2 (commit old) -->\n| stale |\n<!-- end cosim docs: table2 -->\n")
    problems = regenerate(["table2"], check=True, root=tmp_path, log=lambda _: None)
    assert len(problems) == 1 and "stale" in problems[0] and "commit old" in problems[0]
    assert regenerate(["table2"], check=False, root=tmp_path, log=lambda _: None) == []
    assert regenerate(["table2"], check=True, root=tmp_path, log=lambda _: None) == []
    text = (tmp_path / "README.md").read_text()
    assert "| paper MIMO (veDYNA) |" in text and "(commit old)" not in text


def test_markdown_tables_have_as_many_cells_in_every_row() -> None:
    """An unescaped `|` in a cell (mimo | siso, |ay|) splits it into a column too many."""
    for doc in DOCS:
        columns = None
        for number, line in enumerate(doc.read_text().splitlines(), 1):
            if not line.startswith("|"):
                columns = None
                continue
            cells = len(re.findall(r"(?<!\\)\|", line))
            columns = columns or cells
            assert cells == columns, f"{doc.name}:{number}: {line[:80]}"


def test_prose_figures_match_their_tables() -> None:
    """Figures in the text quoted from a marked table (`<!-- cosim value: ... -->`) are
    that table's cells: `cosim docs --check` fails otherwise (0.27 m stayed in the text
    after the table said 0.09 m)."""
    from cosim.docs_tables import DOCS, check_values, doc_tables

    texts = {d: (ROOT / d).read_text() for d in DOCS}
    assert sum(t.count("<!-- cosim value:") for t in texts.values()) >= 6
    assert check_values(texts, doc_tables(texts), write=False)[1] == []


def test_stale_prose_figure_is_found_and_rewritten(tmp_path: Path) -> None:
    from cosim.docs_tables import regenerate, table_cell

    table = ("<!-- cosim docs: run_outcomes (commit old) -->\n"
             "| case | driver | min gap (m) |\n|---|---|---|\n| 5.1 | MIMO | 0.09 |\n"
             "| | SUMO-native | 10.09 |\n<!-- end cosim docs: run_outcomes -->\n")
    assert table_cell(table, ["5.1", "SUMO-native"], "min gap (m)") == "10.09"
    assert table_cell(table, ["5.2"], "min gap (m)") is None
    stale = "passes <!-- cosim value: run_outcomes[5.1; MIMO][min gap (m)] -->0.27" \
        "<!-- end value --> m behind\n"
    (tmp_path / "README.md").write_text(table + stale)
    problems = regenerate([], check=True, root=tmp_path, log=lambda _: None)
    assert len(problems) == 1 and "'0.27'" in problems[0] and "'0.09'" in problems[0]
    assert regenerate([], check=False, root=tmp_path, log=lambda _: None) == []
    assert "-->0.09<!-- end value --> m behind" in (tmp_path / "README.md").read_text()
    (tmp_path / "README.md").write_text(table + stale.replace("MIMO", "SISO"))
    assert "no such table cell" in regenerate([], check=True, root=tmp_path,
                                              log=lambda _: None)[0]
