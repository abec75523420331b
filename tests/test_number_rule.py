"""One rule for the numbers of every declared key: finite, and either 0 or at least a
least meaningful magnitude: the smallest normal float for every number (a subnormal one
is no quantity, and SUMO cannot read it), one shortest SUMO step (0.001 s) for a time,
0.01 km/h for a speed; a run's duration and its traffic's lane-change duration at least
one step of the scenario. Each refusal is one line with the allowed range; nothing
runs."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path
from typing import Any

import pytest

from cosim.cli import main
from cosim.errors import InputError
from cosim.scenario import NESTED, TABLES, scenario_from_dict

BASE = Path(__file__).resolve().parent / "bad_inputs" / "base.toml"
DOC = tomllib.loads(BASE.read_text())


def _with(table: str, key: str, value: Any) -> dict[str, Any]:
    doc = copy.deepcopy(DOC)
    if table == "tv":
        doc["tv"][0][key] = value
    else:
        doc.setdefault(table, {})[key] = value
    return doc


FLOAT_KEYS = [(table, f.key) for table, specs in TABLES.items() for f in specs
              if f.kind is float and f.parse is None]


@pytest.mark.parametrize(("table", "key"), FLOAT_KEYS)
def test_every_number_key_refuses_a_subnormal_value(table: str, key: str) -> None:
    with pytest.raises(InputError) as info:
        scenario_from_dict(_with(table, key, 5e-324), path=BASE)
    assert info.value.key == (f"tv[0].{key}" if table == "tv" else f"{table}.{key}")
    assert "\n" not in str(info.value)


def test_nested_tables_hold_the_rule_too() -> None:
    doc = copy.deepcopy(DOC)
    doc["tv"][0]["lane_change"]["tau_s"] = 1e-310
    with pytest.raises(InputError,
                       match=r"tv\[0\]\.lane_change\.tau_s = 1e-310: .*\[0\.001, 60\] s"):
        scenario_from_dict(doc, path=BASE)
    assert {f.key for f in NESTED["tv.lane_change"]} >= {"tau_s"}


# (table, key, value, what the line must say is allowed)
CASES = [
    ("traffic", "lanechange_duration_s", 5e-324, "0 or a finite number in [0.001, 20] s"),
    ("traffic", "lanechange_duration_s", 0.01,
     "0 (instant) or at least one step, scenario.step_s = 0.05 s"),
    ("tv", "speed_kmh", 1e-320, "0 or a finite number in [0.01, 250] km/h"),
    ("sv", "speed_kmh", 0.001, "a finite number in [0.01, 250] km/h"),
    ("scenario", "duration_s", 5e-324, "a finite number in [0.001, 3600] s"),
    ("scenario", "duration_s", 0.02, "at least one step, scenario.step_s = 0.05 s"),
    ("v2v", "noise_position_m", 5e-324, "in [0, 10] m (0 or at least 2.23e-308 in magnitude"),
]


def _text_with(table: str, key: str, value: float) -> str:
    """base.toml with `key = value` in its [table] (the first [[tv]] for "tv")."""
    lines = BASE.read_text().splitlines()
    header = "[[tv]]" if table == "tv" else f"[{table}]"
    if header not in lines:
        lines += ["", header]
    start = lines.index(header) + 1
    end = next((i for i in range(start, len(lines)) if lines[i].startswith("[")), len(lines))
    found = [i for i in range(start, end) if lines[i].split("=")[0].strip() == key]
    if found:
        lines[found[0]] = f"{key} = {value!r}"
    else:
        lines.insert(start, f"{key} = {value!r}")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize(("table", "key", "value", "allowed"), CASES)
def test_meaningless_numbers_are_refused_in_one_line(
        table: str, key: str, value: float, allowed: str, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    scenario = tmp_path / "s.toml"
    scenario.write_text(_text_with(table, key, value))
    out = tmp_path / "out"
    assert main(["run", str(scenario), "--out", str(out), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"{table if table != 'tv' else 'tv[0]'}.{key} = " in err, err
    assert allowed in err, err
    assert not out.exists()
